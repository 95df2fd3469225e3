#!/usr/bin/env python3
"""The physics step's time for each of several configurations, interleaved.

Each --config LABEL=BINARY[:OPTIONS] is one `overlap run` (BINARY, e.g. this
build's and an older commit's) with the options common to all (--common) and
its own (OPTIONS, e.g. "--threads 2"). The configurations run one after
another, round after round (--rounds), so a change of load hits them alike.
Each run's figure is the median physics_ms of its frames from --skip on; a
configuration's is the median over its rounds. Each run also gives its
physics time per substep (the frames' physics_ms over their substeps, from --skip
on: the step's speed where two solvers' piles take different substeps) and its
state hash (a change that keeps the bits shows it). One CSV row per run, then the
ratio of each configuration to the first, on the terminal and in the CSV's
'#' lines (each on one line: a newline or other control character in a binary's
name, an option or a run's machine text is written escaped); the load is
recorded before and after.

  scripts/thread_scaling.py --out docs/results/thread_scaling.csv \\
      --config "t1=build/overlap:--threads 1" --config "t2=build/overlap:--threads 2"
"""
import csv
import io
import os
import pathlib
import shlex
import statistics
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from overlap_runs import run_summary  # noqa: E402
from results_files import read_csv  # noqa: E402
from script_cli import BadInput, Parser, one_line, run, write_atomically  # noqa: E402

# run_summary() adds --capture-every 0 --no-wav.
COMMON = "--scene 4 --objects 3500 --frames 24 --no-tasks --algo cpusap"


def parse_config(text: str) -> tuple:
    label, sep, rest = text.partition("=")
    binary, _, options = rest.partition(":")
    if not sep or not label or not binary:
        raise BadInput(f"--config {one_line(text)}: expected LABEL=BINARY[:OPTIONS]")
    if not label.isprintable():
        raise BadInput(f"--config {one_line(text)}: the label {one_line(label)} holds a "
                       "control character (it names a CSV row)")
    if not os.path.isfile(binary) or not os.access(binary, os.X_OK):
        raise BadInput(f"--config {one_line(text)}: {one_line(binary)} is not an executable file")
    return label, binary, split_options(f"--config {text}", options)


def split_options(option: str, text: str) -> list:
    """`text` split as a shell would, or BadInput naming `option`."""
    try:
        return shlex.split(text)
    except ValueError as error:
        raise BadInput(f"{one_line(option)}: {error}")


def check_out(out: pathlib.Path) -> None:
    """Refuses, before any run, an --out the CSV could not be written to at the end:
    its folder is made (an empty one stays if the runs fail) and a file tried in it."""
    if out.exists() and not out.is_file():
        raise BadInput(f"--out {one_line(out)}: not a regular file")
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=out.parent, prefix=f".{out.name}."):
            pass
    except OSError as error:
        raise BadInput(f"--out {one_line(out)}: {one_line(error.strerror or error)}")


def run_once(binary: str, options: list, skip: int) -> tuple:
    """(the run's CSV row past round and config, the machine and commit its summary
    names), over its frames from `skip` on."""
    with tempfile.TemporaryDirectory() as work:
        out = pathlib.Path(work) / "run"
        summary = run_summary(binary, out, options)
        frames = read_csv(out / "frames.csv")[skip:]
        if not frames:
            raise BadInput(f"--skip {skip}: the run has no frame after it")
        substeps = sum(int(row["substeps"]) for row in frames)
        physics = sum(float(row["physics_ms"]) for row in frames)
        row = {"physics_ms": f"{statistics.median(float(r['physics_ms']) for r in frames):.2f}",
               "substeps": substeps,
               "per_substep_ms": f"{physics / substeps:.3f}" if substeps else "",
               "state_hash": summary.get("state_hash", "")}
        return row, summary["machine"]


