#!/usr/bin/env python3
"""What scripts/gpu_check.sh's steps read from the files they write: the standard
library only (a GPU machine's python3 may have nothing else).

  gpu_check_steps.py within FACTOR FINDERS BENCH.json  cpusap and each of FINDERS
      (comma-separated) whose frame at the largest n is within FACTOR of cpusap's
  gpu_check_steps.py has ALGOS BENCH.json     exit 1 unless every one has rows
      (the benchmark leaves out a GPU finder it finds no device for)
  gpu_check_steps.py ran ALGO SUMMARY.json    the run's frame; exit 1 unless ALGO ran
  gpu_check_steps.py junit CTEST.xml          ctest's counts (its exit status is the verdict)
  gpu_check_steps.py jobs STUDY_OPTIONS...    how many of the study's jobs are done, of all
  gpu_check_steps.py gpu-finders OVERLAP      the finders `OVERLAP --list-algos --json` says
      need a device, comma-separated: a new one is checked with no edit of gpu_check.sh
  gpu_check_steps.py resume ARCHIVE FOLDER    the archive's ./study unpacked as FOLDER/study
      with study_archive.py's checks (an earlier run's archive is untrusted: no link, no
      absolute or '..' name, no device, the study's text and runs as the report reads them);
      a bad archive exits 1 with one line saying why

Each prints one line, the step's note; a bad file exits 2 naming it.
"""
import json
import subprocess
import sys
import xml.etree.ElementTree


def rows(path: str) -> list:
    return json.load(open(path))["rows"]


def within(factor: str, finders: str, path: str) -> str:
    table = rows(path)
    largest = max(r["n"] for r in table)
    frame = {r["algorithm"]: r["median_us"] for r in table if r["n"] == largest}
    kept = [f for f in finders.split(",") if f in frame and frame[f] <= float(factor) * frame["cpusap"]]
    return ",".join(["cpusap"] + kept)


def has(algorithms: str, path: str) -> str:
    table = rows(path)
    missing = sorted(set(algorithms.split(",")) - {r["algorithm"] for r in table})
    if missing:
        raise SystemExit(f"{len(table)} rows; none for {','.join(missing)} (no device?)")
    return f"{len(table)} rows, every algorithm: {algorithms}"


def ran(algorithm: str, path: str) -> str:
    """The line scripts/gpu_results.py reads back from the step table (checked_frames)."""
    summary = json.load(open(path))
    times, sync = summary["timings_ms"], summary.get("compare_sync") or {}
    used = summary["parameters"]["algorithm"]
    frame, physics, broadphase = (times[k]["median"] for k in ("total_ms", "physics_ms", "broadphase_ms"))
    line = (f"ran {used}; frame {frame:.2f} ms, physics {physics:.2f}, broadphase {broadphase:.3f}; "
            f"state {summary['state_hash']}")
    if sync:
        line += f"; sync/async {sync['speedup']:.2f}, same state {sync['identical_state']}"
    if used != algorithm:
        raise SystemExit(f"{line}: not {algorithm}")
    return line


def junit(path: str) -> str:
    counts = xml.etree.ElementTree.parse(path).getroot().attrib
    return f"{counts['tests']} tests, {counts['failures']} failed, {counts['skipped']} skipped"


def jobs(*options: str) -> str:
    sys.path.insert(0, __file__.rsplit("/", 1)[0])
    import broadphases
    import study
    args = study.parse_args(list(options) + ["--no-runs"])
    broadphases.load(args.overlap)
    planned = study.study_plan.plan(args)
    done = sum(job.done() for job in planned)
    if done < len(planned):
        raise SystemExit(f"{done} of {len(planned)} jobs done: copy the archive to "
                         ".gpu-carry/resume.tar.xz and call --study again")
    return f"{done} of {len(planned)} jobs done"


def gpu_finders(overlap: str) -> str:
    listed = subprocess.run([overlap, "--list-algos", "--json"], capture_output=True, text=True,
                            check=True).stdout
    return ",".join(b["name"] for b in json.loads(listed)["broadphases"] if b["needs_device"])


def resume(archive: str, folder: str) -> str:
    sys.path.insert(0, __file__.rsplit("/", 1)[0])
    import pathlib
    import study_archive
    scratch = pathlib.Path(folder)
    scratch.mkdir()
    try:
        log = study_archive.check_study(study_archive.extract(pathlib.Path(archive), scratch))
    except study_archive.BadArchive as error:
        raise SystemExit(str(error))
    return f"its ./study unpacked: {len(log)} invocations"


def main(argv: list) -> int:
    commands = {"within": within, "has": has, "ran": ran, "junit": junit, "jobs": jobs,
                "gpu-finders": gpu_finders, "resume": resume}
    if not argv or argv[0] not in commands:
        print(f"gpu_check_steps: the first argument is one of {', '.join(commands)}", file=sys.stderr)
        return 2
    try:
        print(commands[argv[0]](*argv[1:]))
    except (OSError, ValueError, KeyError, TypeError, subprocess.CalledProcessError,
            xml.etree.ElementTree.ParseError) as error:
        print(f"gpu_check_steps: {' '.join(argv)}: {error!r}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
