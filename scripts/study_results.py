"""The study's results read back from its run folders, aggregated, and written as CSV.

Only what exists is read: a missing run (not yet done, another shard's, or a
GPU run on a machine without one) is left out and counted, never filled in.
Rows carry the algorithm that actually ran (summary.json's
parameters.algorithm) next to the one asked for, so a CPU fallback can never
be read as a GPU figure.
"""
import csv
import json
import math
import pathlib
import statistics
import struct

import broadphases

TIMES = ["update_ms", "broadphase_ms", "narrowphase_ms", "solver_ms", "integrate_ms",
         "ccd_query_ms", "total_ms"]
# frames.csv columns the physics table uses when the engine writes them (the lead's FrameReport).
ENERGY = ("kinetic_energy", "potential_energy")


def number(text: str) -> float:
    try:
        return float(text)
    except (TypeError, ValueError):
        return float("nan")


def read_frames(folder: pathlib.Path) -> dict:
    """frames.csv as {column: [float per frame]}; a column the engine adds is read too, and
    a cell that is not a number reads as NaN (the tables use only the columns they name)."""
    with open(folder / "frames.csv", newline="") as f:  # a row at a time: floats held only
        rows = csv.reader(f)
        header = next(rows, None) or []
        columns = [[] for _ in header]
        for row in rows:
            if not row:  # a blank line, as DictReader skips it
                continue
            if len(row) != len(header):  # as DictReader read one (None: NaN; extra left)
                row = (row + [None] * len(header))[:len(header)]
            for cells, cell in zip(columns, row):
                cells.append(number(cell))
    return dict(zip(header, columns)) if columns and columns[0] else {}


def write_csv(path: pathlib.Path, rows: list) -> None:
    if not rows:
        path.unlink(missing_ok=True)
        return
    with open(path, "w", newline="", encoding="utf-8", errors="backslashreplace") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        for row in rows:
            writer.writerow({k: f"{v:.6g}" if isinstance(v, float) else v for k, v in row.items()})


def summaries(jobs: list, experiment: str) -> list:
    """(job, summary.json) for each done `overlap run` job of the experiment."""
    found = []
    for job in jobs:
        if job.experiment == experiment and job.done():
            found.append((job, json.loads((job.folder / "summary.json").read_text())))
    return found


def csv_results(jobs: list, experiment: str) -> list:
    """(job, its CSV's rows as dicts of strings) for each done job of the experiment whose
    result is one CSV file (`job.path`): pairs and latency."""
    found = []
    for job in jobs:
        if job.experiment == experiment and job.done():
            with open(job.path, newline="") as f:
                found.append((job, list(csv.DictReader(f))))
    return found


def timing(timings: dict, column: str, statistic: str) -> float:
    """One statistic of one timing column; NaN where the run did not record it."""
    return timings.get(column, {}).get(statistic, float("nan"))


def sweep_row(job, s: dict) -> dict:
    p, t, c = s["parameters"], s["timings_ms"], s["counts"]
    row = {"scene": p["scene"], "objects": p["objects"], "algo_requested":
           p["algorithm_requested"], "algorithm": p["algorithm"], "rep": job.labels["rep"],
           "frames": p["frames"], "seed": p["seed"],
           # the mean K the run used (--substeps auto), or its fixed K
           "substeps": c["substeps"]["mean"] if "substeps" in c else p["substeps"]}
    for column in TIMES:
        row[column.replace("_ms", "_mean")] = timing(t, column, "mean")
        row[column.replace("_ms", "_median")] = timing(t, column, "median")
    # Of the pair search, what ran beside the narrowphase (NaN: a run older than the column).
    row["search_hidden_mean"] = timing(t, "search_hidden_ms", "mean")
    row.update({"pairs_median": c["pairs"]["median"], "escaped_max": int(c["escaped"]["max"]),
                "sunk_max": int(c["sunk"]["max"]),
                "penetration_max": c["max_penetration"]["max"],
                "state_hash": s["state_hash"], "wall_seconds": s["wall_seconds"],
                "gpu": s["machine"]["gpu"], "folder": str(job.folder)})
    return row


def sweep_runs(jobs: list) -> list:
    """One row per sweep run."""
    return [sweep_row(job, s) for job, s in summaries(jobs, "sweep")]


