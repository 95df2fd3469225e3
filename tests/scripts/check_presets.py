#!/usr/bin/env python3
"""CMakePresets.json's GPU test presets against the finder table: each
compute-sanitizer tool has its preset and an emulation- twin, every preset that
needs a device sets OVERLAP_REQUIRE_DEVICE=1, and the sanitizer presets' name
filter selects every finder `overlap --list-algos --json` says needs a device.

  check_presets.py PRESETS_JSON OVERLAP
"""
import json
import re
import subprocess
import sys

TOOLS = ("memcheck", "racecheck", "initcheck", "synccheck")


def resolved(presets: dict, name: str) -> dict:
    """A test preset with what it inherits filled in (the preset's own keys win)."""
    preset = presets[name]
    merged = {"environment": {}, "filter": {}}
    parents = preset.get("inherits", [])
    for parent in [parents] if isinstance(parents, str) else parents:
        base = resolved(presets, parent)
        merged["environment"].update(base["environment"])
        merged["filter"].update(base["filter"])
    merged["environment"].update(preset.get("environment", {}))
    merged["filter"].update(preset.get("filter", {}))
    return merged


def main(presets_json: str, overlap: str) -> int:
    presets = {p["name"]: p for p in json.load(open(presets_json))["testPresets"]}
    listed = json.loads(subprocess.run([overlap, "--list-algos", "--json"], check=True,
                                       capture_output=True, text=True).stdout)
    gpu_finders = [b["name"] for b in listed["broadphases"] if b["needs_device"]]
    problems = []
    for name in ("gpu", "device-suite") + TOOLS:
        for preset in (name, "emulation-" + name):
            if preset not in presets:
                problems.append(f"no test preset {preset}")
                continue
            settings = resolved(presets, preset)
            if settings["environment"].get("OVERLAP_REQUIRE_DEVICE") != "1":
                problems.append(f"{preset} does not set OVERLAP_REQUIRE_DEVICE=1")
            if name in TOOLS:
                if settings["environment"].get("OVERLAP_SANITIZER") != name:
                    problems.append(f"{preset} does not set OVERLAP_SANITIZER={name}")
                pattern = settings["filter"].get("include", {}).get("name", "")
                for finder in gpu_finders:  # gtest names a finder with '_' for '-'
                    if not re.search(pattern, "AllFinders/PairFinderTest.X/" + finder.replace("-", "_")):
                        problems.append(f"{preset}'s name filter '{pattern}' leaves out {finder}")
    for problem in problems:
        print(f"check_presets: {problem}", file=sys.stderr)
    print(f"check_presets: {len(problems)} problems; GPU finders {', '.join(gpu_finders)}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:]))
