"""Shards at once: two `scripts/study.py --shard i/2` processes started together into one
--out must both finish with every job's result there, nothing lost.

The smallest study that touches every path shards share: a sweep with a GPU
algorithm in each shard's share (each shard probes for a GPU), and the pairs
experiment split across the shards (both need the one recorded stream and bf's
pairs); both then write the tables and the report, and the invocation log.
Exit 77 (ctest's skip) when this interpreter has no matplotlib.
"""
import json
import pathlib
import subprocess
import sys

from check_quick import STUDY, arguments_or_skip, check, rows

# Jobs in plan order: sweep bf, bvh, gpubf at 80, then at 120; pairs bf, cpubf.  The sweep
# at each n is one group (its algorithms are compared), so one shard takes the 120 boxes and
# the other the 80, each with a gpubf run (each probes for a GPU); the pairs jobs go to the
# lighter one.
OBJECTS, ALGOS, PAIRS_ALGOS = [80, 120], ["bf", "bvh", "gpubf"], ["bf", "cpubf"]
SMALLEST = ["--quick", "--threads", "1", "--experiments", "sweep,pairs", "--scenes", "1",
            "--objects", ",".join(map(str, OBJECTS)), "--algos", ",".join(ALGOS),
            "--frames", "3", "--figure-objects", "80", "--pairs-objects", "80",
            "--pairs-frames", "3", "--pairs-algos", ",".join(PAIRS_ALGOS)]
SHARDS = 2


def run_shards(args, study_out) -> None:
    # No emulation build: the GPU jobs stay pending here, the same in every build tree.
    common = [sys.executable, str(STUDY), "--overlap", args.overlap, "--emulation",
              str(args.out / "no-emulation"), "--out", str(study_out), *SMALLEST]
    shards = [subprocess.Popen([*common, "--shard", f"{i}/{SHARDS}"], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True) for i in range(1, SHARDS + 1)]
    outputs = [shard.communicate() for shard in shards]
    for i, (shard, (_, stderr)) in enumerate(zip(shards, outputs), start=1):
        check(shard.returncode == 0, f"shard {i}/{SHARDS} exited {shard.returncode}:\n{stderr}")
        check(f"shard {i}/{SHARDS}:" in stderr, f"shard {i}/{SHARDS} did not plan:\n{stderr}")


def expected_runs(study_out) -> set:
    """The sweep runs this machine runs: the GPU jobs wherever its `overlap` has a device
    (the CUDA emulation's too, the sanitizer builds), none without one."""
    summaries = sorted((study_out / "sweep").glob("*/summary.json"))
    check(bool(summaries), "no sweep run finished")
    gpu = json.loads(summaries[0].read_text())["machine"]["gpu"]
    has_gpu = not gpu.startswith("none")
    return {f"s1_n{n}_{a}_r0" for n in OBJECTS for a in ALGOS if has_gpu or a != "gpubf"}


def check_log(study_out) -> None:
    log = json.loads((study_out / "study_invocations.json").read_text())
    check(len(log) == SHARDS and all(entry["finished"] for entry in log),
          f"the invocation log holds {len(log)} entries, expected {SHARDS} finished:\n{log}")
    check(sorted(entry["argv"][-1] for entry in log) ==
          [f"{i}/{SHARDS}" for i in range(1, SHARDS + 1)], "the log lost a shard's entry")


def main() -> int:
    args = arguments_or_skip()
    if args is None:
        return 77
    study_out = args.out / "study"
    run_shards(args, study_out)
    expected = expected_runs(study_out)
    done = {path.parent.name for path in (study_out / "sweep").glob("*/summary.json")}
    check(done == expected, f"sweep runs {sorted(done)}, expected {sorted(expected)}")
    for algo in PAIRS_ALGOS:
        check((study_out / "pairs" / f"{algo}.csv").exists(), f"pairs/{algo}.csv is missing")
    # The report written last read every shard's results.
    tables = study_out / "report"
    recorded = {pathlib.Path(run["folder"]).name for run in rows(tables / "sweep_runs.csv")}
    check(recorded == expected, f"sweep_runs.csv holds {sorted(recorded)}")
    check({p["algo"] for p in rows(tables / "pairs.csv")} == set(PAIRS_ALGOS),
          "pairs.csv lacks a shard's pairs")
    check_log(study_out)
    report = (study_out / "REPORT.md").read_text()
    check("What ran beside what: " in report and "never ran at once" in report,
          "the report does not say that the runs compared with each other ran apart")
    left = [p.name for p in study_out.rglob("*") if "partial" in p.name or "probe" in p.name]
    check(not left, f"temporaries left in --out: {left}")
    print(f"study.shards: {SHARDS} shards at once, all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
