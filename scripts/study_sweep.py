"""The sweep's generated blocks: its figures, the paper's claims target by target, where
the frame goes, and its tables (scripts/study_report.py puts them in the report).

Rules, each with its reason:
  * Broadphases are compared on update + broadphase: Bullet's sap and bvh do most of
    their work while the AABBs are written ("update"), ours in "broadphase".
  * A fallback (a GPU algorithm that ran its CPU fallback) is never a row of a claim.
  * Each figure's data is also a CSV beside it (report/*.csv).
"""
import pathlib

import gpu_results
import study_claims
import study_plots
import study_results
import study_targets
from overlap_runs import portable
from study_tables import algo_order, fmt, table

REPO = pathlib.Path(__file__).resolve().parent.parent
STAGE_HEADERS = ["algo", "update", "broadphase", "narrowphase", "solver", "integration",
                 "CCD queries", "other", "total", "update + broadphase", "mean K"]


def honest(cells: list) -> list:
    return [c for c in cells if not c["fallback"]]


def fewer_repetitions(cells: list, args) -> str:
    """The sweep cells run fewer times than asked (a long cell cut to fit the session)."""
    short = {}
    for c in cells:
        if c["repetitions"] < args.repetitions:
            short.setdefault(c["repetitions"], []).append(
                f"s{c['scene']} n{c['objects']} {c['algo']}")
    return "".join(f" Run {k} time(s) only, so without a spread: {', '.join(v)}."
                   for k, v in sorted(short.items()))


def gpu_lines(jobs: list, pairs: list) -> list:
    """What this report leaves out for want of a GPU, and what the CUDA emulation checked."""
    left = {}
    for job in jobs:
        if job.gpu_algo and not job.done():
            left.setdefault(job.experiment, set()).add(job.gpu_algo)
    emulated = [r["algo"] for r in pairs if r["algo"].endswith("(CUDA emulation)")]
    lines = []
    if left:
        elsewhere = gpu_results.measured_elsewhere()
        lines += ["Needs a real GPU, so not in this report: " + "; ".join(
            f"{experiment}: {', '.join(sorted(algos))}" for experiment, algos in
            sorted(left.items())) + ". On a CUDA machine the same command with the same "
            "--out runs just these." + (" The GPU machines' figures measured outside the "
                                       "study are rows of the findings." if elsewhere
                                       else ""), ""]
    if emulated:
        lines += ["Checked without a GPU, pair for pair, never timed: " + ", ".join(emulated)
                  + " (the `.cu` kernels through the CUDA emulation build, §3.1).", ""]
    return lines


def keyframe_lines(args, figures: dict) -> list:
    folder = args.out / "keyframes" if args.capture else REPO / "docs" / "keyframes"
    frames = [int(f) for f in args.capture_keyframes.split(",")]
    scenes = sorted({int(s) for s in args.scenes.split(",")})
    images = [(s, [folder / f"scene{s}_frame{f:04d}.png" for f in frames]) for s in scenes]
    if not all(p.exists() for _, paths in images for p in paths):
        return [f"Figure 1: keyframes not found in {folder}.", ""]
    study_plots.keyframes(images, frames, figures["folder"])
    return ["Figure 1, the scenes (boxes amber 1 m, blue small, crimson large):", "",
            "![keyframes](report/fig1_keyframes.png)", ""]


def per_frame_lines(runs: list, cells: list, n_fig: int, figures: dict) -> list:
    lines = []
    for scene in sorted({c["scene"] for c in cells}):
        series = study_results.per_frame(runs, scene, n_fig)
        if not series:
            continue
        name = study_plots.per_frame(scene, n_fig, series, figures["folder"])
        study_results.write_csv(figures["folder"] / name.replace(".png", ".csv"),
                                study_results.per_frame_rows(series))
        lines += [f"Figure {scene + 1}, scene {scene}, {n_fig} boxes, per frame (mean over "
                  "repetitions; compare broadphases on update + broadphase):", "",
                  f"![scene {scene}](report/{name})", ""]
    return lines


def sweep_block(args, runs: list, cells: list, jobs: list, pairs: list, figures: dict) -> list:
    """The sweep's set-up, what needed a GPU, and Figures 1 to 6."""
    present = len(runs)
    planned = sum(1 for j in jobs if j.experiment == "sweep")
    lines = [f"Scenes {args.scenes}; {args.algos}; n {args.objects}; {args.repetitions} "
             f"repetition(s) of {args.frames} frames, seed {args.seed}, `--no-tasks`, "
             f"today's physics defaults. Runs present: {present} of {planned}."
             + fewer_repetitions(cells, args), ""]
    lines += gpu_lines(jobs, pairs) + keyframe_lines(args, figures)
    if not cells:
        return lines + ["No sweep runs yet.", ""]
    out = args.out
    study_results.write_csv(figures["folder"] / "sweep_runs.csv",
                            [dict(r, folder=portable(r["folder"], {out: "$OUT"})) for r in runs])
    study_results.write_csv(figures["folder"] / "sweep.csv", cells)
    sizes = sorted({c["objects"] for c in cells})
    n_fig = min(sizes, key=lambda n: abs(n - args.figure_objects))
    lines += per_frame_lines(runs, cells, n_fig, figures)
    study_plots.total_against_n(cells, figures["folder"])
    return lines + ["Figure 6, the whole frame against n (bars: the repetitions' run means):",
                    "", "![total against n](report/fig6_total_against_n.png)", ""]