def label(row: dict) -> str:
    """The algorithm as it ran; a fallback says what was asked for, and a GPU algorithm
    run by the CUDA emulation says so (its times are the CPU's, never a GPU figure)."""
    if row["algorithm"] != row["algo_requested"]:
        return f"{row['algorithm']} (asked {row['algo_requested']})"
    if row["algorithm"] in broadphases.needs_device() and "emulation" in row["gpu"]:
        return f"{row['algorithm']} (CUDA emulation)"
    return row["algorithm"]


STAGES = ("update", "broadphase", "narrowphase", "solver", "integrate", "ccd_query")


def sweep_cell(scene: int, n: int, algo: str, group: list) -> dict:
    """The repetitions of one (scene, n, algorithm) averaged as the paper does."""
    cell = {"scene": scene, "objects": n, "algo": algo,
            "fallback": algo != group[0]["algo_requested"],  # not what was asked: no claim
            "repetitions": len(group), "frames": group[0]["frames"],
            "substeps": group[0]["substeps"]}
    for column in STAGES + ("total",):
        cell[f"{column}_mean"] = statistics.fmean(r[f"{column}_mean"] for r in group)
        cell[f"{column}_median"] = statistics.median(r[f"{column}_median"] for r in group)
    cell["search_hidden_mean"] = statistics.fmean(r["search_hidden_mean"] for r in group)
    cell["total_min"] = min(r["total_mean"] for r in group)
    cell["total_max"] = max(r["total_mean"] for r in group)
    cell.update({"pairs_median": group[0]["pairs_median"],
                 "escaped_max": max(r["escaped_max"] for r in group),
                 "sunk_max": max(r["sunk_max"] for r in group),
                 "penetration_max": max(r["penetration_max"] for r in group),
                 "same_state_every_rep": len({r["state_hash"] for r in group}) == 1})
    return cell


def aggregate_sweep(runs: list) -> list:
    """One row per (scene, n, algorithm as it ran): repetitions averaged as the paper does.

    *_mean is the mean over repetitions of each run's mean frame; total_min
    and total_max bound those run means; *_median is the median over
    repetitions of each run's median frame.
    """
    groups = {}
    for run in runs:
        groups.setdefault((run["scene"], run["objects"], label(run)), []).append(run)
    return [sweep_cell(scene, n, algo, group)
            for (scene, n, algo), group in sorted(groups.items())]


def stage_rows(cells: list) -> list:
    """Each honest sweep cell's frame by stage (ms, means over repetitions), what the named
    stages leave of the total ("other": what a stage the tables do not name takes), and the
    share of the frame a broadphase can change: update + broadphase, in %."""
    rows = []
    for c in cells:
        if c["fallback"]:
            continue
        row = {"scene": c["scene"], "objects": c["objects"], "algo": c["algo"]}
        row.update({stage: c[f"{stage}_mean"] for stage in STAGES})
        named = sum(v for stage, v in row.items() if stage in STAGES and v == v)
        row["other"] = max(0.0, c["total_mean"] - named)
        row["total"] = c["total_mean"]
        row["broadphase_pct"] = 100 * c["broadphase_mean"] / c["total_mean"]
        row["update_broadphase_pct"] = 100 * update_and_broadphase_ms(c) / c["total_mean"]
        rows.append(row)
    return rows


def update_and_broadphase_ms(cell: dict) -> float:
    """The part of a sweep cell's frame a broadphase changes: writing the AABBs and finding
    the pairs (SAP and DBVT do most of their work while the AABBs are written)."""
    return cell["update_mean"] + cell["broadphase_mean"]


def per_frame(runs: list, scene: int, n: int) -> dict:
    """{algo: {column: [per-frame mean over repetitions]}} for update, broadphase, their sum
    and the total."""
    series = {}
    for run in runs:
        if (run["scene"], run["objects"]) != (scene, n) or label(run) != run["algorithm"]:
            continue
        frames = read_frames(pathlib.Path(run["folder"]))
        series.setdefault(run["algorithm"], []).append(frames)
    averaged = {}
    for algo, reps in series.items():
        length = min(len(r["frame"]) for r in reps)
        averaged[algo] = {c: [statistics.fmean(r[c][i] for r in reps) for i in range(length)]
                          for c in ("update_ms", "broadphase_ms", "total_ms")}
        averaged[algo]["update_broadphase_ms"] = [
            u + b for u, b in zip(averaged[algo]["update_ms"], averaged[algo]["broadphase_ms"])]
    return averaged


def per_frame_rows(series: dict) -> list:
    """per_frame()'s series as CSV rows: one per algorithm and frame."""
    return [{"algo": algo, "frame": frame, **{c: values[c][frame] for c in values}}
            for algo, values in sorted(series.items()) for frame in range(len(values["total_ms"]))]


