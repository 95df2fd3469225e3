"""The study's named option sets, read from scripts/study_profiles.json.

Rules, each with its reason:
  * Every option set lives in the one committed file: `study.py --profile
    NAME` reads it, and so does any driver that runs the study (a GPU
    machine's, a batch queue's), so no program reads options out of a
    report's text.
  * A profile names only what differs from its base, and the base profile
    ("full") names every option: one place holds each default.
  * An option given on the command line wins over the profile.
  * A profile marked "confirm" (the full study, tens of hours) runs only with
    --full or a yes typed on a terminal, after its estimate is printed: no one
    starts it by accident.
  * A bad file is refused with the file and the problem named (exit 2).
"""
import json
import pathlib
import sys

PATH = pathlib.Path(__file__).resolve().parent / "study_profiles.json"


def refuse(problem: str):
    print(f"study: {PATH.name}: {problem}", file=sys.stderr)
    sys.exit(2)


def load(path: pathlib.Path = PATH) -> dict:
    """The file as read, its profiles checked: every key known to the base, one base each."""
    try:
        data = json.loads(path.read_text())
        profiles = data["profiles"]
        base = profiles["full"]["options"]
    except (OSError, ValueError, KeyError, TypeError) as error:
        refuse(f"cannot be read as the study's profiles ({error!r})")
    for name, profile in profiles.items():
        unknown = set(profile.get("options", {})) - set(base)
        if unknown:
            refuse(f"profile {name} names options the full profile lacks: {sorted(unknown)}")
        if name != "full" and profile.get("base", "full") not in profiles:
            refuse(f"profile {name}: its base {profile.get('base')} is not a profile")
    return data


def options(data: dict, name: str) -> dict:
    """The profile's every option, its bases' filled in, keyed as argparse keys them."""
    profile = data["profiles"][name]
    merged = {} if name == "full" else options(data, profile.get("base", "full"))
    merged.update({key.replace("-", "_"): value for key, value in profile["options"].items()})
    return merged


def names(data: dict) -> list:
    return sorted(data["profiles"])


def needs_confirmation(data: dict, name: str) -> bool:
    return bool(data["profiles"][name].get("confirm", False))


def estimate_seconds(data: dict, jobs: list) -> float:
    """The jobs' cost before running them: a start-up per job and a cost per weight unit."""
    model = data["estimate"]
    return (model["seconds_per_job"] * len(jobs)
            + model["seconds_per_unit"] * sum(job.weight for job in jobs))


def confirmed(name: str, summary: str) -> bool:
    """Whether to run a profile that asks first: on a terminal, the answer; elsewhere no."""
    print(f"study: --profile {name}: {summary}", file=sys.stderr)
    if not sys.stdin.isatty():
        print("study: run it with --full (or --quick: minutes; or --shard i/k to share it "
              "between machines: docs/STUDY.md)", file=sys.stderr)
        return False
    return input("Run it? [y/N] ").strip().lower() in ("y", "yes")