def best_rows(cells: list) -> list:
    rows = []
    for scene in sorted({c["scene"] for c in honest(cells)}):
        at_n = study_claims.largest(cells, scene)
        frame = min(at_n, key=lambda c: c["total_mean"])
        search = min(at_n, key=study_results.update_and_broadphase_ms)
        rows.append([scene, frame["objects"], f"{frame['algo']} {fmt(frame['total_mean'])}",
                     f"{search['algo']} {fmt(study_results.update_and_broadphase_ms(search))}"])
    return rows


def claims_block(targets: dict, cells: list) -> list:
    """The paper's claims and ours from the sweep, target by target, and each scene's best."""
    if not cells:
        return ["No sweep runs yet.", ""]
    keys = ("paper1", "twin1", "paper2", "twin2", "paper3", "cpusap")
    lines = study_targets.lines([t for key in keys for t in targets[key]], table)
    lines += ["A difference smaller than the spread between repetitions (`total_min` to "
              "`total_max` in sweep.csv) is no difference" +
              ("; with one repetition there is no spread." if all(
                  c["repetitions"] == 1 for c in cells) else "."), "",
              "Fastest at each scene's largest n (ms per frame):", ""]
    return lines + table(["scene", "n", "whole frame", "update + broadphase"], best_rows(cells))


def stage_row(row: dict, cell: dict) -> list:
    return ([row["algo"]] + [fmt(row[s]) for s in study_results.STAGES]
            + [fmt(row["other"]), fmt(row["total"]), f"{row['update_broadphase_pct']:.1f}%",
               fmt(cell["substeps"])])


def scene_stage_lines(stages: list, by_key: dict, scene: int) -> list:
    n = max(r["objects"] for r in stages if r["scene"] == scene)
    mine = [r for r in stages if r["scene"] == scene and r["objects"] == n]
    order = algo_order(r["algo"] for r in mine)
    mine.sort(key=lambda r: order.index(r["algo"]))
    return ([f"Scene {scene}, {n} boxes, ms per frame (mean over repetitions):", ""]
            + table(STAGE_HEADERS, [stage_row(r, by_key[(scene, n, r["algo"])])
                                    for r in mine]))


def stages_block(stages: list, cells: list, targets: dict, figures: dict) -> list:
    """The frame by stage at each scene's largest n: one stacked figure, one table a scene."""
    if not stages:
        return ["No sweep runs yet.", ""]
    study_results.write_csv(figures["folder"] / "stages.csv", stages)
    name = study_plots.stages(stages, figures["folder"])
    lines = [f"![the frame by stage](report/{name})", ""]
    by_key = {(c["scene"], c["objects"], c["algo"]): c for c in cells}
    for scene in sorted({r["scene"] for r in stages}):
        lines += scene_stage_lines(stages, by_key, scene)
    return lines + study_targets.lines(targets["premise"], table)


def ratio_table(cells: list, title: str, value) -> list:
    by_key = {(c["scene"], c["objects"], c["algo"]): c for c in honest(cells)}
    algos = algo_order({c["algo"] for c in honest(cells)})
    rows = []
    for scene, n in sorted({(c["scene"], c["objects"]) for c in honest(cells)}):
        base = by_key.get((scene, n, "bf"))
        row = [scene, n]
        for algo in algos:
            cell = by_key.get((scene, n, algo))
            text = "—" if cell is None else fmt(value(cell))
            if cell is not None and base is not None and algo != "bf":
                text += f" ({value(cell) / value(base):.2f})"
            row.append(text)
        rows.append(row)
    return [f"{title}:", ""] + table(["scene", "n"] + algos, rows)


def tables_block(cells: list) -> list:
    """Whole frame and update + broadphase, ms per frame, scene and n down, algorithms
    across, with each one's ratio to bf; then what the sweep's runs did to the boxes."""
    if not cells:
        return ["No sweep runs yet.", ""]
    lines = ratio_table(cells, "Whole frame, ms (mean over repetitions; ratio to bf)",
                        lambda c: c["total_mean"])
    lines += ratio_table(cells, "Update + broadphase, ms (ratio to bf)",
                         study_results.update_and_broadphase_ms)
    varied = [f"s{c['scene']} n{c['objects']} {c['algo']}" for c in cells
              if not c["same_state_every_rep"]]
    lines.append(f"Boxes escaped in any sweep run: {max(c['escaped_max'] for c in cells)}; "
                 f"most sunk at once: {max(c['sunk_max'] for c in cells)}; deepest "
                 f"penetration {fmt(max(c['penetration_max'] for c in cells))} box edges."
                 + ("" if not varied else " Repetitions end in different states in: "
                    + ", ".join(varied) + "."))
    return lines + [""]
