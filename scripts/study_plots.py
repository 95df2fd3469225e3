"""The study's figures (matplotlib, Agg backend), each saved as PNG and SVG.

Every function takes rows already measured and aggregated by study_results
and draws them as they are: no smoothing, no fitted curves.  Each algorithm
keeps one colour across all figures.  matplotlib is imported at the first
figure, not with this module: the study's runs need only the standard
library (a GPU machine's python3 may have nothing else), the report's
figures need Debian's python3-matplotlib, which scripts/setup.sh installs.
"""
import importlib
import math
import pathlib
import sys


class _Pyplot:
    """matplotlib.pyplot, imported (with the Agg backend) on first use."""

    def __getattr__(self, name: str):
        try:
            matplotlib = importlib.import_module("matplotlib")
        except ImportError:
            sys.exit(f"study: {sys.executable} has no matplotlib, which the figures need: make "
                     "the report with /usr/bin/python3 (Debian's python3-matplotlib, which "
                     "scripts/setup.sh installs); the runs alone need only --runs-only")
        matplotlib.use("Agg")
        return getattr(importlib.import_module("matplotlib.pyplot"), name)


plt = _Pyplot()

COLOURS = {"bf": "#444444", "sap": "#1f77b4", "sap32": "#17becf", "bvh": "#2ca02c",
           "cpubf": "#ff7f0e", "cpusap": "#8c564b", "gpubf": "#d62728", "gpubf-paper": "#9467bd",
           "gpusap": "#e377c2"}
LANE_COLOURS = {"frame": "#eeeeee", "physics": "#cccccc", "substep": "#aaaaaa",
                "broadphase": "#d62728", "narrowphase": "#9467bd",
                "tasks": "#dddddd", "sound": "#1f77b4", "ai": "#2ca02c",
                "wait for tasks": "#ff7f0e"}


def colour(algo: str) -> str:
    return COLOURS.get(algo.split(" ")[0], "#e377c2")


def save(figure, folder: pathlib.Path, name: str) -> str:
    """Writes NAME.png and NAME.svg into `folder`; returns NAME.png."""
    folder.mkdir(parents=True, exist_ok=True)
    figure.tight_layout()
    figure.savefig(folder / f"{name}.png", dpi=120)
    # No date and fixed clip-path ids, so the same results give the same SVG bytes
    # and a regenerated report differs only where its numbers do.
    with plt.rc_context({"svg.hashsalt": "overlap"}):
        figure.savefig(folder / f"{name}.svg", metadata={"Date": None})
    plt.close(figure)
    return f"{name}.png"


def keyframes(images: list, frames: list, folder: pathlib.Path) -> str:
    """Figure 1: rows of (scene, [PNG per keyframe]) as one montage."""
    figure, axes = plt.subplots(len(images), len(frames), squeeze=False,
                                figsize=(2.6 * len(frames), 2.0 * len(images)))
    for row, (scene, paths) in enumerate(images):
        for column, path in enumerate(paths):
            axis = axes[row][column]
            axis.imshow(plt.imread(path))
            axis.set_xticks([])
            axis.set_yticks([])
            if row == 0:
                axis.set_title(f"frame {frames[column]}", fontsize=9)
            if column == 0:
                axis.set_ylabel(f"scene {scene}", fontsize=9)
    return save(figure, folder, "fig1_keyframes")


LINESTYLES = ("-", "--", "-.", ":")
MARKERS = "osD^v<>pX"


def style(algo: str) -> dict:
    """One algorithm's colour, dash and marker, the same in every figure: lines of two
    algorithms differ in more than a shade."""
    known = list(COLOURS)
    index = known.index(algo.split(" ")[0]) if algo.split(" ")[0] in known else len(known)
    return {"color": colour(algo), "linestyle": LINESTYLES[index % len(LINESTYLES)],
            "marker": MARKERS[index % len(MARKERS)]}


