"""The study's physics section: substeps, CCD, sleep and the contact solver
against escapes, sinking and penetration, and the automatic setting against the fixed K
the project ran before (8 substeps at 50 g, 2 at 1 g, Bullet's own solver settings).

Rows come from study_results.physics_runs.  The main table is one size and seed; the
comparison cells (the automatic setting and the old fixed K, both solvers) also run at
more seeds and sizes, so that a target met on one seed is not taken for a rule.
"""
import csv
import statistics

import results_files
import study_plots
import study_targets
from study_tables import plain
from study_targets import Target


def old_default_k(scene: int) -> int:
    """The fixed K every frame used before --substeps auto: 8 at 50 g, 2 at 1 g."""
    return 8 if scene >= 3 else 2


def time_share(scene: int) -> float:
    """Issue 14's time target for the automatic setting, as a share of the old K's."""
    return 0.6 if scene >= 3 else 1.0


def setting(row: dict) -> str:
    """A physics run's options as a user types them."""
    return (f"K={row['substeps']}, ccd {row['ccd']}"
            + (", no sleep" if row["scene"] <= 2 and row["sleep"] == "off" else "")
            + (", solver bullet" if row["solver"] == "bullet" else ""))


def compare(auto: dict, base: dict) -> tuple:
    """(time ratio, load-free cost ratio, what the automatic run misses against base)."""
    time = auto["total_median"] / base["total_median"]
    cost = auto["k_x_boxes"] / base["k_x_boxes"]
    misses = [name for name, mine, theirs in (
        ("escaped", auto["escaped_max"], 0 if auto["scene"] >= 3 else base["escaped_max"]),
        ("sunk", auto["sunk_max"], base["sunk_max"]),
        ("penetration", auto["penetration_max"], base["penetration_max"])) if mine > theirs]
    if time > time_share(auto["scene"]):
        misses.append(f"time ({time:.2f} > {time_share(auto['scene'])})")
    return time, cost, misses


def find(rows: list, substeps, ccd: str, solver: str):
    for r in rows:
        if (str(r["substeps"]) == str(substeps) and r["ccd"] == ccd and r["solver"] == solver
                and (r["sleep"] != "off" or r["scene"] >= 3)):
            return r
    return None


def comparisons(scene: int, rows: list) -> list:
    """(auto, base) pairs: the automatic setting against the old K with the same solver
    (pile) and with Bullet's (the project's old default), each with the same CCD and
    without CCD."""
    k, found = old_default_k(scene), []
    for ccd in ("off", "auto"):
        auto = find(rows, "auto", ccd, "pile")
        for solver in ("pile", "bullet"):
            for against in dict.fromkeys((ccd, "off")):
                base = find(rows, k, against, solver)
                if auto is not None and base is not None:
                    found.append((auto, base))
    return found


def comparison_row(auto: dict, base: dict, fmt) -> list:
    time, cost, misses = compare(auto, base)
    return [auto["scene"], setting(auto), setting(base), f"x{time:.2f}", f"x{cost:.2f}",
            f"{auto['escaped_max']} / {base['escaped_max']}",
            f"{auto['sunk_max']} / {base['sunk_max']}",
            f"{fmt(auto['penetration_max'])} / {fmt(base['penetration_max'])}",
            "met" if not misses else "missed: " + ", ".join(misses)]


def comparison_lines(main: list, fmt, table) -> list:
    body = [comparison_row(auto, base, fmt)
            for scene in sorted({r["scene"] for r in main})
            for auto, base in comparisons(scene, [r for r in main if r["scene"] == scene])]
    if not body:
        return []
    return (["The automatic setting against the old fixed K (time and mean K x boxes: auto / "
             "old; each error: auto / old; target: no more error, and time at most x0.6 of "
             "the old at 50 g, x1.0 at 1 g):", ""]
            + table(["scene", "auto", "against", "time", "K x boxes", "escaped max",
                     "sunk max", "deepest pen. / edge", "target"], body))


