#!/usr/bin/env python3
"""cpusap against cpubf and Bullet's broadphases on recorded scene-4 streams (issue 13).

Runs overlap_bench_broadphase once, every algorithm in one process on the same
streams (scene 4, seed 42, 64 frames: each n's median ms per frame over the 56
frames after 8 of warm-up, the search, the deltas and Bullet's pair-cache
update included), and writes OUT.csv and OUT.json (the benchmark's own, with
the load average before and after the run added) and OUT.md: the table, the
ratios measured in this one run, the issue's targets, and the peers' figures
the issue quotes.  Take it in a quiet window: the load average is in OUT.md.

  scripts/cpusap_table.py --streams /work/streams   # about 10 minutes on 2 cores
  scripts/cpusap_table.py --no-run                  # OUT.md again from OUT.json
  scripts/cpusap_table.py --stub                    # OUT.md before any run
"""
import argparse
import json
import os
import pathlib
import subprocess
import sys

from overlap_runs import results_header

TARGETS_MS = {3500: 0.6, 10000: 2.5, 30000: 10.5}
SHOWN = ["cpusap", "cpubf", "sap", "bvh"]

PEERS = """\
Peers, as issue 13 quotes them: each algorithm's median ms per frame over 56
frames after 8 of warm-up on the same streams, the peers timed by the
Broadmark collection's own code compiled for this machine (their timings
cover the search and its pair list, not Bullet's pair cache), ours by
`overlap_bench_broadphase`; load average below 0.5 before each batch.

| n | best peer, 2 threads | best peer, 1 thread | SAP AVX, 1 thread | KD tree, 1 thread | Grid 2D + SAP, 2 threads | Bullet `sap` | Bullet `bvh` | ours `cpubf` |
|---:|---:|---:|---:|---:|---:|---:|---:|---:|
| 3500 | 0.66-0.78 (SAP AVX parallel) | 0.93 (SAP AVX) | 0.93 | 1.19 | 0.80-0.90 | 3.13 | 4.24 | 1.92 |
| 10000 | 2.79 (SAP AVX parallel) | 3.78 (SAP SSE) | 3.85 | 3.80 | 3.62 | 15.0 | 23.5 | 10.5 |
| 30000 | 11.9 (SAP AVX parallel) | 15.0 (KD) | 20.3 | 15.0 | 13.2 | 127.5 | 237.7 | 84.7 |

Every exact peer found exactly cpubf's pairs on every frame (11968 per frame
at 3500, 39679 at 10000, 132234 at 30000).
"""


def load_average() -> str:
    return "%.2f %.2f %.2f" % os.getloadavg()


def bench_command(args) -> list:
    return [args.bench, "--streams", args.streams, "--out", args.out,
            "--objects", args.objects, "--algos", args.algos,
            "--big-objects", args.big_objects, "--big-algos", args.big_algos,
            "--repeats", str(args.repeats)]


def run_bench(args) -> None:
    before = load_average()
    print(f"cpusap_table: load average {before}; running {' '.join(bench_command(args))}",
          file=sys.stderr)
    failed = subprocess.run(bench_command(args)).returncode
    after = load_average()
    json_path = pathlib.Path(args.out + ".json")
    results = json.loads(json_path.read_text())
    results["load_average_before"], results["load_average_after"] = before, after
    json_path.write_text(json.dumps(results, indent=2) + "\n")
    csv_path = pathlib.Path(args.out + ".csv")
    lines = csv_path.read_text().splitlines(keepends=True)
    lines.insert(1, f"# load average (1, 5, 15 min) before the run: {before}; after: {after}\n")
    csv_path.write_text("".join(lines))
    if failed:
        raise SystemExit(f"cpusap_table: the benchmark failed (exit {failed}); see its FAIL lines")


def ms(row: dict) -> str:
    return "%.3g (%.3g-%.3g)" % (row["median_us"] / 1e3, row["min_us"] / 1e3, row["max_us"] / 1e3)


