#!/usr/bin/env python3
"""One `overlap run` as one picture: scripts/plot_run.py OUT draws OUT/frames.csv
frame by frame into OUT/run.png, beside the run's other outputs.

  top     the physics step's stages stacked (update, broadphase, narrowphase,
          solver, integrate, CCD query, the rest of the step), the whole
          frame above them, and the frame time (summary.json's frame_time,
          1/30 s without it) as a line: a frame over it is a stutter;
  middle  the pairs in the pair cache;
  bottom  the substeps the frame ran.

Bad input (OUT not a run's folder, a frames.csv or summary.json that is
not UTF-8 text, a frames.csv without a column this draws, a value that is
not an ASCII decimal number (as a run writes it: 12, 0.25, 1.5e-05; not
another script's digits nor 1_000, which float() takes), or one no run
writes: NaN, an infinity, 1e999, a negative or one beyond LARGEST; a
summary.json that is not a JSON object, or whose frame_time is not a
positive number of seconds up to MAX_FRAME_TIME_S) is one line naming the
file, exit 2, and nothing written; the PNG is written to a temporary beside it and
renamed into place.  Needs matplotlib (Debian's python3-matplotlib, which
scripts/setup.sh installs, lives with /usr/bin/python3).
"""
import csv
import io
import json
import math
import os
import pathlib
import re
import sys
import tempfile

from script_cli import Parser, run

STAGES = ["update_ms", "broadphase_ms", "narrowphase_ms", "solver_ms", "integrate_ms",
          "ccd_query_ms"]
COLUMNS = ["frame", "physics_ms", "total_ms", "pairs", "substeps"] + STAGES
COLOURS = {"update_ms": "#2ca02c", "broadphase_ms": "#d62728", "narrowphase_ms": "#9467bd",
           "solver_ms": "#1f77b4", "integrate_ms": "#8c564b", "ccd_query_ms": "#e377c2",
           "other": "#bbbbbb"}
LARGEST = 1e15  # any column's value (ms, pairs, substeps): far past any run, far below inf
MAX_FRAME_TIME_S = 3600.0
# A number as a run writes it: ASCII digits, a point, an exponent (float() takes more:
# any script's digits, '_' between digits, spaces around, 'inf' and 'nan').
NUMBER = re.compile(r"-?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")


class BadInput(Exception):
    """A problem with OUT, worded for the one line the script prints."""


def utf8_text(path: pathlib.Path) -> str:
    """`path`'s text; BadInput naming it when it is not UTF-8."""
    try:
        return path.read_bytes().decode("utf-8")
    except UnicodeDecodeError as error:
        raise BadInput(f"{path}: not UTF-8 text (byte {error.start})") from None


def read_frames(out: pathlib.Path) -> dict:
    """frames.csv's columns this draws, as lists of floats."""
    path = out / "frames.csv"
    if not out.is_dir():
        raise BadInput(f"{out}: not a folder (give the --out folder of an `overlap run`)")
    if not path.is_file():
        raise BadInput(f"{out}: has no frames.csv (give the --out folder of an `overlap run`)")
    try:
        rows = list(csv.DictReader(io.StringIO(utf8_text(path), newline="")))
    except csv.Error as error:
        raise BadInput(f"{path}: not CSV ({error})") from None
    if not rows:
        raise BadInput(f"{path}: no frames")
    missing = [c for c in COLUMNS if c not in rows[0]]
    if missing:
        raise BadInput(f"{path}: no column {', '.join(missing)}")
    columns = {c: [] for c in COLUMNS}
    for line, row in enumerate(rows, start=2):
        for c in COLUMNS:
            if not isinstance(row[c], str) or not NUMBER.fullmatch(row[c]):
                raise BadInput(f"{path}, line {line}: {c} is {row[c]!r}, not a number (ASCII "
                               "decimal, as a run writes it)")
            value = float(row[c])
            # float() reads nan, inf and 1e999 without a word: no run writes them, and the
            # axes cannot hold them (nor a sum past a double, nor a negative time).
            if not (math.isfinite(value) and 0 <= value <= LARGEST):
                raise BadInput(f"{path}, line {line}: {c} is {row[c]!r}, no number a run "
                               f"writes (expected 0 to {LARGEST:g})")
            columns[c].append(value)
    return columns