def default_against_old(rows: list) -> list:
    """(scene, boxes, seed, auto, old) for every seed and size where both the default
    (--substeps auto --ccd auto, solver pile) and the old default (K fixed, no CCD,
    Bullet's solver) ran, in (scene, boxes, seed) order."""
    cells = []
    for scene, n, seed in sorted({(r["scene"], r["objects"], r["seed"]) for r in rows}):
        mine = [r for r in rows if (r["scene"], r["objects"], r["seed"]) == (scene, n, seed)]
        auto = find(mine, "auto", "auto", "pile")
        base = find(mine, old_default_k(scene), "off", "bullet")
        if auto is not None and base is not None:
            cells.append((scene, n, seed, auto, base))
    return cells


def cell_target(cell: tuple, fmt) -> Target:
    scene, n, seed, auto, base = cell
    time, _, misses = compare(auto, base)
    return Target(f"scene {scene}, {n} boxes, seed {seed}",
                  f"time x{time:.2f}; escaped {auto['escaped_max']} / {base['escaped_max']}, "
                  f"sunk {auto['sunk_max']} / {base['sunk_max']}, pen. "
                  f"{fmt(auto['penetration_max'])} / {fmt(base['penetration_max'])}"
                  + ("" if not misses else "; missed on " + ", ".join(misses)), not misses)


def targets(rows: list, fmt) -> list:
    """The section's targets, one per (scene, boxes, seed) the comparison ran: the default
    (--substeps auto --ccd auto, solver pile) against the old default (K fixed, no CCD,
    Bullet's solver).  The findings' verdict for the physics claim."""
    return [cell_target(cell, fmt) for cell in default_against_old(rows)]


def robustness_lines(rows: list, fmt, table) -> list:
    """The targets at every seed and size the comparison cells ran, then summed by size."""
    cells = default_against_old(rows)
    if not cells:
        return []
    return (["Target, at every seed and size the comparison ran: the default (`--substeps "
             "auto --ccd auto`, solver pile) costs less than the old default (K=8 at 50 g, "
             "K=2 at 1 g, no CCD, Bullet's solver), with no more error; each error auto / old:",
             ""]
            + study_targets.lines(targets(rows, fmt), table)
            + seed_summary_lines(cells, fmt, table))


def seed_summary_row(scene: int, n: int, pairs: list, fmt) -> list:
    times = sorted(compare(auto, base)[0] for auto, base in pairs)
    median = lambda key, side: fmt(statistics.median(p[side][key] for p in pairs))  # noqa: E731
    return [scene, n, len(pairs), sum(not compare(a, b)[2] for a, b in pairs),
            f"x{statistics.median(times):.2f} (x{times[0]:.2f}-x{times[-1]:.2f})",
            f"{median('penetration_max', 0)} / {median('penetration_max', 1)}",
            sum(a["penetration_max"] > b["penetration_max"] for a, b in pairs),
            sum(a["sunk_max"] > b["sunk_max"] for a, b in pairs),
            sum(a["escaped_max"] > 0 for a, _ in pairs)]


def seed_summary_lines(cells: list, fmt, table) -> list:
    """default_against_old's cells summed over the seeds of each (scene, size) that ran at
    more than one: a chaotic pile's deepest overlap over a run is one draw, so a cell met or
    missed at one seed says little; how often and by how much it is met says more."""
    by_size = {}
    for scene, n, _, auto, base in cells:
        by_size.setdefault((scene, n), []).append((auto, base))
    body = [seed_summary_row(scene, n, pairs, fmt)
            for (scene, n), pairs in sorted(by_size.items()) if len(pairs) >= 2]
    if not body:
        return []
    return (["Summed over the seeds of each size (the same runs):", ""]
            + table(["scene", "boxes", "seeds", "target met", "time, median (range)",
                     "deepest pen. median, auto / old", "seeds auto deeper",
                     "seeds auto more sunk", "seeds auto escaped"], body))


