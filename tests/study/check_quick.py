"""Smoke test of scripts/study.py: a tiny --quick study end to end, then its outputs checked.

Checks what the study promises rather than what it measured: every planned
run has its result, the algorithm recorded is the one that ran (a GPU run on
a machine without a GPU is left for a GPU machine, never a relabelled CPU
fallback, and an emulated one is never a GPU figure), no algorithm missed an
exact pair, every figure the report shows exists with its CSV beside it where
it has one, the findings' cells are short, a second invocation redoes nothing
and regenerates the report byte for byte, --report fills a hand-written
report's blocks and keeps its prose, and a shard runs only its share, in whole
groups.  Exit 77 (ctest's skip) when this interpreter has no matplotlib.
"""
import argparse
import csv
import importlib.util
import json
import pathlib
import re
import shutil
import subprocess
import sys

STUDY = pathlib.Path(__file__).resolve().parents[2] / "scripts" / "study.py"
SCENES, OBJECTS, ALGOS = [1, 4], [80, 120], ["bf", "bvh", "cpubf", "gpubf"]
SUBSTEPS = ["1", "auto"]  # fixed K x --ccd off|auto|all, auto x --ccd off|auto
TINY = ["--quick", "--threads", "1", "--scenes", ",".join(map(str, SCENES)),
        "--objects", ",".join(map(str, OBJECTS)), "--algos", ",".join(ALGOS),
        "--frames", "4", "--figure-objects", "120",
        "--pairs-objects", "120", "--pairs-frames", "4",
        "--physics-scenes", "1,4", "--physics-objects", "120", "--physics-frames", "4",
        "--physics-substeps", ",".join(SUBSTEPS),
        "--latency-scenes", "1,4", "--latency-objects", "120", "--latency-frames", "4",
        "--latency-algos", "bvh,cpubf", "--timeline-objects", "120", "--timeline-frames", "4",
        "--overlap-objects", "80", "--overlap-loads", "0,1", "--overlap-frames", "3",
        "--ideal-objects", "80", "--ideal-frames", "3"]


def rows(path: pathlib.Path) -> list:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def study(overlap: str, out: pathlib.Path, *extra: str) -> subprocess.CompletedProcess:
    command = [sys.executable, str(STUDY), "--overlap", overlap, "--out", str(out), *TINY, *extra]
    result = subprocess.run(command, capture_output=True, text=True)
    if result.returncode != 0:
        sys.exit(f"FAIL: {' '.join(command)} exited {result.returncode}:\n{result.stderr}")
    return result


def check(condition: bool, message: str) -> None:
    if not condition:
        sys.exit("FAIL: " + message)


def arguments_or_skip():
    """--overlap and --out (emptied), or None after saying why the test skips: this
    interpreter has no matplotlib, which the study's figures need."""
    parser = argparse.ArgumentParser(allow_abbrev=False)
    parser.add_argument("--overlap", required=True)
    parser.add_argument("--out", type=pathlib.Path, required=True)
    args = parser.parse_args()
    if importlib.util.find_spec("matplotlib") is None:
        print(f"SKIP: {sys.executable} has no matplotlib (install python3-matplotlib)")
        return None
    shutil.rmtree(args.out, ignore_errors=True)
    return args


HAND_WRITTEN = """# A report kept by hand

Prose before the findings.

<!-- generated:findings -->
stale text the study replaces
<!-- /generated:findings -->

A hand-written finding about the sweep, which the study never rewrites.

<!-- generated:stages -->
<!-- /generated:stages -->
"""