def plain_log_axis(axis, which: str = "y") -> None:
    """A log axis labelled with plain numbers at 1, 2 and 5 times a power of ten when it
    spans at most two decades, at the powers of ten alone when it spans more: every
    minor tick labelled (2x10^3, 3x10^3, ...) collides on a narrow panel, and none
    labelled leaves an axis within one decade without a number."""
    ticker = importlib.import_module("matplotlib.ticker")
    target = axis.yaxis if which == "y" else axis.xaxis

    def label(value: float, _) -> str:
        low, high = sorted(target.get_view_interval())
        if value <= 0 or low <= 0:
            return ""
        mantissa = round(value / 10 ** math.floor(math.log10(value) + 1e-9), 6)
        wanted = (1,) if math.log10(high / low) > 2 else (1, 2, 5)
        return f"{value:g}" if mantissa in wanted else ""

    target.set_major_formatter(ticker.FuncFormatter(label))
    target.set_minor_formatter(ticker.FuncFormatter(label))


def per_frame(scene: int, n: int, series: dict, folder: pathlib.Path) -> str:
    """Figures 2-5: update, broadphase, update + broadphase and total time per frame, one
    line per algorithm.  Bullet's sap and bvh do most of their work in the update and ours
    in the broadphase, so only the third panel compares broadphases like with like."""
    figure, axes = plt.subplots(1, 4, figsize=(16, 3.8))
    titles = {"update_ms": "update", "broadphase_ms": "broadphase",
              "update_broadphase_ms": "update + broadphase (compare these)",
              "total_ms": "whole frame"}
    for axis, (column, title) in zip(axes, titles.items()):
        for algo, columns in sorted(series.items()):
            frames = len(columns[column])
            axis.plot(columns[column], label=algo, linewidth=0.9, markersize=3,
                      markevery=max(1, frames // 8), **style(algo))
        axis.set_title(title, fontsize=10)
        axis.set_xlabel("frame")
        axis.set_yscale("log")
        plain_log_axis(axis)
        axis.grid(alpha=0.3)
    axes[0].set_ylabel("ms per frame")
    axes[0].legend(fontsize=8)
    figure.suptitle(f"scene {scene}, {n} boxes", fontsize=11)
    return save(figure, folder, f"fig{scene + 1}_scene{scene}_per_frame")


STAGE_PARTS = [("update", "#d62728", "//"), ("broadphase", "#ff9896", "//"),
               ("narrowphase", "#9467bd", ""), ("solver", "#1f77b4", ""),
               ("integrate", "#2ca02c", ""), ("ccd_query", "#8c564b", ""),
               ("other", "#c7c7c7", "")]


def stacked_bars(axis, mine: list) -> None:
    """One bar per algorithm, its stages stacked, the update + broadphase share on top."""
    positions = range(len(mine))
    bottom = [0.0] * len(mine)
    for stage, tint, hatch in STAGE_PARTS:
        values = [r[stage] if r[stage] == r[stage] else 0.0 for r in mine]
        axis.bar(positions, values, bottom=bottom, color=tint, hatch=hatch,
                 edgecolor="white", linewidth=0.5, label=stage.replace("_", " "))
        bottom = [b + v for b, v in zip(bottom, values)]
    for x, r in zip(positions, mine):
        axis.annotate(f"{r['update_broadphase_pct']:.0f}%", (x, r["total"]),
                      ha="center", va="bottom", fontsize=7)
    axis.set_xticks(list(positions))
    axis.set_xticklabels([r["algo"] for r in mine], rotation=45, ha="right", fontsize=8)


def stages(rows: list, folder: pathlib.Path) -> str:
    """The frame by stage at each scene's largest n, one stacked bar per algorithm, so the
    share a broadphase can change (update + broadphase, hatched) is seen at once."""
    scenes = sorted({r["scene"] for r in rows})
    figure, axes = plt.subplots(1, len(scenes), figsize=(3.6 * len(scenes), 4), squeeze=False)
    for axis, scene in zip(axes[0], scenes):
        n = max(r["objects"] for r in rows if r["scene"] == scene)
        stacked_bars(axis, [r for r in rows if r["scene"] == scene and r["objects"] == n])
        axis.set_title(f"scene {scene}, {n} boxes", fontsize=10)
        axis.grid(axis="y", alpha=0.3)
    axes[0][0].set_ylabel("ms per frame (mean)")
    figure.suptitle("the frame by stage; on each bar, the share of update + broadphase",
                    fontsize=10)
    axes[0][-1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return save(figure, folder, "fig_stages")


def errorbar_line(axis, cells: list, algo: str) -> None:
    """One algorithm's mean total against n, its bar the repetitions' run means."""
    points = sorted((c["objects"], c["total_mean"], c["total_min"], c["total_max"])
                    for c in cells if c["algo"] == algo)
    n, mean, low, high = zip(*points)
    axis.errorbar(n, mean, yerr=[[m - lo for m, lo in zip(mean, low)],
                                 [hi - m for m, hi in zip(mean, high)]],
                  label=algo, capsize=3, **style(algo))


def total_against_n(cells: list, folder: pathlib.Path) -> str:
    """Figure 6: mean total frame time against n; bars span the repetitions' run means."""
    scenes = sorted({c["scene"] for c in cells})
    figure, axes = plt.subplots(1, len(scenes), figsize=(4 * len(scenes), 3.6), squeeze=False)
    for axis, scene in zip(axes[0], scenes):
        mine = [c for c in cells if c["scene"] == scene and not c["fallback"]]
        for algo in sorted({c["algo"] for c in mine}):
            errorbar_line(axis, mine, algo)
        axis.set_title(f"scene {scene}")
        axis.set_xlabel("boxes")
        axis.set_ylabel("total ms / frame")
        axis.set_yscale("log")
        plain_log_axis(axis)
        axis.grid(alpha=0.3)
    axes[0][0].legend(fontsize=8)
    return save(figure, folder, "fig6_total_against_n")


def timeline(frame: int, algo: str, spans: list, folder: pathlib.Path) -> str:
    """One frame of the async loop: each lane's spans against time since the frame began.

    Left the whole frame, right a zoom on its first substep, where the first
    search and the narrowphase that follows are wide enough to see.
    Nested spans of the main lane (frame > physics > substep > broadphase,
    narrowphase) are drawn ever thinner, so each stays visible.
    """
    lanes = ["main", "tasks", "sound", "ai"]
    lanes += sorted({lane for lane, *_ in spans} - set(lanes))
    heights = {"frame": 0.9, "physics": 0.75, "substep": 0.6, "broadphase": 0.4,
               "narrowphase": 0.4}
    first_substep = next(((start, duration) for _, name, start, duration in spans
                          if name == "substep"), None)
    figure, axes = plt.subplots(1, 2, figsize=(13, 3.2), gridspec_kw={"width_ratios": [1, 1.4]})
    zoom = "its first substep" if first_substep else "the whole frame"
    for axis, title in zip(axes, ("the whole frame", zoom)):
        for lane, name, start, duration in spans:
            row = len(lanes) - 1 - lanes.index(lane)
            axis.barh(row, duration, left=start, height=heights.get(name, 0.8),
                      color=LANE_COLOURS.get(name, "#8c564b"), edgecolor="black",
                      linewidth=0.4, label=name)
        axis.set_yticks(range(len(lanes)))
        axis.set_yticklabels(reversed(lanes))
        axis.set_xlabel("ms since the frame began")
        axis.set_title(f"frame {frame}, broadphase {algo}: {title}", fontsize=10)
        axis.grid(axis="x", alpha=0.3)
    if first_substep:
        start, duration = first_substep
        axes[1].set_xlim(start - 0.05 * duration, start + 1.05 * duration)
    handles, labels = axes[1].get_legend_handles_labels()
    unique = dict(zip(labels, handles))
    axes[1].legend(unique.values(), unique.keys(), fontsize=8, loc="upper left",
                   bbox_to_anchor=(1.01, 1.0))
    return save(figure, folder, "fig_timeline")


def broadphase_error(rows: list, folder: pathlib.Path) -> str:
    """Each algorithm's broadphase time per frame against its extra pairs (misses are 0)."""
    figure, axis = plt.subplots(figsize=(6, 4))
    for row in rows:
        axis.scatter(row["extra_share"] * 100, row["time_ms"], color=colour(row["algo"]), s=40)
        axis.annotate(row["algo"], (row["extra_share"] * 100, row["time_ms"]), fontsize=8,
                      xytext=(4, 4), textcoords="offset points")
    axis.set_xlabel("extra pairs, % of the exact pairs")
    axis.set_ylabel("update + broadphase ms / frame")
    axis.set_yscale("log")
    plain_log_axis(axis)
    axis.set_title("broadphase speed against error, scene 4")
    axis.grid(alpha=0.3)
    return save(figure, folder, "fig_broadphase_error")


CCD_STYLES = {"off": ("#1f77b4", "o-"), "auto": ("#2ca02c", "s-"), "all": ("#d62728", "^-")}


def physics_fixed_k(axis, rows: list, key: str, ccd: str) -> None:
    """The fixed-K runs with the default solver as numbers joined by a line."""
    tint, line = CCD_STYLES[ccd]
    fixed = sorted((r["k_x_boxes"], r[key], r["substeps"]) for r in rows
                   if r["ccd"] == ccd and r["substeps"] != "auto" and r["solver"] == "pile")
    if not fixed:
        return
    axis.plot([f[0] for f in fixed], [f[1] for f in fixed], line, color=tint,
              label=f"fixed K, ccd {ccd}", markersize=4)
    for x, y, k in fixed:
        axis.annotate(str(k), (x, y), fontsize=7, xytext=(2, 2), textcoords="offset points")


def physics_marked(axis, rows: list, key: str, ccd: str) -> None:
    """The old fixed K with Bullet's solver as a cross, the automatic setting as a star."""
    tint, _ = CCD_STYLES[ccd]
    for r in rows:
        if r["ccd"] != ccd or (r["substeps"] != "auto" and r["solver"] != "bullet"):
            continue
        auto = r["substeps"] == "auto"
        name = (f"auto, ccd {ccd}" + (", no sleep" if r["sleep"] == "off" and r["scene"] <= 2
                                       else "")
                if auto else f"K={r['substeps']}, ccd {ccd}, Bullet's solver")
        axis.plot(r["k_x_boxes"], r[key], "*" if auto else "X", color=tint,
                  markersize=13 if auto else 9, markeredgecolor="black", label=name)


def physics(rows: list, folder: pathlib.Path) -> str:
    """Per scene (columns): each error (rows) against the cost per frame, one point per run;
    fixed K as numbers joined per CCD mode, the automatic setting as a star, the old fixed K
    with Bullet's own solver settings as a cross.  The cost is mean
    K x boxes, which the machine's load does not change (the tables give the times)."""
    scenes = sorted({r["scene"] for r in rows})
    measures = [("penetration_max", "deepest penetration / edge"),
                ("sunk_max", "sunk (max over frames)"), ("escaped_max", "escaped (max)")]
    figure, axes = plt.subplots(len(measures), len(scenes), squeeze=False,
                                figsize=(4.5 * len(scenes), 2.8 * len(measures)))
    for column, scene in enumerate(scenes):
        mine = [r for r in rows if r["scene"] == scene]
        for row, (key, title) in enumerate(measures):
            axis = axes[row][column]
            for ccd in CCD_STYLES:
                physics_fixed_k(axis, mine, key, ccd)
                physics_marked(axis, mine, key, ccd)
            axis.set_xscale("log")
            plain_log_axis(axis, "x")
            if column == 0:
                axis.set_ylabel(title)
            axis.grid(alpha=0.3)
        axes[0][column].set_title(f"scene {scene}")
        axes[-1][column].set_xlabel("cost: mean K x boxes")
    axes[0][-1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return save(figure, folder, "fig_physics")


def late_over_on_time(r: dict) -> float:
    return r["late_ms"] / r["on_time_ms"] if r["on_time_ms"] > 0 else float("nan")


LATENCY_MEASURES = (
    ("missed pairs per frame", lambda r: r["missed_total"] / r["frames"], "symlog"),
    ("extra pairs per frame", lambda r: r["extra_mean"], "symlog"),
    ("late / on-time search (medians)", late_over_on_time, "log"))


def latency_panel(axis, mine: list, value, scale: str) -> None:
    """One scene's one measure against growth, one line per algorithm."""
    for algo in sorted({r["algo"] for r in mine}):
        line = sorted((r for r in mine if r["algo"] == algo), key=lambda r: r["growth"])
        axis.plot([r["growth"] for r in line], [value(r) for r in line], label=algo,
                  **style(algo))
    axis.set_yscale(scale)
    if scale == "log":
        plain_log_axis(axis)
    axis.grid(alpha=0.3)


def latency(rows: list, folder: pathlib.Path) -> str:
    """Late broadphase against growth, one column per scene, one row per measure (missed
    and extra pairs per frame, late / on-time search time), one line per algorithm in its
    own colour, dash and marker.  An exact algorithm's misses are the latency's alone; a
    conservative one's are fewer, paid for in extras."""
    scenes = sorted({r["scene"] for r in rows})
    figure, axes = plt.subplots(len(LATENCY_MEASURES), len(scenes), squeeze=False, sharex=True,
                                figsize=(3.6 * len(scenes), 2.6 * len(LATENCY_MEASURES)))
    for column, scene in enumerate(scenes):
        mine = [r for r in rows if r["scene"] == scene]
        for row, (title, value, scale) in enumerate(LATENCY_MEASURES):
            latency_panel(axes[row][column], mine, value, scale)
            if column == 0:
                axes[row][column].set_ylabel(title, fontsize=9)
        axes[0][column].set_title(f"scene {scene}", fontsize=10)
        axes[-1][column].set_xlabel("growth (x |v| dt)")
        axes[-1][column].axhline(1.0, color="black", linewidth=0.6)
    axes[0][-1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return save(figure, folder, "fig_latency")


def overlap_lines(axes: tuple, mine: list, n: int, tint) -> None:
    """One n's lines in one scene's three panels."""
    times, speedups, hidden = axes
    loads = [r["load"] for r in mine]
    for axis, key, line, name in ((times, "sync_ms", "-o", "sync"),
                                  (times, "async_ms", "--s", "async"),
                                  (times, "ideal_ms", ":", "ideal"),
                                  (speedups, "speedup", "-o", "measured"),
                                  (speedups, "ideal_speedup", ":", "ideal"),
                                  (hidden, "hidden", "-o", "")):
        axis.plot(loads, [r[key] for r in mine], line, color=tint,
                  label=f"n {n} {name}".rstrip())


def overlap(rows: list, folder: pathlib.Path) -> str:
    """The overlap-timing study: per scene, frame times and speed-up against the task load.

    Top: sync (solid), async (dashed) and this machine's ideal (dotted), one
    colour per n.  Middle: the measured speed-up (solid) and the ideal's
    (dotted).  Bottom: the share of the tasks' time the async frame hid.
    """
    scenes = sorted({r["scene"] for r in rows})
    sizes = sorted({r["objects"] for r in rows})
    palette = plt.get_cmap("viridis")
    figure, axes = plt.subplots(3, len(scenes), figsize=(5.5 * len(scenes), 10), squeeze=False)
    titles = ("frame time (median)", "speed-up, sync / async", "share of the tasks' time hidden")
    labels = ("ms per frame", "speed-up", "(sync - async) / tasks")
    for column, scene in enumerate(scenes):
        panels = tuple(axes[row][column] for row in range(3))
        for index, n in enumerate(sizes):
            mine = sorted((r for r in rows if r["scene"] == scene and r["objects"] == n),
                          key=lambda r: r["load"])
            if mine:
                overlap_lines(panels, mine, n, palette(index / max(1, len(sizes) - 1) * 0.85))
        panels[0].set_yscale("log")
        plain_log_axis(panels[0])
        panels[1].axhline(1.0, color="black", linewidth=0.6)
        panels[2].set_ylim(-0.05, 1.05)
        for axis, title, label in zip(panels, titles, labels):
            axis.set_title(f"scene {scene}: {title}", fontsize=10)
            axis.set_ylabel(label)
            axis.set_xlabel("task load X (tasks' cost / physics step)")
            axis.grid(alpha=0.3)
            axis.legend(fontsize=7, ncol=2)
    return save(figure, folder, "fig_overlap")