def pair_errors(jobs: list) -> list:
    """One row per algorithm: its pairs on the scene-4 stream against bf's."""
    rows = []
    for job, table in csv_results(jobs, "pairs"):
        frames = [{k: int(v) for k, v in row.items()} for row in table]
        exact = sum(r["exact"] for r in frames)
        extra = [r["extra"] for r in frames]
        device = job.folder / f"{job.labels['algo']}.device.json"
        algo = job.labels["algo"] + (" (CUDA emulation)" if device.exists() else "")
        rows.append({"algo": algo, "frames": len(frames),
                     "exact_mean": exact / len(frames),
                     "reported_mean": statistics.fmean(r["reported"] for r in frames),
                     "missed": sum(r["missed"] for r in frames),
                     "extra_mean": statistics.fmean(extra), "extra_max": max(extra),
                     "extra_share": sum(extra) / exact if exact else 0.0})
    return rows


def box_centres(path: pathlib.Path) -> list:
    """An `overlap record` stream (the .aabbs layout of docs/SCENES.md) as box centres:
    one list per frame (the start, then each frame) of one (x, y, z) per box."""
    data = path.read_bytes()
    objects = struct.unpack_from("<i", data, 256)[0]
    offset = 256 + 16 + 32  # names, four int32, the world AABB; then the start and F frames
    floats = struct.unpack_from(f"<{(len(data) - offset) // 4}f", data, offset)
    box = 8  # min x, y, z, pad, max x, y, z, pad
    return [[tuple((floats[i + k] + floats[i + 4 + k]) / 2 for k in range(3))
             for i in range(start, start + objects * box, box)]
            for start in range(0, len(floats) - objects * box + 1, objects * box)]


def position_error(on: list, off: list) -> dict:
    """How far each box is from where the run without sleep put it (m): the largest over
    every frame and box, where, and the median and largest box's at the end."""
    distance = [[math.dist(a, b) for a, b in zip(frame_on, frame_off)]
                for frame_on, frame_off in zip(on, off)]
    largest = [max(frame) for frame in distance]
    frame = max(range(len(largest)), key=largest.__getitem__)
    box = max(range(len(distance[frame])), key=distance[frame].__getitem__)
    apart = next((index for index, d in enumerate(largest) if d > 0), 0)
    return {"max_m": largest[frame], "max_frame": frame - 1, "max_box": box,
            "end_median_m": statistics.median(distance[-1]), "end_max_m": largest[-1],
            "first_frame_apart": apart - 1}


def ccd_mode(parameters: dict) -> str:
    """--ccd as text; runs from before --ccd auto recorded a bool."""
    ccd = parameters["ccd"]
    return ccd if isinstance(ccd, str) else ("all" if ccd else "off")


def physics_row(s: dict) -> dict:
    """A physics run's cost (ms, mean K) and its errors, from its summary.json."""
    p, t, c = s["parameters"], s["timings_ms"], s["counts"]
    mean_k = c["substeps"]["mean"] if "substeps" in c else float(p["substeps"])
    return {"scene": p["scene"], "objects": p["objects"], "algorithm": p["algorithm"],
            "substeps": p["substeps"], "ccd": ccd_mode(p),
            "sleep": "off" if p.get("sleep", "off") == "off" or p["scene"] >= 3 else "on",
            # runs from before --solver ran Bullet's own settings
            "solver": p.get("solver", "bullet"), "seed": p["seed"], "frames": p["frames"],
            "total_mean": t["total_ms"]["mean"], "total_median": t["total_ms"]["median"],
            "total_max": t["total_ms"]["max"], "mean_k": mean_k,
            "k_x_boxes": mean_k * p["objects"],
            "ccd_bodies_mean": c["ccd_bodies"]["mean"] if "ccd_bodies" in c else float("nan"),
            "escaped_max": int(c["escaped"]["max"]), "escaped_final": c["escaped_final"],
            "sunk_max": int(c["sunk"]["max"]), "sunk_final": c["sunk_final"],
            "penetration_max": c["max_penetration"]["max"],
            "penetration_median": c["max_penetration"]["median"],
            "removed_max": int(c["removed"]["max"]),
            "asleep_max": int(c["sleeping"]["max"]) if "sleeping" in c else 0}