def check_hand_written(args) -> None:
    """--report fills the blocks of a hand-written report and keeps its prose; a marker
    naming no block is refused, naming the marker, and the report is left as it was."""
    doc = args.out / "hand" / "REPORT.md"
    doc.parent.mkdir()
    doc.write_text(HAND_WRITTEN)
    # The sweep's blocks alone (the others say "not run"): the fill is what is checked.
    only_sweep = ["--experiments", "sweep", "--no-runs", "--report", "--report-doc", str(doc)]
    study(args.overlap, args.out, *only_sweep)
    filled = doc.read_text()
    check("stale text" not in filled
          and "| claim | verdict | figure | runs a cell | machine | section |"
          in filled, "--report did not fill the findings block")
    check("A hand-written finding about the sweep, which the study never rewrites." in filled
          and filled.index("generated:findings") < filled.index("A hand-written finding"),
          "--report moved or lost the hand-written prose")
    check((doc.parent / "report" / "fig_stages.png").exists(),
          "--report did not copy the figures beside the report")
    doc.write_text(filled + "\n<!-- generated:section_that_went -->\n"
                   "<!-- /generated:section_that_went -->\n")
    command = [sys.executable, str(STUDY), "--overlap", args.overlap, "--out", str(args.out),
               *TINY, *only_sweep]
    stale = subprocess.run(command, capture_output=True, text=True)
    check(stale.returncode == 1 and "section_that_went" in stale.stderr
          and doc.read_text().endswith("<!-- /generated:section_that_went -->\n"),
          f"a marker naming no block was not refused (exit {stale.returncode}):\n{stale.stderr}")


def check_sweep(args, tables: pathlib.Path) -> bool:
    """The sweep's runs are the ones planned, each recorded as the algorithm that ran;
    returns whether this machine has a GPU."""
    runs = rows(tables / "sweep_runs.csv")
    gpu = json.loads(next((args.out / "sweep").glob("*/summary.json")).read_text())
    has_gpu = not gpu["machine"]["gpu"].startswith("none")
    expected = len(SCENES) * len(OBJECTS) * (len(ALGOS) - (0 if has_gpu else 1))
    check(len(runs) == expected, f"sweep_runs.csv has {len(runs)} runs, expected {expected}")
    for run in runs:
        check(run["algorithm"] == run["algo_requested"],
              f"a {run['algo_requested']} run is recorded as {run['algorithm']}")
    report = (args.out / "REPORT.md").read_text()
    if not has_gpu:
        check("Needs a real GPU, so not in this report" in report, "no GPU here, yet the "
              "report does not say what it leaves for a GPU machine")
    # No GPU, or the CUDA emulation (its times are the CPU's): no GPU figure either way.
    if not has_gpu or "emulation" in gpu["machine"]["gpu"]:
        check("not run: needs a GPU" in report, "the paper's claims quote a GPU figure")
    # Committed reports name no path of the machine they were made on.
    for local in (str(args.out.resolve()), str(STUDY.parents[1])):
        check(local not in report, f"the report names the local path {local}")
        check(all(local not in run["folder"] for run in runs),
              f"sweep_runs.csv names the local path {local}")
    return has_gpu


def check_figures(args, tables: pathlib.Path, report: str) -> None:
    findings = report.split("## Findings")[1].split("\n## ")[0]
    cells = [c.strip() for line in findings.splitlines() if line.startswith("| ")
             for c in line.strip("|").split("|")]
    check(max(map(len, cells)) <= 160, f"a findings cell of {max(map(len, cells))} characters")
    for image in re.findall(r"\]\(report/([^)]+)\)", report):
        for suffix in (".png", ".svg"):
            path = tables / pathlib.Path(image).with_suffix(suffix)
            check(path.exists(), f"the report shows {image} but {path} is missing")
    # Broadphases are compared on update + broadphase (SAP's work is in the update).
    check("update + broadphase (compare these)" in (tables / "fig5_scene4_per_frame.svg")
          .read_text(), "Figures 2-5 lack the update + broadphase panel")
    for figure in ("fig1_keyframes", "fig6_total_against_n", "fig_stages", "fig_timeline",
                   "fig_physics", "fig_latency", "fig_broadphase_error", "fig_overlap"):
        check(f"report/{figure}.png" in report, f"the report lacks {figure}")
    for data in ("fig5_scene4_per_frame.csv", "fig_timeline.csv", "stages.csv"):
        check((tables / data).exists(), f"the figures' data {data} is missing")


def check_pairs(tables: pathlib.Path) -> None:
    pairs = rows(tables / "pairs.csv")
    check({p["algo"] for p in pairs} == {"bf", "sap", "sap32", "bvh", "cpubf", "cpusap"},
          f"pairs.csv holds {sorted(p['algo'] for p in pairs)}")
    check(all(p["missed"] == "0" for p in pairs), "an algorithm missed exact pairs")


