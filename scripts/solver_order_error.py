#!/usr/bin/env python3
"""The coloured contact solver's error next to Bullet's serial solver's, at the same K.

Runs every physics cell of a study profile (scripts/study_profiles.json; the
quick one by default) twice, `overlap run ... --solver-order serial` and
`--solver-order coloured`, and writes one CSV row per cell: each order's
escaped, sunk and removed boxes (the run's maximum), deepest penetration and
energy drift (scripts/study_results.py's columns), and whether the coloured run
meets each target against the serial one:
  - escaped, sunk and removed no higher;
  - maximum penetration at most 1.1x;
  - energy drift (|end - start| / |start|) no larger.
The runs are kept under --work and reused when rerun.

  scripts/solver_order_error.py --overlap build/overlap \\
      --out docs/results/solver_order_error.csv
"""
import argparse
import concurrent.futures
import csv
import os
import pathlib
import platform
import subprocess
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import study_plan  # noqa: E402
import study_profiles  # noqa: E402
import study_results  # noqa: E402
from script_cli import Parser, run  # noqa: E402
from overlap_runs import run_summary  # noqa: E402

ORDERS = ("serial", "coloured")
COUNTS = ("escaped_max", "sunk_max", "removed_max")
PENETRATION_SHARE = 1.1


def cells(profile: str, seed: int) -> list:
    args = argparse.Namespace(**study_profiles.options(study_profiles.load(), profile))
    args.seed = seed
    return study_plan.physics_cells(args), args


def options_of(args, cell: tuple, order: str) -> list:
    """The study's own command line for the cell, with the solver's order."""
    plan_args = argparse.Namespace(**vars(args))
    plan_args.out, plan_args.overlap, plan_args.threads = pathlib.Path("."), "", None
    plan = study_plan.Plan(plan_args)
    job = study_plan.physics_run(plan, cell)
    return [*job.options, "--solver-order", order]


def measure(overlap: str, folder: pathlib.Path, options: list) -> dict:
    summary = run_summary(overlap, folder, options)
    row = study_results.physics_row(summary)
    row.update(study_results.energy_drift(study_results.read_frames(folder)))
    return row


def verdicts(serial: dict, coloured: dict) -> dict:
    return {
        "counts_met": all(coloured[c] <= serial[c] for c in COUNTS),
        "penetration_met": coloured["penetration_max"]
        <= PENETRATION_SHARE * serial["penetration_max"],
        "energy_met": abs(coloured["energy_drift"]) <= abs(serial["energy_drift"]),
    }


def git_commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                              text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def main() -> None:
    parser = Parser(description=__doc__.splitlines()[0])
    parser.add_argument("--overlap", default="build/overlap", help="the overlap binary")
    parser.add_argument("--profile", default="quick", help="the study profile whose cells run")
    parser.add_argument("--seed", type=int, default=42, help="the study's main seed")
    parser.add_argument("--work", type=pathlib.Path, default=pathlib.Path("out/solver_order"),
                        help="where the runs are kept")
    parser.add_argument("--out", type=pathlib.Path,
                        default=pathlib.Path("docs/results/solver_order_error.csv"))
    parser.add_argument("--jobs", type=int, default=1, help="runs at once")
    a = parser.parse_args()
    if a.profile not in study_profiles.names(study_profiles.load()):
        known = ", ".join(study_profiles.names(study_profiles.load()))
        parser.error(f"--profile {a.profile}: not one of {known}")
    if not pathlib.Path(a.overlap).is_file():
        parser.error(f"--overlap {a.overlap}: no such file")
    all_cells, args = cells(a.profile, a.seed)

    def run(cell, order):
        folder = a.work / f"{study_plan.physics_key(args, cell)}_{order}"
        return measure(a.overlap, folder, options_of(args, cell, order))

    with concurrent.futures.ThreadPoolExecutor(a.jobs) as pool:
        futures = {(cell, order): pool.submit(run, cell, order)
                   for cell in all_cells for order in ORDERS}
        results = {key: future.result() for key, future in futures.items()}

    rows = []
    for cell in all_cells:
        serial, coloured = (results[(cell, order)] for order in ORDERS)
        row = {key: serial[key] for key in ("scene", "objects", "seed", "substeps", "ccd", "sleep",
                                            "solver", "frames")}
        row["mean_k"] = serial["mean_k"]
        for order, result in zip(ORDERS, (serial, coloured)):
            for key in (*COUNTS, "penetration_max", "energy_drift", "energy_max_deviation"):
                row[f"{order}_{key}"] = result[key]
        row.update(verdicts(serial, coloured))
        rows.append(row)

    a.out.parent.mkdir(parents=True, exist_ok=True)
    load = os.getloadavg()[0]
    with open(a.out, "w", newline="") as f:
        f.write(f"# commit {git_commit()}\n")
        f.write(f"# machine {platform.node()} ({os.cpu_count()} CPUs, {platform.machine()})\n")
        f.write(f"# command {' '.join(sys.argv)}\n")
        f.write(f"# profile {a.profile}: {len(rows)} physics cells, each run with both orders\n")
        f.write(f"# load {load:.1f} (1-minute average at the end)\n")
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    for target in ("counts_met", "penetration_met", "energy_met"):
        met = sum(r[target] for r in rows)
        print(f"{target}: {met} of {len(rows)} cells")


if __name__ == "__main__":
    sys.exit(run(main, "solver_order_error.py"))
