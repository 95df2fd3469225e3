"""The broadphase catalogue as the study's scripts read it: `overlap --list-algos --json`,
the one table of names, exactness and device needs (physics/broadphase/broadphase_factory.h).

load() runs the binary once; the other functions answer from what it printed, in the
catalogue's order, so a broadphase added to the code reaches the study with no edit here.
"""
import json
import subprocess

_TABLE = []


def load(overlap: str) -> None:
    listed = subprocess.run([overlap, "--list-algos", "--json"], check=True,
                            capture_output=True, text=True).stdout
    _TABLE[:] = json.loads(listed)["broadphases"]


def names() -> list:
    return [entry["name"] for entry in _TABLE]


def needs_device() -> tuple:
    return tuple(entry["name"] for entry in _TABLE if entry["needs_device"])


def exact() -> tuple:
    return tuple(entry["name"] for entry in _TABLE if entry["exact"])
