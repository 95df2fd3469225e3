"""The broadphase catalogue as the study's scripts read it: `overlap --list-algos --json`,
the one table of names, exactness and device needs (physics/broadphase/broadphase_factory.h).

load() runs the binary once; the other functions answer from what it printed, in the
catalogue's order, so a broadphase added to the code reaches the study with no edit here.
A binary that is missing or cannot list its broadphases ends the program with one line
naming it (exit 2), never a traceback.
"""
import json
import subprocess

from script_cli import BadInput, run_child

_TABLE = []


def load(overlap: str) -> None:
    """Raises BadInput naming `overlap` when it does not list its broadphases."""
    try:
        listed = run_child([overlap, "--list-algos", "--json"], check=True,
                           capture_output=True, text=True).stdout
        _TABLE[:] = json.loads(listed)["broadphases"]
    except OSError as error:
        raise BadInput(f"{overlap}: cannot run it ({error.strerror}): build it first, or name "
                       "another with --overlap")
    except (subprocess.CalledProcessError, ValueError, KeyError, TypeError) as error:
        raise BadInput(f"{overlap} --list-algos --json failed ({error})")


def names() -> list:
    return [entry["name"] for entry in _TABLE]


def needs_device() -> tuple:
    return tuple(entry["name"] for entry in _TABLE if entry["needs_device"])


def ours() -> tuple:
    """The project's own finders (their catalogue descriptions open with "ours"): those
    whose search can run beside the narrowphase (--narrowphase beside-search)."""
    return tuple(entry["name"] for entry in _TABLE if entry["description"].startswith("ours"))


def exact() -> tuple:
    return tuple(entry["name"] for entry in _TABLE if entry["exact"])