def frame_time_ms(out: pathlib.Path) -> float:
    """The run's frame time: summary.json's, else (no summary.json, or no frame_time in
    its parameters) the default 1/30 s; a summary.json that is not UTF-8, not JSON or not
    an object (nor its parameters), or a frame_time that is no positive number of seconds
    up to MAX_FRAME_TIME_S (NaN, an infinity, 1e999, -5, a string) is BadInput."""
    path = out / "summary.json"
    if not path.exists():
        return 1000.0 / 30
    try:
        summary = json.loads(utf8_text(path))
    except (ValueError, RecursionError) as error:
        raise BadInput(f"{path}: not JSON ({str(error)[:80]})") from None
    parameters = summary.get("parameters", {}) if isinstance(summary, dict) else None
    if not isinstance(parameters, dict):
        raise BadInput(f"{path}: not a run's summary (no object of parameters)")
    if "frame_time" not in parameters:
        return 1000.0 / 30
    given = parameters["frame_time"]
    if isinstance(given, bool) or not isinstance(given, (int, float)) or \
            not (math.isfinite(given) and 0 < given <= MAX_FRAME_TIME_S):
        raise BadInput(f"{out / 'summary.json'}: parameters.frame_time is "
                       f"{json.dumps(given)[:40]}, not a frame time (expected seconds, "
                       f"above 0, up to {MAX_FRAME_TIME_S:g})")
    return 1000.0 * given


def draw(columns: dict, budget_ms: float, title: str, png: pathlib.Path) -> None:
    try:
        import matplotlib
    except ImportError:
        sys.exit(f"plot_run.py: {sys.executable} has no matplotlib: run it with /usr/bin/python3 "
                 "(Debian's python3-matplotlib, which scripts/setup.sh installs)")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    frames = columns["frame"]
    named = [sum(values) for values in zip(*(columns[s] for s in STAGES))]
    other = [max(0.0, p - n) for p, n in zip(columns["physics_ms"], named)]
    figure, (stages, pairs, substeps) = plt.subplots(
        3, 1, sharex=True, figsize=(10, 7.5), gridspec_kw={"height_ratios": [3, 1, 1]})
    stacked = [columns[s] for s in STAGES] + [other]
    labels = [s.removesuffix("_ms").replace("_", " ") for s in STAGES] + ["rest of the step"]
    stages.stackplot(frames, stacked, labels=labels,
                     colors=[COLOURS[s] for s in STAGES] + [COLOURS["other"]], linewidth=0)
    stages.plot(frames, columns["total_ms"], color="black", linewidth=0.8, label="whole frame")
    over = sum(1 for t in columns["total_ms"] if t > budget_ms)
    stages.axhline(budget_ms, color="#ff7f0e", linestyle="--", linewidth=1,
                   label=f"frame time {budget_ms:.3g} ms ({over} of {len(frames)} frames over)")
    stages.set_ylabel("ms")
    # Room above the tallest frame for the legend.
    stages.set_ylim(0, 1.3 * max(max(columns["total_ms"]), max(columns["physics_ms"]), budget_ms))
    stages.set_title(title, fontsize=10)
    stages.legend(loc="upper left", fontsize=7, ncol=3, frameon=False)
    pairs.plot(frames, columns["pairs"], color="#444444", linewidth=1)
    pairs.set_ylabel("pairs")
    substeps.step(frames, columns["substeps"], where="mid", color="#1f77b4", linewidth=1)
    substeps.set_ylabel("substeps")
    substeps.set_xlabel("frame")
    for axes in (pairs, substeps):
        axes.set_ylim(bottom=0)
    for axes in (stages, pairs, substeps):
        axes.grid(axis="y", linewidth=0.3)
    figure.tight_layout()
    # Whole or not at all: a temporary in the same folder, renamed over the name.
    handle, temporary = tempfile.mkstemp(prefix=".run.png.", dir=png.parent)
    os.close(handle)
    try:
        figure.savefig(temporary, dpi=110, format="png")
        os.replace(temporary, png)
    finally:
        if os.path.exists(temporary):
            os.remove(temporary)
    plt.close(figure)


def title_of(out: pathlib.Path) -> str:
    """"scene 4, 1000 boxes, cpusap, async" from summary.json, else the folder's name."""
    try:
        p = json.loads((out / "summary.json").read_text())["parameters"]
        return (f"{out}: scene {p['scene']}, {p['objects']} boxes, {p['algorithm']}, "
                f"{'sync' if p['sync'] else 'async'}, {p['threads']} threads")
    except (OSError, ValueError, KeyError, TypeError):
        return str(out)


def main() -> int:
    parser = Parser(
        description="Draw an `overlap run`'s frames.csv (stages per frame, pairs, substeps) "
                    "as OUT/run.png.")
    parser.add_argument("out", type=pathlib.Path, metavar="OUT",
                        help="the run's --out folder (holding frames.csv)")
    args = parser.parse_args()
    try:
        columns = read_frames(args.out)
        budget_ms = frame_time_ms(args.out)
    except BadInput as problem:
        print(f"plot_run.py: {problem}", file=sys.stderr)
        return 2
    except OSError as error:
        print(f"plot_run.py: {args.out}: {error.strerror}", file=sys.stderr)
        return 2
    png = args.out / "run.png"
    draw(columns, budget_ms, title_of(args.out), png)
    print(f"plot_run.py: wrote {png}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(run(main, "plot_run.py"))
