"""The findings' verdicts follow their sections' targets: a report made from a small study
whose targets are met in one section and missed in another.

The study runs the pairs and the overlap experiments at a few boxes.  The pairs'
targets are met by the finders' exactness (a miss would be a bug, and fails the
study).  The overlap runs' summaries are then rewritten so that every async frame
takes twice its sync frame (a test asserts behaviour, never timings: the speed-up is
set, not measured), and the report is made again from the runs.  The findings must
say "holds" for the exact finders and "does not hold" for the asynchronous frame,
each as its section's targets table says; the claims whose experiments did not run
(the sweep's, the physics') must have no verdict; no findings cell may be over 160
characters.  The runs are also relabelled as the repository's first commit's, so the
report's header must say they are behind the code.  Exit 77 (ctest's skip) when this
interpreter has no matplotlib.
"""
import json
import subprocess
import sys

from check_quick import STUDY, arguments_or_skip, check

SMALL = ["--quick", "--threads", "1", "--experiments", "pairs,overlap", "--pairs-objects", "60",
         "--pairs-frames", "3", "--pairs-algos", "bf,cpubf,cpusap", "--overlap-scenes", "4",
         "--overlap-objects", "40", "--overlap-loads", "0,1", "--overlap-frames", "2",
         "--overlap-repetitions", "1", "--ideal-objects", "40", "--ideal-frames", "2"]


def findings(report: str) -> dict:
    """{claim: (verdict, every cell)} of the report's findings table."""
    table = report.split("## Findings")[1].split("\n## ")[0]
    rows = [[c.strip() for c in line.strip().strip("|").split("|")]
            for line in table.splitlines() if line.startswith("| ") and "---" not in line]
    return {cells[0]: (cells[1], cells) for cells in rows[1:]}


def section(report: str, title: str) -> str:
    return report.split(f"## {title}")[1].split("\n## ")[0]


def root_commit() -> str:
    """The repository's first commit, which every later change to engine/ is behind; None
    where this checkout has no history to ask."""
    found = subprocess.run(["git", "-C", str(STUDY.parents[1]), "rev-list", "--max-parents=0",
                            "HEAD"], capture_output=True, text=True)
    return found.stdout.split()[0][:12] if found.returncode == 0 and found.stdout else None


def rewrite_runs(out, commit: str) -> None:
    """Every overlap run's async frame made twice its sync frame, and every run made at
    `commit` (when given): the report must then say its runs are behind the code."""
    for path in out.glob("*/*/summary.json"):
        summary = json.loads(path.read_text())
        if "compare_sync" in summary:
            compare = summary["compare_sync"]
            compare["async_total_ms_median"] = 2 * compare["sync_total_ms_median"]
        if commit:
            summary["machine"]["git_commit"] = commit
        path.write_text(json.dumps(summary))


def main() -> int:
    args = arguments_or_skip()
    if args is None:
        return 77
    command = [sys.executable, str(STUDY), "--overlap", args.overlap, "--emulation",
               str(args.out / "no-emulation"), "--out", str(args.out), *SMALL]
    ran = subprocess.run(command, capture_output=True, text=True)
    check(ran.returncode == 0, f"the study exited {ran.returncode}:\n{ran.stderr}")
    commit = root_commit()
    rewrite_runs(args.out, commit)
    made = subprocess.run([*command, "--no-runs"], capture_output=True, text=True)
    check(made.returncode == 0, f"the report exited {made.returncode}:\n{made.stderr}")
    report = (args.out / "REPORT.md").read_text()
    found = findings(report)
    exact = found["Ours: the exact finders are exact"][0]
    pays = found["Ours: the asynchronous frame pays"][0]
    pairs, overlap = section(report, "3.1 "), section(report, "4. ")
    check(exact == "holds" and "| missed |" not in pairs and "| met |" in pairs,
          f"exact finders: verdict {exact!r}, section:\n{pairs}")
    check(pays == "does not hold" and "| missed |" in overlap,
          f"asynchronous frame: verdict {pays!r}, section:\n{overlap}")
    for claim in ("Paper 1: GPU-BF beats BF everywhere", "Paper 3: GPU-BF does best in scene 4 "
                  "(mixed sizes)", "Ours: cpusap beats Bullet's CPU broadphases",
                  "Ours: the default substeps and CCD cost less than the old fixed K, "
                  "no more error"):
        check(found[claim][0] == "—" and "not run" in found[claim][1][2],
              f"{claim}: a claim not run has the verdict {found[claim][0]!r}")
    if commit:
        check("**The runs are behind the code**" in report.split("## Findings")[0],
              f"runs of {commit} (the first commit), yet the header does not say they are "
              "behind the code")
    longest = max(len(c) for _, cells in found.values() for c in cells)
    check(longest <= 160, f"a findings cell of {longest} characters")
    check(" in 0 of " not in report.split("## 1.")[0], "a verdict counts cells of none met")
    print("study.verdicts: met in §3.1, missed in §4, not run elsewhere: all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
