"""The study's results read back from its run folders, aggregated, and written as CSV.

Only what exists is read: a missing run (not yet done, another shard's, or a
GPU run on a machine without one) is left out and counted, never filled in.
Rows carry the algorithm that actually ran (summary.json's
parameters.algorithm) next to the one asked for, so a CPU fallback can never
be read as a GPU figure.
"""
import csv
import json
import pathlib
import statistics

TIMES = ["update_ms", "broadphase_ms", "narrowphase_ms", "solver_ms", "integrate_ms", "total_ms"]
# frames.csv columns the physics table uses when the engine writes them (the lead's FrameReport).
ENERGY = ("kinetic_energy", "potential_energy")


def read_frames(folder: pathlib.Path) -> dict:
    """frames.csv as {column: [float per frame]}."""
    with open(folder / "frames.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    return {column: [float(row[column]) for row in rows] for column in rows[0]} if rows else {}


def write_csv(path: pathlib.Path, rows: list) -> None:
    if not rows:
        path.unlink(missing_ok=True)
        return
    with open(path, "w", newline="") as f:
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


def sweep_runs(jobs: list) -> list:
    """One row per sweep run."""
    rows = []
    for job, s in summaries(jobs, "sweep"):
        p, t, c = s["parameters"], s["timings_ms"], s["counts"]
        row = {"scene": p["scene"], "objects": p["objects"], "algo_requested":
               p["algorithm_requested"], "algorithm": p["algorithm"], "rep": job.labels["rep"],
               "frames": p["frames"], "substeps": p["substeps"], "seed": p["seed"]}
        for column in TIMES:
            row[column.replace("_ms", "_mean")] = t[column]["mean"]
            row[column.replace("_ms", "_median")] = t[column]["median"]
        row.update({"pairs_median": c["pairs"]["median"], "escaped_max": int(c["escaped"]["max"]),
                    "sunk_max": int(c["sunk"]["max"]),
                    "penetration_max": c["max_penetration"]["max"],
                    "state_hash": s["state_hash"], "wall_seconds": s["wall_seconds"],
                    "gpu": s["machine"]["gpu"], "folder": str(job.folder)})
        rows.append(row)
    return rows


def label(row: dict) -> str:
    """The algorithm as it ran; a fallback says what was asked for."""
    if row["algorithm"] == row["algo_requested"]:
        return row["algorithm"]
    return f"{row['algorithm']} (asked {row['algo_requested']})"


def aggregate_sweep(runs: list) -> list:
    """One row per (scene, n, algorithm as it ran): repetitions averaged as the paper does.

    *_mean is the mean over repetitions of each run's mean frame; total_min
    and total_max bound those run means; *_median is the median over
    repetitions of each run's median frame.
    """
    groups = {}
    for run in runs:
        groups.setdefault((run["scene"], run["objects"], label(run)), []).append(run)
    cells = []
    for (scene, n, algo), group in sorted(groups.items()):
        cell = {"scene": scene, "objects": n, "algo": algo,
                "fallback": group[0]["algorithm"] != group[0]["algo_requested"],
                "repetitions": len(group), "frames": group[0]["frames"],
                "substeps": group[0]["substeps"]}
        for column in ("update", "broadphase", "narrowphase", "solver", "integrate", "total"):
            cell[f"{column}_mean"] = statistics.fmean(r[f"{column}_mean"] for r in group)
            cell[f"{column}_median"] = statistics.median(r[f"{column}_median"] for r in group)
        cell["total_min"] = min(r["total_mean"] for r in group)
        cell["total_max"] = max(r["total_mean"] for r in group)
        cell.update({"pairs_median": group[0]["pairs_median"],
                     "escaped_max": max(r["escaped_max"] for r in group),
                     "sunk_max": max(r["sunk_max"] for r in group),
                     "penetration_max": max(r["penetration_max"] for r in group),
                     "same_state_every_rep": len({r["state_hash"] for r in group}) == 1})
        cells.append(cell)
    return cells


def per_frame(runs: list, scene: int, n: int) -> dict:
    """{algo: {column: [per-frame mean over repetitions]}} for update, broadphase and total."""
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
    return averaged


def pair_errors(jobs: list) -> list:
    """One row per algorithm: its pairs on the scene-4 stream against bf's."""
    rows = []
    for job, table in csv_results(jobs, "pairs"):
        frames = [{k: int(v) for k, v in row.items()} for row in table]
        exact = sum(r["exact"] for r in frames)
        extra = [r["extra"] for r in frames]
        rows.append({"algo": job.labels["algo"], "frames": len(frames),
                     "exact_mean": exact / len(frames),
                     "reported_mean": statistics.fmean(r["reported"] for r in frames),
                     "missed": sum(r["missed"] for r in frames),
                     "extra_mean": statistics.fmean(extra), "extra_max": max(extra),
                     "extra_share": sum(extra) / exact if exact else 0.0})
    return rows


def physics_runs(jobs: list) -> list:
    """One row per (scene, substeps, ccd): cost against escapes, sinking, penetration, energy."""
    rows = []
    for job, s in summaries(jobs, "physics"):
        p, t, c = s["parameters"], s["timings_ms"], s["counts"]
        row = {"scene": p["scene"], "objects": p["objects"], "algorithm": p["algorithm"],
               "substeps": p["substeps"], "ccd": p["ccd"], "frames": p["frames"],
               "total_mean": t["total_ms"]["mean"], "total_median": t["total_ms"]["median"],
               "escaped_max": int(c["escaped"]["max"]), "escaped_final": c["escaped_final"],
               "sunk_max": int(c["sunk"]["max"]), "sunk_final": c["sunk_final"],
               "penetration_max": c["max_penetration"]["max"],
               "penetration_median": c["max_penetration"]["median"],
               "removed_max": int(c["removed"]["max"])}
        frames = read_frames(job.folder)
        if all(column in frames for column in ENERGY):
            energy = [k + u for k, u in zip(*(frames[column] for column in ENERGY))]
            scale = abs(energy[0]) or 1.0
            row["energy_drift"] = (energy[-1] - energy[0]) / scale
            row["energy_max_deviation"] = max(abs(e - energy[0]) for e in energy) / scale
        rows.append(row)
    rows.sort(key=lambda r: (r["scene"], r["ccd"], r["substeps"]))
    return rows


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


def timeline_frame(folder: pathlib.Path) -> tuple:
    """(frame number, algorithm, [(lane, name, start ms, duration ms)]) of one typical frame.

    The frame is the one whose length is the median of the run's frames after
    the first (which pays for warming up); times are relative to its start.
    """
    trace = json.loads((folder / "timeline.json").read_text())["traceEvents"]
    summary = json.loads((folder / "summary.json").read_text())
    lanes = {e["tid"]: e["args"]["name"] for e in trace if e["ph"] == "M"}
    spans = [e for e in trace if e["ph"] == "X"]
    frames = sorted((e["dur"], e["args"]["frame"]) for e in spans
                    if e["name"] == "frame" and e["args"]["frame"] > 0)
    if not frames:
        frames = [(e["dur"], e["args"]["frame"]) for e in spans if e["name"] == "frame"]
    chosen = frames[len(frames) // 2][1]
    mine = [e for e in spans if e["args"]["frame"] == chosen]
    start = min(e["ts"] for e in mine)
    return chosen, summary["parameters"]["algorithm"], [
        (lanes[e["tid"]], e["name"], (e["ts"] - start) / 1e3, e["dur"] / 1e3) for e in mine]