def main() -> None:
    parser = Parser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", action="append", default=[],
                        help="LABEL=BINARY[:OPTIONS], in the order run; the first is the base")
    parser.add_argument("--common", default=COMMON, help="options every run gets")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--skip", type=int, default=8, help="frames left out at the start")
    parser.add_argument("--out", type=pathlib.Path, required=True, help="the CSV to write")
    args = parser.parse_args()
    try:
        if not args.config:
            raise BadInput("--config: at least one LABEL=BINARY[:OPTIONS]")
        configs = [parse_config(text) for text in args.config]
        labels = [label for label, _, _ in configs]
        if len(set(labels)) != len(labels):
            raise BadInput("--config: each LABEL once (given: " + one_line(" ".join(labels)) + ")")
        if args.rounds < 1:
            raise BadInput(f"--rounds {args.rounds}: at least 1")
        if args.skip < 0:
            raise BadInput(f"--skip {args.skip}: at least 0")
        common = split_options(f"--common {args.common}", args.common)
        check_out(args.out)
        load_before = os.getloadavg()[0]
        rows = []
        machines = {}
        for round_ in range(args.rounds):
            for label, binary, options in configs:
                row, machines[label] = run_once(binary, common + options, args.skip)
                rows.append({"round": round_, "config": label, **row})
                print(f"round {round_ + 1}/{args.rounds} {label}: {row['physics_ms']} ms, "
                      f"{row['per_substep_ms']} ms a substep", flush=True)
        load_after = os.getloadavg()[0]
    except BadInput as error:
        print(f"{parser.prog}: {error}", file=sys.stderr)
        sys.exit(2)
    except subprocess.CalledProcessError as error:
        print(f"{parser.prog}: {one_line(' '.join(error.cmd))} exited {error.returncode}; "
              "nothing written", file=sys.stderr)
        sys.exit(2 if error.returncode == 2 else 1)  # 2: overlap refused an option
    def median_of(column: str) -> dict:
        """Each configuration's median of `column` (None where no run has one)."""
        medians = {}
        for label, _, _ in configs:
            values = [float(r[column]) for r in rows if r["config"] == label and r[column] != ""]
            medians[label] = statistics.median(values) if values else None
        return medians

    base = configs[0][0]

    def ratios(medians: dict, digits: int) -> list:
        return [f"{label} n/a" if ms is None else
                f"{label} {ms:.{digits}f} ms" + (f" ({ms / medians[base]:.{digits}f}x {base})"
                                                 if medians[base] else "")
                for label, ms in medians.items()]
    summary = ratios(median_of("physics_ms"), 2)
    substep_summary = ratios(median_of("per_substep_ms"), 3)
    hashes = ["{} {}".format(label, " ".join(sorted({r["state_hash"] for r in rows
                                                     if r["config"] == label})))
              for label, _, _ in configs]
    machine = machines[base]
    lines = [f"# what: per run, over frames {args.skip}+: the median physics_ms, the "
             "substeps, physics ms per substep and the state hash; configurations "
             "interleaved round by round",
             f"# machine: {machine['cpu']}, {machine['hardware_threads']} hardware threads, "
             f"GPU: {machine['gpu']}; {machine['compiler']}, {machine['build_type']}",
             "# commits: " + "; ".join(f"{label} {m['git_commit']}" for label, m in machines.items()),
             f"# date: {time.strftime('%Y-%m-%d %H:%M %Z')}",
             f"# load: {load_before:.2f} before, {load_after:.2f} after",
             f"# common options: {' '.join(common)}",
             "# configs: " + "; ".join(f"{label}={pathlib.Path(binary).name} {' '.join(o)}"
                                       for label, binary, o in configs),
             "# medians: " + "; ".join(summary),
             "# per substep: " + "; ".join(substep_summary),
             "# state hashes: " + "; ".join(hashes)]
    table = io.StringIO(newline="")
    writer = csv.DictWriter(table, fieldnames=["round", "config", "physics_ms", "substeps",
                                               "per_substep_ms", "state_hash"])
    writer.writeheader()
    writer.writerows(rows)
    # Each '#' line on one line, whatever a name, an option or a run's machine text holds
    # (a newline would end the comment, its rest read as the CSV's header).
    write_atomically(args.out, "".join(f"{one_line(line)}\n" for line in lines) +
                     table.getvalue())
    print(f"load {load_before:.2f} -> {load_after:.2f}; " + "; ".join(summary))
    print("per substep: " + "; ".join(substep_summary))
    print("state hashes: " + "; ".join(hashes))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    sys.exit(run(main, "thread_scaling.py"))
