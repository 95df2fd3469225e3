"""The broadphase catalogue as the study's scripts read it: `overlap --list-algos --json`,
the one table of names, exactness and device needs (physics/broadphase/broadphase_factory.h).

load() runs the binary once; the other functions answer from what it printed, in the
catalogue's order, so a broadphase added to the code reaches the study with no edit here.
A binary that is missing or is no overlap (it refuses --list-algos, or prints no catalogue)
ends the program with one line naming it, exit 2; one that fails to start or is killed
(a memory limit: its loader cannot map its libraries, exit 127) is the machine's, exit 1;
never a traceback.
"""
import errno
import json
import subprocess

from script_cli import BadInput, Failed, one_line, run_child, signal_name

_TABLE = []


def load(overlap: str) -> None:
    """Raises BadInput naming `overlap` when it does not list its broadphases."""
    try:
        listed = run_child([overlap, "--list-algos", "--json"], check=True,
                           capture_output=True, text=True).stdout
        _TABLE[:] = json.loads(listed)["broadphases"]
    except OSError as error:
        if error.errno in (errno.ENOMEM, errno.EAGAIN):
            raise Failed(f"{overlap}: cannot start it ({error.strerror})")
        raise BadInput(f"{overlap}: cannot run it ({error.strerror}): build it first, or name "
                       "another with --overlap")
    except subprocess.CalledProcessError as error:
        said = [line for line in (error.stderr or "").splitlines() if line.strip()]
        said = f": {one_line(said[-1])}" if said else ""
        if error.returncode == 2:  # overlap's answer to bad input: not an overlap that lists them
            raise BadInput(f"{overlap} --list-algos --json refused (exit 2){said}")
        # exit 1, 127 (its loader could not map its libraries) or a signal: the machine's
        # (a memory limit, a library missing), not the input's
        how = (f"killed by {signal_name(-error.returncode)}" if error.returncode < 0
               else f"exit {error.returncode}")
        raise Failed(f"{overlap} --list-algos --json failed ({how}){said}")
    except (ValueError, KeyError, TypeError) as error:
        raise BadInput(f"{overlap} --list-algos --json: not a list of broadphases ({error})")


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