def check_errors(tables: pathlib.Path, report: str) -> None:
    """Pairs, physics and latency: every cell planned is in its CSV."""
    check_pairs(tables)
    physics = rows(tables / "physics.csv")
    # Per scene 3 fixed-K runs and 2 automatic ones, scene 1 (it sleeps) once more without
    # sleep; the old fixed K (2 and 8) x ccd off|auto x solver pile|bullet; at seed 7 those
    # 4 and the 2 automatic ones again.
    check(len(physics) == 2 * 5 + 1 + 2 * 4 + 2 * 6,
          f"physics.csv has {len(physics)} runs, expected 31")
    check({(r["scene"], r["substeps"], r["solver"]) for r in physics if r["solver"] == "bullet"}
          == {("1", "2", "bullet"), ("4", "8", "bullet")}, "physics.csv lacks the old default")
    check(sum(r["seed"] == "7" for r in physics) == 12, "physics.csv lacks seed 7's runs")
    check("at every seed and size the comparison ran" in report
          and "Summed over the seeds of each size" in report,
          "the report lacks the comparison across seeds")
    check(any(r["scene"] == "1" and r["sleep_error_max_m"] not in ("", "nan") for r in physics),
          "physics.csv lacks scene 1's sleep error")
    latency = rows(tables / "latency.csv")
    check({(r["scene"], r["algo"], r["growth"]) for r in latency} ==
          {(s, a, g) for s in ("1", "4") for a in ("bvh", "cpubf") for g in ("0", "1", "2")},
          "latency.csv lacks a (scene, algo, growth)")


def check_overlap(tables: pathlib.Path, report: str) -> None:
    overlap = rows(tables / "overlap.csv")
    check({(r["scene"], r["load"]) for r in overlap} == {("1", "0"), ("1", "1"), ("4", "0"),
                                                         ("4", "1")},
          f"overlap.csv holds {sorted((r['scene'], r['load']) for r in overlap)}")
    check(all(r["identical"] == "True" for r in overlap),
          "a sync and an async run of the overlap study ended differently")
    check("## 4. The asynchronous frame" in report, "the report lacks the overlap section")


def check_shard(args, has_gpu: bool) -> None:
    """A shard runs whole groups of the runs compared with each other: every (scene, n) it
    ran with all of its algorithms (gpubf only with a GPU), and some of the groups, not all."""
    shard_out = args.out / "shard"
    sharded = study(args.overlap, shard_out, "--experiments", "sweep", "--shard", "2/3")
    ran = {path.parent.name for path in (shard_out / "sweep").glob("*/summary.json")}
    groups = {tuple(name.split("_")[:2]) for name in ran}
    runnable = [a for a in ALGOS if has_gpu or a != "gpubf"]
    check(ran == {f"{s}_{n}_{a}_r0" for s, n in groups for a in runnable},
          f"shard 2/3 ran part of a group: {sorted(ran)}:\n{sharded.stderr}")
    check(0 < len(groups) < len(SCENES) * len(OBJECTS),
          f"shard 2/3 ran {len(groups)} of {len(SCENES) * len(OBJECTS)} groups:\n{sharded.stderr}")


def main() -> int:
    args = arguments_or_skip()
    if args is None:
        return 77
    done = study(args.overlap, args.out)
    last = done.stderr.rstrip().splitlines()[-1]
    check(last.startswith(f"study: report: {args.out}/REPORT.md"),
          "the study does not end naming its report:\n" + done.stderr[-400:])
    tables = args.out / "report"
    has_gpu = check_sweep(args, tables)
    report = (args.out / "REPORT.md").read_text()
    check_figures(args, tables, report)
    check_errors(tables, report)
    check_overlap(tables, report)
    again = study(args.overlap, args.out)
    check(" 0 to run" in again.stderr, "a second invocation ran jobs again:\n" + again.stderr)
    # The report is a function of the results: regenerated, byte for byte the same.
    check((args.out / "REPORT.md").read_text() == report, "regenerating the report changed it")
    check_hand_written(args)
    check_shard(args, has_gpu)
    print("study.quick: all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