def result_lines(results: dict) -> list:
    rows = {(r["n"], r["algorithm"]): r for r in results["rows"]}
    sizes = sorted({r["n"] for r in results["rows"]})
    shown = [a for a in SHOWN if any((n, a) in rows for n in sizes)]
    lines = [f"Benchmark command: `{results['command']}` ({results['run_seconds']:.0f} s).", "",
             f"Load average (1, 5, 15 min) before the run: {results.get('load_average_before', '?')}"
             f"; after: {results.get('load_average_after', '?')}.", "",
             "Median ms per frame over the repeats (fastest-slowest repeat), each repeat the "
             f"median of its measured frames; {results['repeats']} repeats, interleaved.", "",
             "| n | " + " | ".join(f"`{a}`" for a in shown) +
             " | cpusap / sap | cpusap / cpubf | target | met | pairs |",
             "|---:|" + "---:|" * (len(shown) + 5)]
    for n in sizes:
        sap_row = rows.get((n, "cpusap"))
        ratio = lambda other: ("%.3f" % (sap_row["median_us"] / rows[(n, other)]["median_us"])
                               if sap_row and (n, other) in rows else "-")
        target = TARGETS_MS.get(n)
        met = "-" if target is None or not sap_row else (
            "yes" if sap_row["median_us"] / 1e3 <= target else "no")
        pairs = "%.0f" % sap_row["pairs_mean"] if sap_row else "-"
        lines.append(f"| {n} | " + " | ".join(ms(rows[(n, a)]) if (n, a) in rows else "-"
                                              for a in shown) +
                     f" | {ratio('sap')} | {ratio('cpubf')} | "
                     f"{'%.1f' % target if target else '-'} | {met} | {pairs} |")
    exact = [r for r in results["rows"] if r["algorithm"] == "cpusap"]
    lines += ["", "Exactness, every frame of every repeat: " + "; ".join(
        f"n = {r['n']}: " + ("the reference itself" if r["reference"] == "cpusap" else
                             f"{r['mismatched_frames']} frames differ from {r['reference']}'s")
        for r in exact) + "."]
    return lines


def write_markdown(args, results) -> None:
    machine = results["machine"] if results else None
    lines = (results_header("cpusap: exact sort-and-sweep on recorded scene-4 streams (issue 13)",
                            machine) if machine else
             ["# cpusap: exact sort-and-sweep on recorded scene-4 streams (issue 13)", ""])
    lines += ["Targets (issue 13), cpusap on this 2-core machine, search, deltas and Bullet's "
              "pair-cache update included: at most 0.6 ms per frame at n = 3500, 2.5 ms at "
              "10000, 10.5 ms at 30000.", ""]
    if results:
        lines += result_lines(results)
    else:
        lines += ["Not measured yet: the machine was shared when cpusap was written. In a quiet "
                  "window, with the streams of `overlap record --scene 4 --objects N --frames 64` "
                  "(seed 42) in STREAMS (recorded there when missing):", "",
                  "```sh",
                  "cmake --build build --target overlap_bench_broadphase",
                  "scripts/cpusap_table.py --streams STREAMS",
                  "```", "",
                  "which runs `" + " ".join(bench_command(args)) + "`."]
    lines += ["", PEERS,
              "The live loop (`overlap run`, scenes 1-4, n = 3500): `update_ms + broadphase_ms` "
              "in each run's `frames.csv`, cpusap against sap, e.g. "
              "`overlap run --scene 4 --objects 3500 --frames 64 --algo cpusap --out out/cpusap`.",
              ""]
    pathlib.Path(args.out + ".md").write_text("\n".join(lines))
    print(f"cpusap_table: wrote {args.out}.md", file=sys.stderr)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bench", default="build/overlap_bench_broadphase")
    parser.add_argument("--streams", default="out/streams", help="folder of cached streams")
    parser.add_argument("--out", default="docs/results/broadphase_cpusap",
                        help="prefix of .csv, .json and .md")
    parser.add_argument("--objects", default="500,1250,2000,2750,3500,10000,30000")
    parser.add_argument("--algos", default="sap,bvh,cpubf,cpusap")
    parser.add_argument("--big-objects", default="100000")
    parser.add_argument("--big-algos", default="cpubf,cpusap",
                        help="at --big-objects (sap holds at most 32765 boxes)")
    parser.add_argument("--repeats", type=int, default=5)
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument("--no-run", action="store_true", help="OUT.md from an existing OUT.json")
    mode.add_argument("--stub", action="store_true", help="OUT.md with no results yet")
    args = parser.parse_args()
    if args.stub:
        write_markdown(args, None)
        return 0
    if not args.no_run:
        run_bench(args)
    write_markdown(args, json.loads(pathlib.Path(args.out + ".json").read_text()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
