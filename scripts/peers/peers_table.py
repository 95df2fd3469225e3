#!/usr/bin/env python3
"""Tables of a scripts/peers/time_peers.sh run: Broadmark's peers beside our cpusap.

Reads OUT_DIR/n<N>_<algorithm>.json (broadmark_driver) and
OUT_DIR/n<N>_cpusap_{a,b}.json (overlap_bench_broadphase, run before and
after the peers) and prints three markdown tables: ms per frame for every
algorithm and n; cpusap against the fastest peer (frame = update + search +
Bullet's pair-cache update; search = our sort + sweep + delta only); pairs per
frame (cpusap's exact count beside each peer's distinct and reported pairs).
Like for like with Broadmark's frame (AABBs in, full pair list out) is
cpusap's update + sort + sweep; delta (the pair list turned into changes) and
the pair-cache update are what a persistent Bullet pair cache adds.
cpusap's figure in the ratios is the slower of its two runs.  --out PREFIX
also writes PREFIX.csv and PREFIX.json (one row per n and algorithm).

Example: scripts/peers/peers_table.py OUT --out docs/results/peers_broadmark
"""
import csv
import json
import re
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from script_cli import Parser, existing_folder, run  # noqa: E402  (scripts/, one folder up)


def load(out_dir):
    """n -> {"peers": {name: row}, "cpusap": [row_a, row_b]}."""
    runs = {}
    for path in sorted(Path(out_dir).glob("n*_*.json")):
        match = re.fullmatch(r"n(\d+)_(.+)\.json", path.name)
        data = json.loads(path.read_text())
        entry = runs.setdefault(int(match.group(1)), {"peers": {}, "cpusap": []})
        if "row" in data:  # broadmark_driver
            row = dict(data["row"], machine=data["machine"], stream=Path(data["row"]["stream"]).name)
            entry["peers"][row["algorithm"]] = row
        else:  # overlap_bench_broadphase
            row = data["rows"][0]
            entry["cpusap"].append({
                "run": {"cpusap_a": "before", "cpusap_b": "after"}.get(match.group(2), match.group(2)),
                "frame_ms": row["median_us"] / 1e3,
                "update_ms": row["update_us"] / 1e3,
                "sort_ms": row["sort_us"] / 1e3,
                "sweep_ms": row["sweep_us"] / 1e3,
                "delta_ms": row["delta_us"] / 1e3,
                "cache_ms": row["cache_us"] / 1e3,
                "pairs_mean": row["pairs_mean"],
                "repeat_medians_ms": [us / 1e3 for us in row["repeat_medians_us"]],
            })
    return runs


def fmt(value, digits=3):
    return f"{value:.{digits}f}"


def main():
    parser = Parser(description=__doc__.splitlines()[0])
    parser.add_argument("out_dir", type=existing_folder)
    parser.add_argument("--out", help="also write OUT.csv and OUT.json")
    args = parser.parse_args()
    runs = load(args.out_dir)
    if not runs:
        print(f"peers_table: {args.out_dir}: no n*_*.json results", file=sys.stderr)
        return 2
    peers = sorted({name for entry in runs.values() for name in entry["peers"]},
                   key=lambda name: min(e["peers"][name]["median_ms"] for e in runs.values()
                                        if name in e["peers"]))

    print("ms per frame (median over repeats of the median measured frame)\n")
    print("| n | " + " | ".join(peers) + " | cpusap (before, after) |")
    print("|---:|" + "---:|" * (len(peers) + 1))
    for n, entry in sorted(runs.items()):
        cells = [fmt(entry["peers"][p]["median_ms"]) if p in entry["peers"] else "" for p in peers]
        cpusap = ", ".join(fmt(run["frame_ms"]) for run in entry["cpusap"])
        print(f"| {n} | " + " | ".join(cells) + f" | {cpusap} |")

    print("\ncpusap against the fastest peer (cpusap: the slower of its two runs; its phases are "
          "medians, so they need not add up to the frame)\n")
    print("| n | fastest peer | its ms | cpusap frame | update | sort | sweep | delta | pair cache "
          "| frame / peer | (update + sort + sweep) / peer |")
    print("|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    rows = []
    for n, entry in sorted(runs.items()):
        best = min(entry["peers"].values(), key=lambda row: row["median_ms"])
        ours = max(entry["cpusap"], key=lambda run: run["frame_ms"])
        listed = ours["update_ms"] + ours["sort_ms"] + ours["sweep_ms"]
        print(f"| {n} | {best['algorithm']} | {fmt(best['median_ms'])} | {fmt(ours['frame_ms'])} | "
              + " | ".join(fmt(ours[k]) for k in ("update_ms", "sort_ms", "sweep_ms", "delta_ms",
                                                  "cache_ms"))
              + f" | {fmt(ours['frame_ms'] / best['median_ms'], 2)} | "
              f"{fmt(listed / best['median_ms'], 2)} |")
        for run in entry["cpusap"]:
            rows.append(dict(run, n=n, algorithm=f"cpusap ({run['run']})", median_ms=run["frame_ms"],
                             distinct_pairs_mean=run["pairs_mean"]))
        for row in entry["peers"].values():
            rows.append(dict(row, load_average_before=row["machine"]["load_average_before"],
                             load_average_after=row["machine"]["load_average_after"]))

    print("\npairs per measured frame: cpusap (exact) | each peer's distinct (reported, if it differs)\n")
    print("| n | cpusap | " + " | ".join(peers) + " |")
    print("|---:|---:|" + "---:|" * len(peers))
    for n, entry in sorted(runs.items()):
        cells = []
        for p in peers:
            row = entry["peers"].get(p)
            if row is None:
                cells.append("")
                continue
            cell = fmt(row["distinct_pairs_mean"], 1)
            if abs(row["pairs_mean"] - row["distinct_pairs_mean"]) > 0.05:
                cell += f" ({fmt(row['pairs_mean'], 1)})"
            cells.append(cell)
        print(f"| {n} | {fmt(entry['cpusap'][0]['pairs_mean'], 1)} | " + " | ".join(cells) + " |")

    if args.out:
        fields = ["n", "algorithm", "median_ms", "update_ms", "sort_ms", "sweep_ms", "delta_ms",
                  "cache_ms", "structures_ms", "search_ms", "pairs_mean", "distinct_pairs_mean",
                  "load_average_before", "load_average_after"]
        with open(f"{args.out}.csv", "w", newline="") as out:
            out.write("# scripts/peers/peers_table.py: ms per frame (median_ms) and its phases; "
                      "cpusap: update, sort, sweep, delta, cache (Bullet's pair-cache update); "
                      "peers: update (UpdateObjects), structures (UpdateStructures), search "
                      "(SearchOverlaps); pairs_mean: reported pairs per frame, "
                      "distinct_pairs_mean: distinct ones\n")
            writer = csv.DictWriter(out, fieldnames=fields, extrasaction="ignore")
            writer.writeheader()
            writer.writerows(rows)
        machine = {key: value for key, value in
                   next(iter(next(iter(runs.values()))["peers"].values()))["machine"].items()
                   if not key.startswith("load_average")}
        for row in rows:
            row.pop("machine", None)
        Path(f"{args.out}.json").write_text(json.dumps({"machine": machine, "rows": rows}, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(run(main, "peers_table"))
