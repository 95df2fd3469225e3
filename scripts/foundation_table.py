#!/usr/bin/env python3
"""The first results table: `overlap run` for each algorithm, scene and n.

Runs every combination one after another (never in parallel, so runs do not
compete for cores), physics only (--no-tasks, as the paper measures), keeps each run's summary.json under --work, and writes
one CSV row per run plus a Markdown table of median per-frame times with
each algorithm's broadphase and total time as a ratio to bf's in the same
(scene, n).  Resumable: a run whose summary.json exists is not redone.

  scripts/foundation_table.py --frames 256 --out docs/results/foundation
"""
import argparse
import csv
import pathlib
import sys
import time

from overlap_runs import add_table_arguments, results_header, run_summary

COLUMNS = ["update_ms", "broadphase_ms", "narrowphase_ms", "solver_ms", "integrate_ms", "total_ms"]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_table_arguments(parser, algos="bf,sap,bvh", scenes="1,2,3,4", frames=256,
                        name="foundation")
    args = parser.parse_args()

    algos = args.algos.split(",")
    runs = [(s, n, a) for s in map(int, args.scenes.split(","))
            for n in map(int, args.objects.split(",")) for a in algos]
    rows = []
    started = time.monotonic()
    for done, (scene, n, algo) in enumerate(runs):
        folder = pathlib.Path(args.work) / f"s{scene}_n{n}_{algo}"
        summary = run_summary(args.overlap, folder,
                              ["--scene", str(scene), "--objects", str(n), "--algo", algo,
                               "--frames", str(args.frames), "--no-tasks"])
        rows.append(summary)
        elapsed = time.monotonic() - started
        print(f"[{done + 1}/{len(runs)}] scene {scene} n {n} {algo}: "
              f"{summary['timings_ms']['total_ms']['median']:.1f} ms/frame, "
              f"{elapsed:.0f} s elapsed", file=sys.stderr)

    out = pathlib.Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with open(out.with_suffix(".csv"), "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["scene", "objects", "algo", "frames", "substeps"]
                        + [f"{c}_median" for c in COLUMNS] + [f"{c}_mean" for c in COLUMNS]
                        + ["pairs_median", "escaped_max", "sunk_max", "max_penetration"])
        for r in rows:
            p, t, c = r["parameters"], r["timings_ms"], r["counts"]
            writer.writerow([p["scene"], p["objects"], p["algorithm"], p["frames"], p["substeps"]]
                            + [f"{t[c]['median']:.4f}" for c in COLUMNS]
                            + [f"{t[c]['mean']:.4f}" for c in COLUMNS]
                            + [c["pairs"]["median"], c["escaped"]["max"], c["sunk"]["max"],
                               f"{c['max_penetration']['max']:.3f}"])

    machine = rows[0]["machine"]
    baseline = {(r["parameters"]["scene"], r["parameters"]["objects"]): r["timings_ms"]
                for r in rows if r["parameters"]["algorithm"] == "bf"}
    lines = results_header(f"Foundation results: {len(runs)} runs of `overlap run`, "
                           f"{args.frames} frames each", machine, args.work) + [
             "Median per-frame milliseconds over the run; `(upd+bp)/bf` is update plus "
             "broadphase, and `total/bf` the whole frame, divided by bf's in the same scene "
             "and n (SAP and DBVT do most of their work while the AABBs are updated, so "
             "update and broadphase are compared together).",
             "",
             "| scene | n | algo | substeps | update | broadphase | narrowphase | solver | total "
             "| (upd+bp)/bf | total/bf | pairs | escaped | sunk max | max pen. |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        p, t, c = r["parameters"], r["timings_ms"], r["counts"]
        base = baseline.get((p["scene"], p["objects"]))
        def ratio(columns):
            if not base:
                return ""
            ours = sum(t[col]["median"] for col in columns)
            return f"{ours / sum(base[col]['median'] for col in columns):.2f}"
        lines.append(
            f"| {p['scene']} | {p['objects']} | {p['algorithm']} | {p['substeps']} "
            f"| {t['update_ms']['median']:.2f} | {t['broadphase_ms']['median']:.2f} "
            f"| {t['narrowphase_ms']['median']:.2f} | {t['solver_ms']['median']:.2f} "
            f"| {t['total_ms']['median']:.1f} | {ratio(('update_ms', 'broadphase_ms'))} | {ratio(('total_ms',))} "
            f"| {c['pairs']['median']:.0f} | {c['escaped']['max']:.0f} | {c['sunk']['max']:.0f} "
            f"| {c['max_penetration']['max']:.2f} |")
    out.with_suffix(".md").write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
