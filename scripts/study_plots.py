"""The study's figures (matplotlib, Agg backend), each saved as PNG and SVG.

Every function takes rows already measured and aggregated by study_results
and draws them as they are: no smoothing, no fitted curves.  Each algorithm
keeps one colour across all figures.  matplotlib is imported at the first
figure, not with this module: the study's runs need only the standard
library (a GPU machine's python3 may have nothing else), the report's
figures need Debian's python3-matplotlib, which scripts/setup.sh installs.
"""
import importlib
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


def per_frame(scene: int, n: int, series: dict, folder: pathlib.Path) -> str:
    """Figures 2-5: update, broadphase and total time per frame, one line per algorithm."""
    figure, axes = plt.subplots(1, 3, figsize=(13, 3.6))
    titles = {"update_ms": "update", "broadphase_ms": "broadphase", "total_ms": "total"}
    for axis, (column, title) in zip(axes, titles.items()):
        for algo, columns in sorted(series.items()):
            axis.plot(columns[column], label=algo, color=colour(algo), linewidth=0.8)
        axis.set_title(f"scene {scene}, {n} boxes: {title}")
        axis.set_xlabel("frame")
        axis.set_ylabel("ms")
        axis.set_yscale("log")
        axis.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    return save(figure, folder, f"fig{scene + 1}_scene{scene}_per_frame")


def total_against_n(cells: list, folder: pathlib.Path) -> str:
    """Figure 6: mean total frame time against n; bars span the repetitions' run means."""
    scenes = sorted({c["scene"] for c in cells})
    figure, axes = plt.subplots(1, len(scenes), figsize=(4 * len(scenes), 3.6), squeeze=False)
    for axis, scene in zip(axes[0], scenes):
        mine = [c for c in cells if c["scene"] == scene and not c["fallback"]]
        for algo in sorted({c["algo"] for c in mine}):
            points = sorted((c["objects"], c["total_mean"], c["total_min"], c["total_max"])
                            for c in mine if c["algo"] == algo)
            n, mean, low, high = zip(*points)
            axis.errorbar(n, mean, yerr=[[m - lo for m, lo in zip(mean, low)],
                                         [hi - m for m, hi in zip(mean, high)]],
                          label=algo, color=colour(algo), marker="o", capsize=3)
        axis.set_title(f"scene {scene}")
        axis.set_xlabel("boxes")
        axis.set_ylabel("total ms / frame")
        axis.set_yscale("log")
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
    axis.set_title("broadphase speed against error, scene 4")
    axis.grid(alpha=0.3)
    return save(figure, folder, "fig_broadphase_error")


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
    styles = {"off": ("#1f77b4", "o-"), "auto": ("#2ca02c", "s-"), "all": ("#d62728", "^-")}
    for column, scene in enumerate(scenes):
        for row, (key, title) in enumerate(measures):
            axis = axes[row][column]
            for ccd, (tint, style) in styles.items():
                fixed = sorted((r["k_x_boxes"], r[key], r["substeps"]) for r in rows
                               if r["scene"] == scene and r["ccd"] == ccd
                               and r["substeps"] != "auto" and r["solver"] == "pile")
                if fixed:
                    axis.plot([f[0] for f in fixed], [f[1] for f in fixed], style, color=tint,
                              label=f"fixed K, ccd {ccd}", markersize=4)
                    for x, y, k in fixed:
                        axis.annotate(str(k), (x, y), fontsize=7, xytext=(2, 2),
                                      textcoords="offset points")
                for r in rows:
                    if (r["scene"] == scene and r["ccd"] == ccd and r["substeps"] != "auto"
                            and r["solver"] == "bullet"):
                        axis.plot(r["k_x_boxes"], r[key], "X", color=tint, markersize=9,
                                  markeredgecolor="black",
                                  label=f"K={r['substeps']}, ccd {ccd}, Bullet's solver")
                    if r["scene"] == scene and r["ccd"] == ccd and r["substeps"] == "auto":
                        axis.plot(r["k_x_boxes"], r[key], "*", color=tint, markersize=13,
                                  markeredgecolor="black",
                                  label=f"auto, ccd {ccd}" + (", no sleep"
                                                              if r["sleep"] == "off" and scene <= 2
                                                              else ""))
            axis.set_xscale("log")
            if column == 0:
                axis.set_ylabel(title)
            axis.grid(alpha=0.3)
        axes[0][column].set_title(f"scene {scene}")
        axes[-1][column].set_xlabel("cost: mean K x boxes")
    axes[0][-1].legend(fontsize=7)
    return save(figure, folder, "fig_physics")