# Every column of every run is in physics.csv; the report's tables keep these.
HEADERS = ["K", "ccd", "sleep", "solver", "ms median", "mean K", "escaped max", "sunk max",
           "deepest pen. / edge", "sleep error max (m)"]


def run_row(r: dict, fmt) -> list:
    return [r["substeps"], r["ccd"], r["sleep"], r["solver"], fmt(r["total_median"]),
            fmt(r["mean_k"]), r["escaped_max"], r["sunk_max"], fmt(r["penetration_max"]),
            fmt(r["sleep_error_max_m"])]


def cheapest_safe_row(scene: int, mine: list, fmt) -> list:
    """The cheapest run with no box escaping and none left inside a wall at the end."""
    safe = [r for r in mine if r["escaped_max"] == 0 and r["sunk_final"] == 0]
    if not safe:
        return [scene, "none", "—", "—", "—"]
    best = min(safe, key=lambda r: (r["total_median"], r["penetration_max"]))
    return [scene, setting(best), fmt(best["total_median"]), best["sunk_max"],
            fmt(best["penetration_max"])]


def scene_tables(main: list, fmt, table) -> list:
    scenes = sorted({r["scene"] for r in main})
    lines = []
    for scene in scenes:
        lines += [f"Scene {scene}:", ""] + table(
            HEADERS, [run_row(r, fmt) for r in main if r["scene"] == scene])
    lines += ["The cheapest run with no box escaping and none inside a wall at the end:", ""]
    return lines + table(["scene", "setting", "ms median", "sunk max", "deepest pen. / edge"],
                         [cheapest_safe_row(s, [r for r in main if r["scene"] == s], fmt)
                          for s in scenes])


def physics_section(rows: list, figures: dict, fmt, table, objects: int, seed: int) -> list:
    main = [r for r in rows if r["objects"] == objects and r["seed"] == seed]
    if not main:
        return ["No physics runs yet.", ""]
    lines = [f"{objects} boxes, {main[0]['frames']} frames, seed {seed}, broadphase "
             f"{main[0]['algorithm']}, `--no-tasks`. K: fixed substeps or `--substeps auto` "
             "(its mean); solver `pile` (the default) or `bullet` (Bullet 3.24's own); "
             "sleep error: the largest distance between a box with sleep and the same box "
             "without. Every column of every run is in physics.csv.", ""]
    lines += scene_tables(main, fmt, table) + comparison_lines(main, fmt, table)
    study_plots.physics(main, figures["folder"])
    lines += ["![physics: each error against the cost per frame](report/fig_physics.png)", ""]
    return lines + robustness_lines(rows, fmt, table)


# --- the coloured solver against Bullet's serial solver ------------------------------

# (what is compared, the column stem after serial_ / coloured_, how a row reads it)
SOLVER_ORDER_METRICS = (("escaped", "escaped_max", "max"), ("sunk", "sunk_max", "max"),
                        ("removed", "removed_max", "max"),
                        ("deepest pen.", "penetration_max", "max"),
                        ("energy drift", "energy_drift", "median"))
PENETRATION_FACTOR = 1.1  # the coloured solver's deepest overlap at most this x serial's


def solver_order_worse(stem: str, serial: float, coloured: float) -> bool:
    """Whether a cell's coloured figure misses its target against the serial one: counts
    no higher, penetration at most x1.1, energy drift no larger in size."""
    if stem == "penetration_max":
        return coloured > PENETRATION_FACTOR * serial
    if stem == "energy_drift":
        return abs(coloured) > abs(serial)
    return coloured > serial


