"""The overlap-timing experiment: the asynchronous frame against --sync.

Each point is a few `overlap run --task-load X --compare-sync` processes
(--overlap-repetitions): in each, a sync run (the frame's jobs one after
another) and the async run (the sound and AI tasks beside the whole physics
step), same sizes, same seed, stepped in turn frame by frame so that the
machine's drifts reach both alike.  From the two runs' per-frame medians, each
figure is the median over the point's processes (the speed-up also with its
range between them):

  sync, async   frame time, snapshot to join
  speed-up      sync / async
  P, T          the sync run's physics step and task time (sound + AI)
  measured load T / P (the knob X sizes the tasks from the scene's first
                frames; a settled pile costs more, so T / P is what to read)
  hidden        the share of the tasks' time the async frame saved:
                (sync - async) / T, clipped to [0, 1]; none when T < P / 100
  ideal         what this machine allows: max(P, T) when the physics (main
                thread) and the tasks (a worker) each have a core, P + T when
                there is one thread; async / ideal says how close it comes
"""
import statistics

import study_plots
import study_results
from study_targets import Target, not_run
import study_targets


def process_row(s: dict) -> dict:
    """One `--compare-sync` process's point: its ratios are measured in one process."""
    p, c = s["parameters"], s["compare_sync"]
    threads = p["threads"] or s["machine"]["hardware_threads"]
    physics, tasks = c["sync_physics_ms_median"], c["sync_tasks_ms_median"]
    ideal = max(physics, tasks) if threads >= 2 else physics + tasks
    sync, async_ = c["sync_total_ms_median"], c["async_total_ms_median"]
    return {
        "scene": p["scene"], "objects": p["objects"], "load": p["task_load"],
        "algorithm": p["algorithm"], "threads": threads, "frames": p["frames"],
        "sync_ms": sync, "async_ms": async_, "speedup": sync / async_,
        "physics_ms": physics, "tasks_ms": tasks, "ideal_ms": ideal,
        "async_over_ideal": async_ / ideal,
        "identical": c["identical_state"] and c["identical_tasks"]}


def overlap_rows(jobs: list) -> list:
    """One row per (scene, n, load): medians over its processes, the speed-up's range."""
    points = {}
    for job, s in study_results.summaries(jobs, "overlap"):
        r = process_row(s)
        points.setdefault((r["scene"], r["objects"], r["load"]), []).append(r)
    rows = []
    for (scene, n, load), runs in sorted(points.items()):
        med = {k: statistics.median(r[k] for r in runs)
               for k in ("sync_ms", "async_ms", "speedup", "physics_ms", "tasks_ms", "ideal_ms",
                         "async_over_ideal")}
        physics, tasks = med["physics_ms"], med["tasks_ms"]
        rows.append({
            "scene": scene, "objects": n, "load": load, "algorithm": runs[0]["algorithm"],
            "threads": runs[0]["threads"], "frames": runs[0]["frames"],
            "repetitions": len(runs),
            "measured_load": tasks / physics if physics > 0 else float("nan"), **med,
            "speedup_min": min(r["speedup"] for r in runs),
            "speedup_max": max(r["speedup"] for r in runs),
            # Tasks of under 1% of the step hide nothing measurable.
            "hidden": (min(1.0, max(0.0, (med["sync_ms"] - med["async_ms"]) / tasks))
                       if tasks > 0.01 * physics else float("nan")),
            "ideal_speedup": med["sync_ms"] / med["ideal_ms"],
            "identical": all(r["identical"] for r in runs)})
    return rows


def at_load_one(rows: list) -> Target:
    name = "async at least x1.6 of sync at task load 1 in scene 4, every n"
    mine = [r for r in rows if r["scene"] == 4 and r["load"] == 1]
    if not mine:
        return not_run(name)
    missed = [r for r in mine if r["speedup"] < 1.6]
    return Target(name, ", ".join(f"n {r['objects']}: x{r['speedup']:.2f}" for r in mine),
                  not missed)


def near_ideal(rows: list) -> Target:
    name = "async within 10% of this machine's ideal frame at every point"
    if not rows:
        return not_run(name)
    ratios = [r["async_over_ideal"] for r in rows]
    return Target(name, f"async / ideal x{min(ratios):.2f}-x{max(ratios):.2f}",
                  max(ratios) <= 1.1)


def no_slower_at_zero(rows: list) -> Target:
    """As in the sweep, a median below 1 inside the processes' range is no difference."""
    name = "at task load 0, async no slower than sync (every process below x1: slower)"
    mine = [r for r in rows if r["load"] == 0]
    if not mine:
        return not_run(name)
    slower = [r for r in mine if r["speedup_max"] < 1.0]
    low, high = min(r["speedup"] for r in mine), max(r["speedup"] for r in mine)
    return Target(name, f"speed-up x{low:.2f}-x{high:.2f}"
                  + (f"; slower at {len(slower)} of {len(mine)} points" if slower else ""),
                  not slower)


def targets(rows: list) -> list:
    """The section's targets (the findings' verdict for the asynchronous frame)."""
    return [at_load_one(rows), near_ideal(rows), no_slower_at_zero(rows)]


def overlap_section(rows: list, figures: dict, fmt, table) -> list:
    if not rows:
        return ["No overlap runs yet.", ""]
    algorithms = sorted({r["algorithm"] for r in rows})
    lines = [f"Broadphase {', '.join(algorithms)}; {rows[0]['frames']} frames per run; "
             f"threads {rows[0]['threads']}. A row: the median over its point's "
             "`overlap run --task-load X --compare-sync` processes; range: the speed-up's "
             "between them. Ideal: max(P, T) with a core each, P + T with one thread.", ""]
    headers = ["scene", "n", "load X", "T/P measured", "sync ms", "async ms", "speed-up", "range",
               "hidden", "ideal ms", "async / ideal", "identical"]
    body = [[r["scene"], r["objects"], f"{r['load']:g}", fmt(r["measured_load"]),
             fmt(r["sync_ms"]), fmt(r["async_ms"]), f"{r['speedup']:.2f}",
             f"{r['speedup_min']:.2f}-{r['speedup_max']:.2f}",
             fmt(r["hidden"]), fmt(r["ideal_ms"]), f"{r['async_over_ideal']:.2f}",
             "yes" if r["identical"] else "**no**"] for r in rows]
    lines += table(headers, body)
    name = study_plots.overlap(rows, figures["folder"])
    lines += [f"![overlap: frame time and speed-up against the task load](report/{name})", ""]
    lines += study_targets.lines(targets(rows), table)
    if not all(r["identical"] for r in rows):
        lines += ["**Sync and async runs did not end identical at some points** (state or "
                  "task checksums): see overlap.csv's `identical`.", ""]
    return lines