def latency(rows: list, folder: pathlib.Path) -> str:
    """Late broadphase against growth: missed and extra pairs per frame, and the search time.

    Colour: the algorithm; marker: the scene.  An exact algorithm's misses are
    the latency's alone; a conservative one's are fewer, paid for in extras.
    """
    scenes = sorted({r["scene"] for r in rows})
    markers = "osD^v<>"
    figure, axes = plt.subplots(1, 3, figsize=(14, 3.8))
    for algo in sorted({r["algo"] for r in rows}):
        labelled = False
        for index, scene in enumerate(scenes):
            mine = sorted((r for r in rows if r["algo"] == algo and r["scene"] == scene),
                          key=lambda r: r["growth"])
            if not mine:
                continue
            style = {"marker": markers[index % len(markers)], "color": colour(algo),
                     "label": None if labelled else algo}
            labelled = True
            growth = [r["growth"] for r in mine]
            axes[0].plot(growth, [r["missed_total"] / r["frames"] for r in mine], **style)
            axes[1].plot(growth, [r["extra_mean"] for r in mine], **style)
            timed = [(r["growth"], r["late_ms"] / r["on_time_ms"]) for r in mine
                     if r["on_time_ms"] > 0]
            if timed:
                axes[2].plot(*zip(*timed), **style)
    key = ", ".join(f"{s} {markers[i % len(markers)]}" for i, s in enumerate(scenes))
    for axis, title in zip(axes, ("missed pairs per frame", "extra pairs per frame",
                                  "late / on-time search ms (medians)")):
        axis.set_title(f"{title}\nmarkers: scenes {key}", fontsize=10)
        axis.set_xlabel("growth (x |v| dt)")
        axis.grid(alpha=0.3)
        axis.legend(fontsize=8)
    axes[0].set_yscale("symlog")
    axes[1].set_yscale("log")
    axes[2].set_yscale("log")
    axes[2].axhline(1.0, color="black", linewidth=0.6)
    return save(figure, folder, "fig_latency")


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
    for column, scene in enumerate(scenes):
        times, speedups, hidden = axes[0][column], axes[1][column], axes[2][column]
        for index, n in enumerate(sizes):
            mine = sorted((r for r in rows if r["scene"] == scene and r["objects"] == n),
                          key=lambda r: r["load"])
            if not mine:
                continue
            colour_n = palette(index / max(1, len(sizes) - 1) * 0.85)
            loads = [r["load"] for r in mine]
            times.plot(loads, [r["sync_ms"] for r in mine], "-o", color=colour_n,
                       label=f"n {n} sync")
            times.plot(loads, [r["async_ms"] for r in mine], "--s", color=colour_n,
                       label=f"n {n} async")
            times.plot(loads, [r["ideal_ms"] for r in mine], ":", color=colour_n,
                       label=f"n {n} ideal")
            speedups.plot(loads, [r["speedup"] for r in mine], "-o", color=colour_n,
                          label=f"n {n}")
            speedups.plot(loads, [r["ideal_speedup"] for r in mine], ":", color=colour_n,
                          label=f"n {n} ideal")
            hidden.plot(loads, [r["hidden"] for r in mine], "-o", color=colour_n, label=f"n {n}")
        times.set_yscale("log")
        times.set_title(f"scene {scene}: frame time (median)", fontsize=10)
        times.set_ylabel("ms per frame")
        speedups.axhline(1.0, color="black", linewidth=0.6)
        speedups.set_title(f"scene {scene}: speed-up, sync / async", fontsize=10)
        speedups.set_ylabel("speed-up")
        hidden.set_title(f"scene {scene}: share of the tasks' time hidden", fontsize=10)
        hidden.set_ylabel("(sync - async) / tasks")
        hidden.set_ylim(-0.05, 1.05)
        for axis in (times, speedups, hidden):
            axis.set_xlabel("task load X (tasks' cost / physics step)")
            axis.grid(alpha=0.3)
            axis.legend(fontsize=7, ncol=2)
    figure.tight_layout()
    return save(figure, folder, "fig_overlap")