def solver_order_rows(cells: list, present: list) -> list:
    """One row per scene of the comparison's cells: each present metric's serial and
    coloured figure over the scene's cells (max, or the energy drift's median) and the
    cells where the coloured one misses its target."""
    rows = []
    for scene in sorted({c["scene"] for c in cells}):
        mine = [c for c in cells if c["scene"] == scene]
        row = {"scene": scene, "cells": len(mine)}
        for _, stem, statistic in SOLVER_ORDER_METRICS:
            if stem not in present:
                continue
            both = [(c[f"serial_{stem}"], c[f"coloured_{stem}"]) for c in mine
                    if c[f"serial_{stem}"] == c[f"serial_{stem}"]
                    and c[f"coloured_{stem}"] == c[f"coloured_{stem}"]]
            pick = max if statistic == "max" else statistics.median
            nan = float("nan")
            row[f"serial_{stem}"] = pick(s for s, _ in both) if both else nan
            row[f"coloured_{stem}"] = pick(c for _, c in both) if both else nan
            row[f"worse_{stem}"] = sum(solver_order_worse(stem, s, c) for s, c in both)
        rows.append(row)
    return rows


def number(text) -> float:
    try:
        return float(text)
    except (TypeError, ValueError):
        return float("nan")


def solver_order_section(path, fmt, table, shown_path: str) -> tuple:
    """(the block's lines, its summary rows for report/solver_order.csv) from the coloured
    solver's comparison file (one row per physics cell, serial_X and coloured_X columns):
    "not measured" when the file is absent; a metric whose columns are missing is left
    out, named in one line; a file without a scene column is named and not read."""
    if not path.exists():
        return ([f"Not measured: {shown_path} is absent (the coloured solver against "
                 "Bullet's serial solver, over the study's physics cells).", ""], [])
    try:
        raw = results_files.read_csv(path)
    except (OSError, UnicodeDecodeError, csv.Error) as error:
        return ([f"Not measured: {shown_path} cannot be read ({error.__class__.__name__})."
                 , ""], [])
    columns = set(raw[0]) if raw else set()
    if "scene" not in columns:
        return ([f"Not measured: {shown_path} has no `scene` column"
                 + ("" if raw else " (no rows)") + ".", ""], [])
    present = [stem for _, stem, _ in SOLVER_ORDER_METRICS
               if {f"serial_{stem}", f"coloured_{stem}"} <= columns]
    missing = [f"{side}_{stem}" for _, stem, _ in SOLVER_ORDER_METRICS if stem not in present
               for side in ("serial", "coloured") if f"{side}_{stem}" not in columns]
    cells = [{"scene": row["scene"], **{f"{side}_{stem}": number(row[f"{side}_{stem}"])
                                        for stem in present for side in ("serial", "coloured")}}
             for row in raw]
    rows = solver_order_rows(cells, present)
    notes = [line[1:].strip() for line in path.read_text().splitlines()
             if line.startswith("#")][:4]
    lines = [f"From {shown_path}: {len(cells)} physics cells, each run with Bullet's serial "
             "solver and the coloured one at the same K"
             + (f" ({'; '.join(plain(n) for n in notes)})" if notes else "") + ". Each "
             "figure serial / coloured over a scene's cells: the largest (counts, deepest "
             "penetration / edge) or the median (energy drift, relative); worse: the cells "
             f"where the coloured solver has more escaped, sunk or removed boxes, over "
             f"x{PENETRATION_FACTOR} the penetration, or a larger drift.", ""]
    if missing:
        lines += [f"{shown_path} has no column {', '.join(missing)}: "
                  + ", ".join(label for label, stem, _ in SOLVER_ORDER_METRICS
                              if stem not in present) + " not compared.", ""]
    shown = [(label, stem) for label, stem, _ in SOLVER_ORDER_METRICS if stem in present]

    def figure(stem: str, value: float) -> str:  # counts as counts
        counted = stem in ("escaped_max", "sunk_max", "removed_max") and value == value
        return f"{value:g}" if counted else fmt(value)
    body = [[r["scene"], r["cells"]]
            + [f"{figure(stem, r[f'serial_{stem}'])} / {figure(stem, r[f'coloured_{stem}'])}"
               for _, stem in shown]
            + [" / ".join(str(r[f"worse_{stem}"]) for _, stem in shown) or "—"] for r in rows]
    headers = (["scene", "cells"] + [label for label, _ in shown]
               + ["cells worse (" + ", ".join(label for label, _ in shown) + ")"])
    return lines + table(headers, body), rows
