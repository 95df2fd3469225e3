#!/usr/bin/python3
"""The GPU machines' figures, read from the raw files kept in docs/results/gpu/.

Each machine has a folder of raw files as it wrote them: the H200's in
docs/results/gpu/raw/ (commit d1690ab), the H100's in docs/results/gpu/h100/raw/
(commit d5e40a4).  This script prints each machine's tables from those files
(every figure comes from a raw file, none is typed; each folder's README.md
says how to read them), and the study's findings table cites the same figures, machine by machine,
through machine_findings() while the study's own runs have no GPU.  The files:

  bench_*.csv, bench-*.csv     overlap_bench_broadphase: update + findPairs with
                               Bullet's pair cache; from d5e40a4 on, also each
                               finder's launch() to finish(), its CUDA events and calls
  probe_*.log                  (H200) the finder alone, timed by a program of that session's
  */summary.json               (H200) overlap run; */timeline.json.gz its spans (Perfetto)
  gpu_check_summary_*.txt      (H100) scripts/gpu_check.sh's step tables, whose frames
                               steps' notes are its `overlap run` medians

  scripts/gpu_results.py [--raw FOLDER]     (default: every machine's)
"""
import argparse
import gzip
import json
import pathlib
import re
import statistics
import sys

from results_files import read_csv
from script_cli import Parser, run
from study_targets import Target

REPO = pathlib.Path(__file__).resolve().parent.parent
RESULTS = REPO / "docs" / "results" / "gpu"
RAW = RESULTS / "raw"
MACHINES = (RESULTS / "h100" / "raw", RAW)  # newest first: the claims table cites them so
FINDERS = ("cpubf", "cpusap", "gpubf", "gpubf-paper")
BENCH_ALGOS = ("sap", "bvh", "cpubf", "cpusap", "gpubf", "gpubf-paper", "gpusap")
GPU_FINDERS = ("gpubf", "gpubf-paper", "gpusap")
FRAME_RUNS = (("demo", "demo (`overlap run`, 1000 boxes)"),
              ("async_gpubf", "3500 boxes, task load 1, `--compare-sync`"),
              ("async_cpusap", "3500 boxes, task load 1, `--compare-sync`"))


def bench_files(raw: pathlib.Path, suffix: str) -> list:
    """The benchmark's files, the paper's sizes first (bench_paper, bench-paper, then the
    larger sizes in the order of their names)."""
    files = sorted(raw.glob(f"bench[-_]*.{suffix}"))
    return sorted(files, key=lambda path: "paper" not in path.name)


def raw_folder(text: str) -> pathlib.Path:
    """argparse type: a GPU machine's raw folder (its benchmark's bench_*.json in it)."""
    path = pathlib.Path(text)
    if not path.is_dir() or not bench_files(path, "json"):
        raise argparse.ArgumentTypeError(
            f"{text!r}: not a GPU machine's raw folder (no bench_*.json in it)")
    return path


def machine(raw: pathlib.Path = RAW) -> dict:
    """The GPU machine as its benchmark recorded it (GPU, CPU, threads, commit)."""
    return json.loads(bench_files(raw, "json")[0].read_text())["machine"]


def finder_rows(raw: pathlib.Path = RAW) -> list:
    return [row for path in sorted(raw.glob("probe_*.log")) for row in read_csv(path)]


def bench_rows(raw: pathlib.Path = RAW) -> list:
    return [row for path in bench_files(raw, "csv") for row in read_csv(path)]


def bench_median_us(raw: pathlib.Path = RAW) -> dict:
    """{(n, algorithm): median µs per frame} of the benchmark."""
    return {(int(r["n"]), r["algorithm"]): float(r["median_us"]) for r in bench_rows(raw)}


def frame_summary(run: str, raw: pathlib.Path = RAW) -> dict:
    return json.loads((raw / run / "summary.json").read_text())


def checked_frames(raw: pathlib.Path = RAW) -> list:
    """The frames steps of gpu_check's step tables (gpu_check_summary_*.txt) that passed:
    [{step, algo, frame, physics, broadphase, speedup, same_state, state}], medians in ms."""
    pattern = re.compile(r"^(frames-\S+)\s+pass\s.*ran (\S+); frame ([\d.]+) ms, physics ([\d.]+), "
                         r"broadphase ([\d.]+); state (\w+)(?:; sync/async ([\d.]+), same state "
                         r"(\w+))?")
    runs = []
    for path in sorted(raw.glob("gpu_check_summary_*.txt")):
        for line in path.read_text().splitlines():
            m = pattern.match(line)
            if m:
                runs.append({"step": m[1], "algo": m[2], "frame": float(m[3]),
                             "physics": float(m[4]), "broadphase": float(m[5]), "state": m[6],
                             "speedup": float(m[7]) if m[7] else None,
                             "same_state": m[8] == "True"})
    return runs


