#!/usr/bin/env python3
"""cpusap against cpubf and Bullet's broadphases on recorded scene-4 streams.

Runs overlap_bench_broadphase once, every algorithm in one process on the same
streams (scene 4, seed 42, 64 frames: each n's median ms per frame over the 56
frames after 8 of warm-up, the search, the deltas and Bullet's pair-cache
update included), and writes OUT.csv and OUT.json (the benchmark's own, with
the commit and the load average before and after the run added).  With --live
RUNS it also runs the live loop (scenes 1-4, 3500 boxes, sap and cpusap) and
writes OUT_live.csv.  docs/results/broadphase_cpusap.md says how to read them.
Take it in a quiet window: the load average is in the files.

  scripts/cpusap_table.py --streams STREAMS         # about 10 minutes on 2 cores
"""
import argparse
import csv
import json
import os
import pathlib
import statistics
import sys

from overlap_runs import portable
from script_cli import BadInput, Parser, run, run_child


def positive(text: str) -> int:
    if not text.isdigit() or int(text) < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a whole number from 1")
    return int(text)


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
    failed = run_child(bench_command(args)).returncode
    after = load_average()
    json_path = pathlib.Path(args.out + ".json")
    if failed and not json_path.exists():  # it refused its input (exit 2) or wrote nothing
        raise SystemExit(failed)
    results = json.loads(json_path.read_text())
    results["load_average_before"], results["load_average_after"] = before, after
    json_path.write_text(json.dumps(results, indent=2) + "\n")
    csv_path = pathlib.Path(args.out + ".csv")
    lines = csv_path.read_text().splitlines(keepends=True)
    lines.insert(1, f"# load average (1, 5, 15 min) before the run: {before}; after: {after}\n")
    lines.insert(1, f"# commit: {results['machine']['git_commit']}\n")
    csv_path.write_text("".join(lines))
    # The committed files name the streams' folder $STREAMS, not this machine's path.
    for path in (json_path, csv_path):
        path.write_text(portable(path.read_text(), {args.streams: "$STREAMS"}))
    if failed:
        raise SystemExit(f"cpusap_table: the benchmark failed (exit {failed}); see its FAIL lines")


LIVE_FRAMES, LIVE_WARMUP = 24, 8


def live_run_dir(runs: pathlib.Path, scene: int, algorithm: str) -> pathlib.Path:
    return runs / f"scene{scene}_{algorithm}"


def measure_live(runs: pathlib.Path) -> dict:
    """The live loop, cpusap's second target: `overlap run` at n = 3500 in scenes 1-4 with
    sap and cpusap (physics only), the median of update_ms + broadphase_ms per frame after
    the warm-up frames."""
    before = load_average()
    medians = {}
    for scene in (1, 2, 3, 4):
        for algorithm in ("sap", "cpusap"):
            out = live_run_dir(runs, scene, algorithm)
            run_child(["build/overlap", "run", "--scene", str(scene), "--objects", "3500",
                       "--frames", str(LIVE_FRAMES), "--algo", algorithm, "--no-tasks",
                       "--capture-every", "0", "--no-wav", "--out", str(out)], check=True)
            with open(out / "frames.csv") as frames:
                rows = list(csv.DictReader(frames))[LIVE_WARMUP:]
            medians[f"{scene}/{algorithm}"] = statistics.median(
                float(row["update_ms"]) + float(row["broadphase_ms"]) for row in rows)
    return {"medians_ms": medians, "load_average_before": before,
            "load_average_after": load_average(),
            "command": f"build/overlap run --scene S --objects 3500 --frames {LIVE_FRAMES} "
                       "--algo A --no-tasks --capture-every 0 --no-wav --out OUT "
                       "(S = 1..4, A = sap, cpusap)"}


def write_live(out: str, live: dict, commit: str) -> None:
    """The live loop's medians as OUT_live.csv, its provenance in its first lines."""
    medians = live["medians_ms"]
    lines = [f"# what: the live loop, the median of update_ms + broadphase_ms over frames "
             f"{LIVE_WARMUP}-{LIVE_FRAMES - 1}, physics only, the default substeps and CCD",
             f"# commit: {commit}", f"# command: {live['command']}",
             f"# load: {live['load_average_before']} before; {live['load_average_after']} after",
             "scene,sap_ms,cpusap_ms,cpusap_over_sap"]
    for scene in (1, 2, 3, 4):
        sap, ours = medians[f"{scene}/sap"], medians[f"{scene}/cpusap"]
        lines.append(f"{scene},{sap:.2f},{ours:.2f},{ours / sap:.2f}")
    pathlib.Path(out + "_live.csv").write_text("\n".join(lines) + "\n")
    print(f"cpusap_table: wrote {out}_live.csv", file=sys.stderr)


def main() -> int:
    parser = Parser(description=__doc__.splitlines()[0])
    parser.add_argument("--bench", default="build/overlap_bench_broadphase")
    parser.add_argument("--streams", default="out/streams", help="folder of cached streams")
    parser.add_argument("--out", default="docs/results/broadphase_cpusap",
                        help="prefix of .csv, .json and _live.csv")
    parser.add_argument("--objects", default="500,1250,2000,2750,3500,10000,30000")
    parser.add_argument("--algos", default="sap,bvh,cpubf,cpusap")
    parser.add_argument("--big-objects", default="100000")
    parser.add_argument("--big-algos", default="cpubf,cpusap",
                        help="at --big-objects (sap holds at most 32765 boxes)")
    parser.add_argument("--repeats", type=positive, default=5)
    parser.add_argument("--live", metavar="RUNS",
                        help="also run the live loop (scenes 1-4, n = 3500, sap and cpusap) into "
                             "the folder RUNS and write OUT_live.csv")
    args = parser.parse_args()
    if not os.access(args.bench, os.X_OK):
        raise BadInput(f"--bench {args.bench}: not an executable (build it first)")
    run_bench(args)
    if args.live:
        commit = json.loads(pathlib.Path(args.out + ".json").read_text())["machine"]["git_commit"]
        write_live(args.out, measure_live(pathlib.Path(args.live)), commit)
    return 0


if __name__ == "__main__":
    sys.exit(run(main))
