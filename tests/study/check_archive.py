"""The report from a GPU machine's archive: study runs made on another path by a python3
with no matplotlib (nor numpy), two shards at once, `--runs-only`; archived as the GPU
check's study returns them (./study in a .tar.xz); their folder then removed; then
`scripts/study.py --from-archive` makes the report here, in one command, with figures.

Checks that the runs needed only the standard library, that the report names the
machine that ran the runs (their summaries' machine, changed in the archive so it is
not this one), shows none of that machine's paths, draws every figure it shows, says
what ran beside what, and that runs compared with each other never ran at once.  Exit
77 (ctest's skip) when this interpreter has no matplotlib, which the figures need.
"""
import json
import os
import pathlib
import re
import shutil
import subprocess
import sys
import tarfile

from check_quick import STUDY, arguments_or_skip, check, rows

# A sweep of two groups (scene 1 at 40 and at 60 boxes, three algorithms each), scene 1's
# physics cell (its sleep-error job reads the recorded streams) and one overlap point.
SMALL = ["--quick", "--threads", "1", "--experiments", "sweep,physics,overlap",
         "--scenes", "1", "--objects", "40,60", "--algos", "bvh,cpubf,cpusap", "--frames", "3",
         "--figure-objects", "40", "--physics-scenes", "1", "--physics-objects", "40",
         "--physics-frames", "3", "--physics-substeps", "auto", "--physics-ccd", "auto",
         "--physics-seeds", "", "--overlap-scenes", "1", "--overlap-objects", "40",
         "--overlap-loads", "0,1", "--overlap-frames", "3", "--overlap-repetitions", "1",
         "--ideal-objects", "40", "--ideal-frames", "3"]
ELSEWHERE_CPU = "The GPU machine's CPU (written into the archive by this test)"


def hide(folder: pathlib.Path, *modules: str) -> None:
    """Packages that fail to import, first on PYTHONPATH: the modules are not there."""
    for module in modules:
        (folder / module).mkdir(parents=True)
        (folder / module / "__init__.py").write_text(
            f"raise ImportError('{module} is hidden by check_archive.py')\n")


def main() -> int:
    args = arguments_or_skip()
    if args is None:
        return 77
    elsewhere = args.out / "gpu-machine" / "checkout-there"
    hidden = args.out / "hidden"
    hide(hidden, "matplotlib", "numpy")
    runs_out = elsewhere / "out" / "study"
    command = [sys.executable, str(STUDY), "--overlap", args.overlap, "--emulation",
               str(args.out / "no-emulation"), "--out", str(runs_out), "--runs-only", *SMALL]
    environment = {**os.environ, "PYTHONPATH": str(hidden)}
    shards = [subprocess.Popen([*command, "--shard", f"{i}/2"], env=environment,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
              for i in (1, 2)]
    for i, shard in enumerate(shards, start=1):
        _, stderr = shard.communicate()
        check(shard.returncode == 0, f"shard {i}/2 without matplotlib exited "
              f"{shard.returncode}:\n{stderr}")
    check(not (runs_out / "REPORT.md").exists() and not (runs_out / "report").exists(),
          "--runs-only wrote a report")
    for summary in runs_out.rglob("summary.json"):
        data = json.loads(summary.read_text())
        data["machine"]["cpu"] = ELSEWHERE_CPU
        summary.write_text(json.dumps(data))
    archive = args.out / "gpu_check.tar.xz"
    with tarfile.open(archive, "w:xz") as tar:
        tar.add(runs_out, arcname="./study")
    shutil.rmtree(args.out / "gpu-machine")

    here = args.out / "here" / "study"
    made = subprocess.run([sys.executable, str(STUDY), "--from-archive", str(archive),
                           "--overlap", args.overlap, "--out", str(here)],
                          capture_output=True, text=True)
    check(made.returncode == 0, f"--from-archive exited {made.returncode}:\n{made.stderr}")
    report = (here / "REPORT.md").read_text()
    check(ELSEWHERE_CPU in report, "the report does not name the machine that ran the runs")
    check(str(elsewhere) not in report, "the report names a path of the machine that ran the runs")
    check(str(here) not in report, "the report names its --out folder here, not $OUT")
    check("--runs-only" not in report.split("This report:")[1].split("\n")[0],
          "the report's own command is not the report's")
    for image in re.findall(r"\]\(report/([^)]+)\)", report):
        check((here / "report" / image).exists(), f"the report shows {image}, which is missing")
    check("What ran beside what:" in report, "the report does not say what ran beside what")
    check("never ran at once" in report, "runs compared with each other ran at once")
    check(len(rows(here / "report" / "sweep_runs.csv")) == 6, "sweep_runs.csv lacks the archive's runs")
    check(any(r["sleep_error_max_m"] not in ("", "nan") for r in rows(here / "report" / "physics.csv")),
          "the sleep error, computed without numpy, is missing")

    bad = subprocess.run([sys.executable, str(STUDY), "--from-archive", str(args.out / "none"),
                          "--overlap", args.overlap, "--out", str(here)],
                         capture_output=True, text=True)
    check(bad.returncode == 2 and "no such file" in bad.stderr and (here / "REPORT.md").exists(),
          f"a missing archive: exit {bad.returncode}, {bad.stderr!r}; --out must stay as it was")
    print("study.archive: the report from another path's runs, all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
