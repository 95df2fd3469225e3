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

The frame against the ideal for the cores it had (ideal_rows): at each
(scene, n, load, threads) of the --ideal-* options, one async run at --threads N
(no --compare-sync).  Its ideal frame is the CPU time of all the run's threads
over the frame (physics and tasks: frames.csv's cpu_ms) / N, what the frame
would take if no core ever idled; frame / ideal says how much of the cores the
frame left idle.  Medians are over frames 1 onward (frame 0 pays for warming
up), then over the point's processes.
"""
import math
import statistics

import broadphases
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


# --- the frame against the ideal for its cores ---------------------------------

IDEAL_LOAD, IDEAL_THREADS, IDEAL_LIMIT = 1.0, 2, 1.15  # the target's point and its bound


def ideal_process(job, s: dict) -> dict:
    """One run's medians over frames 1 onward: the frame, and its ideal cpu_ms / threads
    (NaN where frames.csv has no cpu_ms: a run older than that column)."""
    frames = study_results.read_frames(job.folder)
    threads = s["parameters"]["threads"] or s["machine"]["hardware_threads"]
    totals = frames.get("total_ms", [])[1:] or frames.get("total_ms", [])
    cpu = frames.get("cpu_ms", [])[1:] or frames.get("cpu_ms", [])
    ideal = [c / threads for c in cpu if c == c]
    return {"frame_ms": statistics.median(totals) if totals else float("nan"),
            "ideal_ms": statistics.median(ideal) if ideal else float("nan"),
            "threads": threads, "algorithm": s["parameters"]["algorithm"],
            "frames": s["parameters"]["frames"]}


def ideal_rows(jobs: list) -> list:
    """One row per (scene, n, load, threads): the frame's and the ideal's medians over the
    point's processes, and frame / ideal."""
    points = {}
    for job, s in study_results.summaries(jobs, "overlap_ideal"):
        l = job.labels
        points.setdefault((l["scene"], l["objects"], l["load"], l["threads"]), []).append(
            ideal_process(job, s))
    rows = []
    for (scene, n, load, threads), runs in sorted(points.items()):
        frame = statistics.median(r["frame_ms"] for r in runs)
        ideal = statistics.median(r["ideal_ms"] for r in runs)
        rows.append({"scene": scene, "objects": n, "load": load, "threads": threads,
                     "threads_used": runs[0]["threads"], "algorithm": runs[0]["algorithm"],
                     "frames": runs[0]["frames"], "repetitions": len(runs),
                     "frame_ms": frame, "ideal_ms": ideal,
                     "frame_over_ideal": frame / ideal if ideal > 0 else float("nan")})
    return rows


def within_ideal(rows: list) -> Target:
    """At task load 1 on 2 threads: the frame within 1.15x of the ideal, at every (scene,
    n) that ran there."""
    name = (f"at task load {IDEAL_LOAD:g} on {IDEAL_THREADS} threads: the frame within "
            f"x{IDEAL_LIMIT} of the ideal (cpu_ms / threads)")
    mine = [r for r in rows if r["load"] == IDEAL_LOAD and r["threads_used"] == IDEAL_THREADS
            and not math.isnan(r["frame_over_ideal"])]
    if not mine:
        return not_run(name)
    return Target(name, ", ".join(f"scene {r['scene']}, n {r['objects']}: "
                                  f"x{r['frame_over_ideal']:.2f}" for r in mine),
                  all(r["frame_over_ideal"] <= IDEAL_LIMIT for r in mine))


def ideal_targets(rows: list) -> list:
    """The ideal table's targets (the findings' verdict for the frame on its cores)."""
    return [within_ideal(rows)]


def ideal_section(rows: list, fmt, table) -> list:
    if not rows:
        return ["No runs against the ideal yet.", ""]
    lines = [f"Broadphase {', '.join(sorted({r['algorithm'] for r in rows}))}; "
             f"{rows[0]['frames']} frames per run, medians over frames 1 onward, then over "
             "the point's processes. One async run at `--threads N` each; ideal: the CPU "
             "time of all its threads over the frame (physics and tasks, frames.csv's "
             "`cpu_ms`) / N, the frame if no core idled.", ""]
    if any(math.isnan(r["ideal_ms"]) for r in rows):
        lines += ["Some runs' frames.csv has no `cpu_ms` column (runs older than it): their "
                  "ideal is not measured (—).", ""]
    lines += table(["scene", "n", "load X", "threads", "runs", "frame ms", "ideal ms",
                    "frame / ideal"],
                   [[r["scene"], r["objects"], f"{r['load']:g}", r["threads_used"],
                     r["repetitions"], fmt(r["frame_ms"]), fmt(r["ideal_ms"]),
                     fmt(r["frame_over_ideal"])] for r in rows])
    return lines + study_targets.lines(ideal_targets(rows), table)


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


# --- the search beside the narrowphase -------------------------------------------

def hidden_rows(cells: list) -> list:
    """Our finders' sweep cells at each scene's largest n: of the pair search, what ran
    beside the narrowphase (search_hidden_ms) against what the main thread spent in the
    broadphase (broadphase_ms: the cache update and its wait for the search), per frame,
    means over the repetitions; hidden share: hidden / (hidden + broadphase)."""
    ours = [c for c in cells if not c["fallback"]
            and c["algo"].split(" ")[0] in broadphases.ours()]
    rows = []
    for scene in sorted({c["scene"] for c in ours}):
        n = max(c["objects"] for c in ours if c["scene"] == scene)
        for c in (c for c in ours if (c["scene"], c["objects"]) == (scene, n)):
            hidden, main = c["search_hidden_mean"], c["broadphase_mean"]
            rows.append({"scene": scene, "objects": n, "algo": c["algo"],
                         "search_hidden_ms": hidden, "broadphase_ms": main,
                         "hidden_share": hidden / (hidden + main) if hidden + main > 0
                         else float("nan")})
    return rows


def hidden_section(rows: list, fmt, table) -> list:
    if not rows:
        return ["No sweep runs of our finders yet.", ""]
    lines = ["Our finders in the sweep (`--narrowphase beside-search`, the default), each "
             "scene's largest n, ms per frame (means over repetitions). Hidden: of the pair "
             "search, what ran beside the narrowphase (frames.csv's `search_hidden_ms`); "
             "broadphase: the main thread's part (the pair cache's update and its wait for "
             "the search); share: hidden / (hidden + broadphase).", ""]
    if any(math.isnan(r["search_hidden_ms"]) for r in rows):
        lines += ["Some runs' frames.csv has no `search_hidden_ms` column (runs older than "
                  "it): not measured (—).", ""]
    return lines + table(["scene", "n", "algo", "search hidden ms", "broadphase ms",
                          "hidden share"],
                         [[r["scene"], r["objects"], r["algo"], fmt(r["search_hidden_ms"]),
                           fmt(r["broadphase_ms"]),
                           "—" if math.isnan(r["hidden_share"]) else
                           f"{100 * r['hidden_share']:.0f}%"] for r in rows])
