#!/usr/bin/env python3
"""Frame time of the async loop against --sync, from `overlap run --compare-sync`.

For each algorithm, scene and n, one process runs the scene with --sync and
then with the tasks beside the broadphase, and reports both medians, the
speed-up, the overlap efficiency, and how close the async frame comes to
max(tasks, search) + the rest of the frame.  Resumable like the foundation
table; runs one after another.

  scripts/async_table.py --algos cpubf --frames 64 --out docs/results/async_cpu
"""
import argparse
import csv
import pathlib
import sys
import time

from overlap_runs import add_table_arguments, results_header, run_summary


def median(summary: dict, column: str) -> float:
    return summary["timings_ms"][column]["median"]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_table_arguments(parser, algos="cpubf", scenes="3,4", frames=64, name="async")
    args = parser.parse_args()

    runs = [(a, s, n) for a in args.algos.split(",") for s in map(int, args.scenes.split(","))
            for n in map(int, args.objects.split(","))]
    rows = []
    started = time.monotonic()
    for done, (algo, scene, n) in enumerate(runs):
        summary = run_summary(args.overlap, pathlib.Path(args.work) / f"{algo}_s{scene}_n{n}",
                              ["--scene", str(scene), "--objects", str(n), "--algo", algo,
                               "--frames", str(args.frames), "--compare-sync"])
        compare = summary["compare_sync"]
        # The frame the async loop should approach: the longer of the tasks and
        # the search, then everything else the frame does one thing at a time.
        rest = sum(median(summary, c) for c in
                   ("update_ms", "narrowphase_ms", "solver_ms", "integrate_ms"))
        bound = max(median(summary, "tasks_ms"), median(summary, "search_ms")) + rest
        rows.append({
            "algo": summary["parameters"]["algorithm"], "scene": scene, "objects": n,
            "frames": args.frames, "substeps": summary["parameters"]["substeps"],
            "sync_total_ms": compare["sync_total_ms_median"],
            "async_total_ms": compare["async_total_ms_median"],
            "speedup": compare["speedup"],
            "tasks_ms": median(summary, "tasks_ms"), "search_ms": median(summary, "search_ms"),
            "join_ms": median(summary, "join_ms"),
            "overlap_efficiency": median(summary, "overlap_efficiency"),
            "bound_ms": bound, "async_over_bound": compare["async_total_ms_median"] / bound,
            "identical_state": compare["identical_state"], "machine": summary["machine"]})
        print(f"[{done + 1}/{len(runs)}] {algo} scene {scene} n {n}: speed-up "
              f"{compare['speedup']:.3f}, {time.monotonic() - started:.0f} s elapsed",
              file=sys.stderr)

    out = pathlib.Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    columns = [c for c in rows[0] if c != "machine"]
    with open(out.with_suffix(".csv"), "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=columns, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    machine = rows[0]["machine"]
    lines = results_header(f"Async frame vs --sync: {len(runs)} runs of `overlap run "
                           f"--compare-sync`, {args.frames} frames each", machine,
                           args.work) + [
             "Medians per frame in ms. `speed-up` = sync / async total, both runs in one "
             "process. `overlap` = the share of the first substep's search that ran while a "
             "task ran. `bound` = max(tasks, search) + update + narrowphase + solver + "
             "integrate; `async/bound` near 1 means the loop hides what it can.",
             "",
             "| algo | scene | n | substeps | sync | async | speed-up | tasks | search | join "
             "| overlap | bound | async/bound | same state |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(
            f"| {r['algo']} | {r['scene']} | {r['objects']} | {r['substeps']} "
            f"| {r['sync_total_ms']:.1f} | {r['async_total_ms']:.1f} | {r['speedup']:.3f} "
            f"| {r['tasks_ms']:.2f} | {r['search_ms']:.2f} | {r['join_ms']:.2f} "
            f"| {r['overlap_efficiency']:.2f} | {r['bound_ms']:.1f} "
            f"| {r['async_over_bound']:.3f} | {r['identical_state']} |")
    out.with_suffix(".md").write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