def energy_drift(frames: dict) -> dict:
    """The drift of kinetic + potential energy over the run, where frames.csv has both."""
    if not all(column in frames for column in ENERGY):
        return {}
    energy = [k + u for k, u in zip(*(frames[column] for column in ENERGY))]
    scale = abs(energy[0]) or 1.0
    return {"energy_drift": (energy[-1] - energy[0]) / scale,
            "energy_max_deviation": max(abs(e - energy[0]) for e in energy) / scale}


def sleep_error(row: dict, job, errors: dict) -> dict:
    """The position error sleep caused, on the run it was measured for (the main cell with
    the default substeps and CCD, where the scene sleeps); NaN elsewhere."""
    error = errors.get(row["scene"])
    measured = (error and row["sleep"] == "on" and row["substeps"] == "auto"
                and row["ccd"] == "auto" and job.labels.get("sleep_error_cell", False))
    nan = float("nan")
    return {"sleep_error_max_m": error["max_m"] if measured else nan,
            "sleep_error_end_median_m": error["end_median_m"] if measured else nan}


def physics_order(r: dict) -> tuple:
    return (r["scene"], r["objects"], r["seed"], r["substeps"] == "auto",
            str(r["substeps"]).zfill(3), r["solver"] == "bullet",
            ("off", "auto", "all").index(r["ccd"]), r["sleep"])


def physics_runs(jobs: list) -> list:
    """One row per physics run: cost (ms, mean K) against escapes, sinking, penetration,
    energy drift, and where a run slept, the position error sleep caused."""
    errors = {job.labels["scene"]: json.loads(job.path.read_text()) for job in jobs
              if job.experiment == "physics_sleep" and job.done()}
    rows = []
    for job, s in summaries(jobs, "physics"):
        row = physics_row(s)
        row.update(energy_drift(read_frames(job.folder)))
        row.update(sleep_error(row, job, errors))
        rows.append(row)
    return sorted(rows, key=physics_order)


def latency_rows(jobs: list) -> list:
    """One row per (scene, algorithm, growth) of `overlap latency`'s per-frame CSV."""
    rows = []
    for job, frames in csv_results(jobs, "latency"):
        groups = {}
        for frame in frames:
            groups.setdefault((frame["algo"], float(frame["growth"])), []).append(frame)
        for (algo, growth), group in sorted(groups.items()):
            value = lambda column: [float(r[column]) for r in group]
            exact, missed = value("exact_pairs"), value("missed")
            on_time, late = value("on_time_ms"), value("late_ms")
            rows.append({
                "scene": job.labels["scene"], "objects": job.labels["objects"], "algo": algo,
                "algo_requested": job.labels["algo"], "growth": growth, "frames": len(group),
                "exact_mean": statistics.fmean(exact),
                "on_time_extra_mean": statistics.fmean(
                    o - e for o, e in zip(value("on_time_pairs"), exact)),
                "late_pairs_mean": statistics.fmean(value("late_pairs")),
                "missed_total": int(sum(missed)), "missed_frames": sum(m > 0 for m in missed),
                "missed_max": int(max(missed)),
                "missed_share": sum(missed) / sum(exact) if sum(exact) else 0.0,
                "extra_mean": statistics.fmean(value("extra")),
                "on_time_ms": statistics.median(on_time), "late_ms": statistics.median(late)})
    rows.sort(key=lambda r: (r["scene"], r["algo"], r["growth"]))
    return rows


def typical_frame(spans: list) -> int:
    """The frame whose length is the median of the run's frames after the first (which
    pays for warming up)."""
    frames = sorted((e["dur"], e["args"]["frame"]) for e in spans
                    if e["name"] == "frame" and e["args"]["frame"] > 0)
    if not frames:
        frames = [(e["dur"], e["args"]["frame"]) for e in spans if e["name"] == "frame"]
    return frames[len(frames) // 2][1]


def timeline_frame(folder: pathlib.Path) -> tuple:
    """(frame number, algorithm, [(lane, name, start ms, duration ms)]) of one typical
    frame; times are relative to its start."""
    trace = json.loads((folder / "timeline.json").read_text())["traceEvents"]
    summary = json.loads((folder / "summary.json").read_text())
    lanes = {e["tid"]: e["args"]["name"] for e in trace if e["ph"] == "M"}
    spans = [e for e in trace if e["ph"] == "X"]
    chosen = typical_frame(spans)
    mine = [e for e in spans if e["args"].get("frame") == chosen]
    start = min(e["ts"] for e in mine)
    return chosen, summary["parameters"]["algorithm"], [
        (lanes.get(e["tid"], str(e["tid"])), e["name"], (e["ts"] - start) / 1e3, e["dur"] / 1e3)
        for e in mine]