def search_span_us(run: str, raw: pathlib.Path = RAW):
    """The median of the timeline's search spans (one per substep), µs; None without a trace."""
    path = raw / run / "timeline.json.gz"
    if not path.exists():
        return None
    trace = json.loads(gzip.decompress(path.read_bytes()))
    events = trace["traceEvents"] if isinstance(trace, dict) else trace
    return statistics.median(e["dur"] for e in events
                             if e.get("ph") == "X" and e["name"] == "search")


def cell(value) -> str:
    return "-" if value is None else f"{value:.0f}"


def table(headers: list, rows: list) -> list:
    return (["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
            + ["| " + " | ".join(map(str, row)) + " |" for row in rows])


def finder_table(raw: pathlib.Path = RAW) -> list:
    """The H200's probe program: the finder alone, launch() + finish() on the host."""
    rows = finder_rows(raw)
    if not rows:
        return []
    by = {(int(r["n"]), r["algo"]): r for r in rows}
    sizes = sorted({n for n, _ in by})
    lines = []
    for n in sizes:
        line = [n]
        for algo in FINDERS:
            row = by.get((n, algo))
            line.append(cell(float(row["host_med_us"]) if row else None))
            if algo.startswith("gpubf"):
                line.append(cell(float(row["search_med_us"]) if row else None))
        line.append(", ".join(sorted({r["exact_vs_ref"] for r in rows if int(r["n"]) == n})))
        lines.append(line)
    return table(["n", "cpubf", "cpusap", "gpubf", "gpubf events", "gpubf-paper",
                  "gpubf-paper events", "pairs against the reference"], lines)


def number(row: dict, column: str):
    value = row.get(column) if row else None
    return float(value) if value not in (None, "") else None


def launch_cells(row: dict, algo: str) -> list:
    """One finder's cells of a launch_table row: launch to finish, and for a GPU finder its
    CUDA events (upload / kernels / download) and calls."""
    cells = [cell(number(row, "launch_to_finish_us"))]
    if algo in GPU_FINDERS:
        cells.append(" / ".join(cell(number(row, c)) for c in (
            "upload_us", "kernels_us", "download_us")) if row else "-")
        cells.append(cell(number(row, "api_calls")))
    return cells


def launch_headers(algo: str) -> list:
    if algo in GPU_FINDERS:
        return [f"{algo} l2f", f"{algo} up / kern / down", f"{algo} calls"]
    return [f"{algo} l2f"]


def launch_table(raw: pathlib.Path = RAW) -> list:
    """The benchmark's own split of our finders (from d5e40a4): launch() to finish() on the
    host, and for the GPU finders their CUDA events (upload, kernels, download) and CUDA
    runtime calls a frame; µs, medians over frames, then repeats."""
    rows = [r for r in bench_rows(raw) if r.get("launch_to_finish_us")]
    if not rows:
        return []
    by = {(int(r["n"]), r["algorithm"]): r for r in rows}
    algos = [a for a in BENCH_ALGOS if any(a == algo for _, algo in by)]
    headers = ["n"] + [h for algo in algos for h in launch_headers(algo)]
    lines = [[n] + [c for algo in algos for c in launch_cells(by.get((n, algo)), algo)]
             for n in sorted({n for n, _ in by})]
    return table(headers, lines)


def bench_table(raw: pathlib.Path = RAW) -> list:
    median = bench_median_us(raw)
    algos = [a for a in BENCH_ALGOS if any(a == algo for _, algo in median)]
    sizes = sorted({n for n, _ in median})
    return table(["n", *algos], [[n, *(cell(median.get((n, a))) for a in algos)]
                                 for n in sizes])


def stopped_bench_table(raw: pathlib.Path = RAW) -> list:
    """A benchmark stopped by its step's budget writes no CSV; its log's per-repeat lines
    ("n=N repeat R/K: A X us B Y us ...") still give each repeat's median frame, µs."""
    pattern = re.compile(r"n=(\d+) repeat (\d+)/\d+: (.*) \(")
    repeats = {}
    for path in sorted(raw.glob("bench[-_]*.log")):
        for m in pattern.finditer(path.read_text()):
            for algo, us in re.findall(r"(\S+) ([\d.]+) us", m[3]):
                repeats.setdefault((int(m[1]), algo), []).append(cell(float(us)))
    algos = [a for a in BENCH_ALGOS if any(a == algo for _, algo in repeats)]
    sizes = sorted({n for n, _ in repeats})
    return table(["n", *algos], [[n, *(", ".join(repeats.get((n, a), ["-"])) for a in algos)]
                                 for n in sizes]) if repeats else []


def frame_table(raw: pathlib.Path = RAW) -> list:
    """The H200's `overlap run` folders (summary.json), or the H100's frames steps."""
    if not (raw / FRAME_RUNS[0][0] / "summary.json").exists():
        return table(["step", "algo", "frame", "physics", "broadphase", "sync/async speed-up",
                      "state hash"],
                     [[r["step"], r["algo"], f"{r['frame']:.2f}", f"{r['physics']:.2f}",
                       f"{r['broadphase']:.3f}", "-" if r["speedup"] is None else
                       f"{r['speedup']:.2f}" + (" (same state)" if r["same_state"]
                                                else " (states differ)"), r["state"]]
                      for r in checked_frames(raw)])
    rows = []
    for run, what in FRAME_RUNS:
        summary = frame_summary(run, raw)
        timings = summary["timings_ms"]
        median = {k: timings[f"{k}_ms"]["median"] for k in (
            "total", "physics", "narrowphase", "solver", "ccd_query", "broadphase", "search")}
        compare = summary.get("compare_sync")
        span = search_span_us(run, raw)
        rows.append([what, summary["parameters"]["algorithm"], f"{median['total']:.1f}",
                     f"{median['physics']:.1f}", f"{median['narrowphase']:.1f}",
                     f"{median['solver']:.1f}", f"{median['ccd_query']:.1f}",
                     f"{median['broadphase']:.2f}", f"{median['search']:.2f}", cell(span),
                     f"{compare['speedup']:.2f}" + (" (same state)" if compare["identical_state"]
                                                    else " (states differ)")
                     if compare else "-", summary["state_hash"]])
    return table(["run", "algo", "frame", "physics", "narrowphase", "solver", "CCD queries",
                  "broadphase", "search", "search span (us)", "sync/async speed-up",
                  "state hash"], rows)


def scene4_frames_ms(raw: pathlib.Path = RAW) -> list:
    """[(algorithm, median whole frame ms)] of the 3500-box, task load 1 runs, fastest first."""
    if (raw / FRAME_RUNS[0][0] / "summary.json").exists():
        frames = [(frame_summary(run, raw)["parameters"]["algorithm"],
                   frame_summary(run, raw)["timings_ms"]["total_ms"]["median"])
                  for run, _ in FRAME_RUNS[1:]]
    else:
        frames = [(r["algo"], r["frame"]) for r in checked_frames(raw) if r["speedup"] is not None]
    return sorted(frames, key=lambda pair: pair[1])


def machine_name(raw: pathlib.Path = RAW) -> str:
    """"H200" from "NVIDIA H200 (sm_90, 132 SMs)", "H100" from "NVIDIA H100 80GB HBM3 (...)"."""
    return machine(raw)["gpu"].split(" (")[0].removeprefix("NVIDIA ").split()[0]


def folder(raw: pathlib.Path) -> str:
    return raw.parent.relative_to(REPO).as_posix() + "/"


def measured(raw: pathlib.Path) -> bool:
    return bool(bench_files(raw, "csv")) if raw.is_dir() else False


def measured_elsewhere(machines=MACHINES) -> str:
    """Where the GPU finders' figures measured outside the study are, machine by machine,
    for the report; empty when no raw files are there."""
    return "; ".join(f"the {machine_name(raw)} machine's, measured outside the study at commit "
                     f"{machine(raw)['git_commit'][:7]}, are in {folder(raw)}"
                     for raw in machines if measured(raw))


def ratio_range(median: dict, algo: str, other: str, sizes: list) -> tuple:
    ratios = [median[(n, algo)] / median[(n, other)] for n in sizes
              if (n, algo) in median and (n, other) in median]
    return (min(ratios), max(ratios)) if ratios else None


def near_target(median: dict, algo: str, near: float) -> "Target":
    """Paper 2 on the benchmark: the finder's update + pairs at most `near` x sap's and
    bvh's at every size of the paper."""
    sizes = sorted({n for n, _ in median})
    ranges = {o: ratio_range(median, algo, o, sizes) for o in ("sap", "bvh")}
    name = f"{algo} near sap and bvh, broadphase alone"
    if not all(ranges.values()):
        return Target(name, "not run", None)
    return Target(name, "; ".join(f"x{lo:.2f}-x{hi:.2f} of {o}'s" for o, (lo, hi) in
                                  ranges.items()) + f" ({sizes[0]}-{sizes[-1]} boxes)",
                  all(hi <= near for lo, hi in ranges.values()))


def fastest_frame_target(raw: pathlib.Path) -> "Target":
    """Paper 3 on the frame runs: a GPU finder has scene 4's fastest whole frame."""
    frames = scene4_frames_ms(raw)
    name = "a GPU finder has the fastest whole frame in scene 4, 3500 boxes"
    if not frames:
        return Target(name, "not run", None)
    return Target(name, "median frame: " + ", ".join(f"{a} {ms:.0f} ms" for a, ms in frames),
                  frames[0][0] in GPU_FINDERS)


def share_target(raw: pathlib.Path, share: float) -> "Target":
    """The premise on the frame runs: update + broadphase as a share of the median frame."""
    name = f"update + broadphase at least {share:g}% of the frame, scene 4, 3500 boxes"
    if not (raw / FRAME_RUNS[1][0] / "summary.json").exists():
        return Target(name, "not run", None)
    shares = []
    for run, _ in FRAME_RUNS[1:]:
        timings = frame_summary(run, raw)["timings_ms"]
        part = timings["update_ms"]["median"] + timings["broadphase_ms"]["median"]
        shares.append((frame_summary(run, raw)["parameters"]["algorithm"],
                       100 * part / timings["total_ms"]["median"]))
    return Target(name, ", ".join(f"{a} {pct:.1f}%" for a, pct in shares),
                  all(pct >= share for _, pct in shares))


def machine_findings(near: float, share: float, raw: pathlib.Path = RAW) -> dict:
    """One GPU machine's figures for the findings table, each a Target of the claim it
    bears on; empty when the raw files are absent.  Only its benchmark's sizes of the
    paper (500-3500 boxes, generated scene-4 streams) count; bf is not in its benchmark,
    so the paper's first claim did not run there."""
    if not measured(raw):
        return {}
    m = machine(raw)
    median = {k: v for k, v in bench_median_us(raw).items() if k[0] <= 3500}
    rows = [("Premise: the broadphase is a large part of the frame", share_target(raw, share))]
    rows += [(f"Paper 2: GPU-BF is near SAP and BVH ({algo}, broadphase alone)",
              near_target(median, algo, near)) for algo in ("gpubf-paper", "gpubf")]
    rows.append(("Paper 3: GPU-BF does best in scene 4 (whole frame)", fastest_frame_target(raw)))
    return {"label": f"{machine_name(raw)} host", "where": folder(raw),
            "description": f"{m['gpu']}, {m['cpu']} with {m['hardware_threads']} hardware "
                           f"threads, commit {m['git_commit'][:7]}; measured outside the "
                           f"study (benchmark and frame runs, {folder(raw)}; bf not in its "
                           "benchmark)",
            "rows": [(claim, target) for claim, target in rows if target.met is not None]}


def print_machine(raw: pathlib.Path) -> None:
    m = machine(raw)
    print(f"## {folder(raw)}\n\nMachine: {m['gpu']}; {m['cpu']}, {m['hardware_threads']} "
          f"hardware threads; {m['compiler']}, {m['build_type']}, commit {m['git_commit']}.\n")
    for title, lines in (("The finder alone (probe program)", finder_table(raw)),
                         ("The finder in the benchmark: launch() to finish(), CUDA events, "
                          "calls", launch_table(raw)),
                         ("The benchmark", bench_table(raw)),
                         ("A benchmark step stopped by its budget, each repeat's median frame",
                          stopped_bench_table(raw)), ("The frame", frame_table(raw))):
        if lines:
            print(f"{title}:\n\n" + "\n".join(lines) + "\n")


def main() -> None:
    parser = Parser(description=__doc__.splitlines()[0])
    parser.add_argument("--raw", type=raw_folder, action="append",
                        help="one machine's raw folder (default: every machine's)")
    for raw in parser.parse_args().raw or MACHINES:
        print_machine(raw.resolve())


if __name__ == "__main__":
    sys.exit(run(main))
