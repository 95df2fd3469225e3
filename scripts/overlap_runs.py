"""What the result tables and the study share: `overlap run` and the machine it ran on.

run_summary() runs one `overlap run` process unless its folder already holds
the summary (so every table is resumable); add_table_arguments() gives the
tables the same options; results_header() opens a Markdown table with the
machine and the exact command, as every file under docs/results/ does.
"""
import argparse
import json
import pathlib
import subprocess
import sys

from script_cli import run_child


def run_summary(overlap: str, folder: pathlib.Path, options: list) -> dict:
    """`overlap run OPTIONS --out FOLDER`, unless FOLDER already holds its summary; a run
    that fails raises CalledProcessError holding its stderr (what overlap said)."""
    summary_path = folder / "summary.json"
    if not summary_path.exists():
        run_child([overlap, "run", *options, "--capture-every", "0", "--no-wav",
                   "--out", str(folder)], check=True, stderr=subprocess.PIPE,
                  text=True, errors="backslashreplace")  # a path's bytes as they are
    return json.loads(summary_path.read_text())


def add_table_arguments(parser: argparse.ArgumentParser, algos: str, scenes: str, frames: int,
                        name: str) -> None:
    """The options every table has; `name` picks the default --work and --out."""
    parser.add_argument("--overlap", default="build/overlap", help="the overlap binary")
    parser.add_argument("--algos", default=algos)
    parser.add_argument("--scenes", default=scenes)
    parser.add_argument("--objects", default="500,1250,2000,2750,3500")
    parser.add_argument("--frames", type=int, default=frames)
    parser.add_argument("--work", default=f"out/{name}", help="folder for the runs")
    parser.add_argument("--out", default=f"docs/results/{name}", help="prefix of .csv and .md")


REPO = pathlib.Path(__file__).resolve().parent.parent


def portable(text: str, folders: dict) -> str:
    """`text` (a command line, a path) without this machine's absolute paths, for the
    committed docs: each of `folders` (a scratch folder outside the repository -> the name
    the docs give it, e.g. "$OUT") is shown by its name, the repository's own paths
    relative to the repository."""
    for folder, name in folders.items():
        text = text.replace(str(pathlib.Path(folder).resolve()), name)
    return text.replace(str(REPO) + "/", "")


def results_header(title: str, machine: dict, work: str) -> list:
    """A results file's first lines: its title, the machine, the command that wrote it
    (its --work folder, scratch space for the runs, shown as $WORK)."""
    command = portable(" ".join(sys.argv[1:]), {work: "$WORK"})
    return [f"# {title}", "",
            f"Machine: {machine['cpu']}, {machine['hardware_threads']} hardware threads, "
            f"GPU: {machine['gpu']}; {machine['compiler']}, {machine['build_type']}, "
            f"commit {machine['git_commit']}.", "",
            f"Command: `scripts/{pathlib.Path(sys.argv[0]).name} {command}` ($WORK: the "
            "folder the runs were kept in).", ""]
