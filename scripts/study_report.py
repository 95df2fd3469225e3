"""The study's tables, figures and REPORT.md, written from the results that exist.

Every sentence of the report that compares algorithms is computed from the
tables it sits beside; where a comparison needs runs that are missing (the
GPU's, on a machine without one) the report says it is pending instead of
guessing.  write_everything() returns the study's failures (an algorithm
that missed exact pairs), which make the command exit with 1.
"""
import json
import pathlib
import shutil

import broadphases
import gpu_results
import study_claims
import study_notes
import study_overlap
import study_physics
import study_plots
import study_results
from overlap_runs import portable

# The spans whose per-frame totals the timeline section quotes.
TIMELINE_TOTALS = ("frame", "physics", "broadphase", "sound", "ai", "wait for tasks")
REPO = pathlib.Path(__file__).resolve().parent.parent


def fmt(x: float) -> str:
    """Milliseconds and counts at a precision the measurements support."""
    if x != x:  # NaN
        return "—"
    magnitude = abs(x)
    if magnitude >= 100:
        return f"{x:.0f}"
    if magnitude >= 10:
        return f"{x:.1f}"
    return f"{x:.2f}" if magnitude >= 0.1 else f"{x:.3g}"


def table(headers: list, rows: list) -> list:
    lines = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return lines + [""]


def algo_order(algos) -> list:
    known = broadphases.names()
    def base(a):  # "gpubf (CUDA emulation)" sorts as gpubf
        return a.split(" ")[0]
    return sorted(algos, key=lambda a: (known.index(base(a)) if base(a) in known else len(known), a))


# --- the sweep ---------------------------------------------------------------

def sweep_tables(cells: list) -> list:
    """Total and update + broadphase ms/frame, scene and n down, algorithms across."""
    honest = [c for c in cells if not c["fallback"]]
    algos = algo_order({c["algo"] for c in honest})
    by_key = {(c["scene"], c["objects"], c["algo"]): c for c in honest}
    keys = sorted({(c["scene"], c["objects"]) for c in honest})
    lines = []
    for title, value in (
            ("Total ms per frame (mean over repetitions of each run's mean; in brackets the "
             "ratio to bf)", lambda c: c["total_mean"]),
            ("Update + broadphase ms per frame (same averaging; ratio to bf)",
             study_results.update_and_broadphase_ms)):
        rows = []
        for scene, n in keys:
            base = by_key.get((scene, n, "bf"))
            row = [scene, n]
            for algo in algos:
                cell = by_key.get((scene, n, algo))
                if cell is None:
                    row.append("—")
                    continue
                text = fmt(value(cell))
                if base is not None and algo != "bf":
                    text += f" ({value(cell) / value(base):.2f})"
                row.append(text)
            rows.append(row)
        lines += [f"{title}:", ""] + table(["scene", "n"] + algos, rows)
    return lines


def stage_tables(cells: list) -> list:
    """Each stage of the frame at the largest n of each scene, one row per algorithm: the
    stages a broadphase changes (update, broadphase) beside those it should not (the
    narrowphase, solver, integration and CCD's queries, which every broadphase asks of the
    same shared tree), with the mean K each run chose from its own state."""
    honest = [c for c in cells if not c["fallback"]]
    stages = ("update", "broadphase", "narrowphase", "solver", "integrate", "ccd_query", "total")
    lines = []
    for scene in sorted({c["scene"] for c in honest}):
        n = max(c["objects"] for c in honest if c["scene"] == scene)
        rows = [[c["algo"]] + [fmt(c[f"{stage}_mean"]) for stage in stages]
                + [fmt(c["substeps"])]
                for c in sorted((c for c in honest if c["scene"] == scene and c["objects"] == n),
                                key=lambda c: algo_order(a["algo"] for a in honest).index(c["algo"]))]
        lines += [f"Scene {scene}, {n} boxes, ms per frame by stage (mean over repetitions):", ""]
        lines += table(["algo", "update", "broadphase", "narrowphase", "solver", "integration",
                        "CCD queries", "total", "mean K"], rows)
    return lines


def fastest(cells: list, scene: int, n: int, value) -> tuple:
    present = [c for c in cells if c["scene"] == scene and c["objects"] == n and not c["fallback"]]
    best = min(present, key=value)
    return best["algo"], value(best)


def claim_lines(cells: list, gpu_pending: int) -> list:
    """The paper's three claims, each checked on total and on update + broadphase time."""
    honest = [c for c in cells if not c["fallback"]]
    by_key = {(c["scene"], c["objects"], c["algo"]): c for c in honest}
    measures = (("total", lambda c: c["total_mean"]),
                ("update + broadphase", study_results.update_and_broadphase_ms))
    lines = []

    def versus(algo: str, other: str, name: str, value) -> str:
        pairs = [(k, by_key[k], by_key[(k[0], k[1], other)]) for k in by_key
                 if k[2] == algo and (k[0], k[1], other) in by_key]
        if not pairs:
            return ""
        wins = [k for k, mine, theirs in pairs if value(mine) < value(theirs)]
        ratios = [value(mine) / value(theirs) for _, mine, theirs in pairs]
        losses = [f"s{k[0]} n{k[1]}" for k, *_ in sorted(pairs) if k not in wins]
        text = (f"{algo} is faster than {other} ({name}) in {len(wins)} of {len(pairs)} "
                f"(scene, n) cells; {algo}/{other} from {min(ratios):.2f} to {max(ratios):.2f}")
        text += f"; not faster in {', '.join(losses)}" if losses else ""
        if name == "total" and any(mine["repetitions"] > 1 for _, mine, _ in pairs):
            ties = [f"s{k[0]} n{k[1]}" for k, mine, theirs in sorted(pairs)
                    if mine["total_min"] <= theirs["total_max"]
                    and theirs["total_min"] <= mine["total_max"]]
            text += (f"; the repetitions' ranges overlap (no difference) in {len(ties)} of "
                     f"{len(pairs)} cells" + (f": {', '.join(ties)}" if ties else ""))
        return text

    gpu_algos = [a for a in broadphases.needs_device() if any(k[2] == a for k in by_key)]
    pending = " (see *What needs a real GPU*)" if gpu_pending else ""
    lines.append("1. *GPU-BF beats BF everywhere.*")
    if not gpu_algos:
        lines.append(f"   - GPU: needs a real GPU{pending}; no GPU figure is in this report.")
    for algo in gpu_algos + ["cpubf"]:
        prefix = "our CPU twin, not the GPU: " if algo == "cpubf" else ""
        for name, value in measures:
            text = versus(algo, "bf", name, value)
            if text:
                lines.append(f"   - {prefix}{text}.")
    lines.append("2. *GPU-BF is near SAP and BVH.*")
    if not gpu_algos:
        lines.append(f"   - GPU: needs a real GPU{pending}.")
    for algo in gpu_algos + ["cpubf"]:
        prefix = "our CPU twin: " if algo == "cpubf" else ""
        for other in ("sap", "bvh"):
            text = versus(algo, other, "total", measures[0][1])
            if text:
                lines.append(f"   - {prefix}{text}.")
    lines.append("3. *GPU-BF does best in scene 4 (mixed sizes).*")
    scene4 = sorted({k[1] for k in by_key if k[0] == 4})
    if not gpu_algos:
        lines.append(f"   - GPU: needs a real GPU{pending}.")
    for name, value in measures:
        if scene4:
            winners = [f"n={n}: {fastest(honest, 4, n, value)[0]}" for n in scene4]
            lines.append(f"   - fastest {name} in scene 4 among the algorithms run: "
                         + ", ".join(winners) + ".")
    lines.append("")
    lines.append("A difference smaller than the spread between repetitions (the bars of "
                 "Figure 6, `total_min`/`total_max` in sweep.csv) is not a difference" +
                 ("; with one repetition there is no spread to judge by."
                  if all(c["repetitions"] == 1 for c in cells) else "."))
    return lines + [""]


def figure_lines(cells: list, n: int) -> list:
    """What Figures 2-6 show, read off the aggregated table.  Broadphases are ranked on
    update + broadphase together: SAP and DBVT do most of their work while the AABBs are
    written (sap's broadphase column alone is a few microseconds)."""
    honest = [c for c in cells if not c["fallback"]]
    search = study_results.update_and_broadphase_ms
    lines = []
    for scene in sorted({c["scene"] for c in honest}):
        present = [c for c in honest if c["scene"] == scene and c["objects"] == n]
        if not present:
            continue
        ranked = sorted(present, key=lambda c: c["total_mean"])
        lines.append(f"- Scene {scene}, {n} boxes: total ms/frame, fastest first: "
                     + ", ".join(f"{c['algo']} {fmt(c['total_mean'])}" for c in ranked)
                     + "; update + broadphase, fastest first: "
                     + ", ".join(f"{c['algo']} {fmt(search(c))}" for c in
                                 sorted(present, key=search)) + ".")
    sizes = sorted({c["objects"] for c in honest})
    if len(sizes) > 1:
        for scene in sorted({c["scene"] for c in honest}):
            growth = []
            for algo in algo_order({c["algo"] for c in honest}):
                ends = {c["objects"]: c["total_mean"] for c in honest
                        if c["scene"] == scene and c["algo"] == algo}
                if sizes[0] in ends and sizes[-1] in ends:
                    growth.append(f"{algo} x{ends[sizes[-1]] / ends[sizes[0]]:.1f}")
            lines.append(f"- Figure 6, scene {scene}: total time from {sizes[0]} to {sizes[-1]} "
                         f"boxes grows " + ", ".join(growth) + ".")
    return lines + [""]


# --- speed against error -----------------------------------------------------

def pairs_section(pairs: list, cells: list, n: int, figures: dict) -> tuple:
    if not pairs:
        return ["No pair comparison has run yet.", ""], []
    failures = [f"{r['algo']} missed {r['missed']} exact pairs on the scene-4 stream"
                for r in pairs if r["missed"]]
    time = {c["algo"]: study_results.update_and_broadphase_ms(c)
            for c in cells if c["scene"] == 4 and c["objects"] == n and not c["fallback"]}
    rows = []
    for r in sorted(pairs, key=lambda r: algo_order([r["algo"]])[0]):
        r["time_ms"] = time.get(r["algo"], float("nan"))
        rows.append([r["algo"], r["frames"], fmt(r["exact_mean"]), fmt(r["reported_mean"]),
                     r["missed"], fmt(r["extra_mean"]), f"{100 * r['extra_share']:.2f}%",
                     r["extra_max"], fmt(r["time_ms"])])
    lines = table(["algo", "frames", "exact pairs/frame", "reported/frame", "missed (total)",
                   "extra/frame", "extra share", "extra max", "update+bp ms/frame (sweep)"], rows)
    if failures:
        lines.append("**FAILED: " + "; ".join(failures) + ".**")
    else:
        lines.append(f"No algorithm missed an exact pair in {pairs[0]['frames']} frames.")
    extra = [r for r in pairs if r["extra_mean"] > 0]
    if extra:
        lines.append("Extra pairs (the narrowphase rejects them): " + ", ".join(
            f"{r['algo']} {100 * r['extra_share']:.2f}%" for r in extra) + ".")
    timed = [r for r in pairs if r["time_ms"] == r["time_ms"] and not r["missed"]]
    if timed:
        best = min(timed, key=lambda r: r["time_ms"])
        lines.append(f"Fastest without a miss in scene 4 at {n} boxes: **{best['algo']}** "
                     f"({fmt(best['time_ms'])} ms/frame update + broadphase).")
        study_plots.broadphase_error(timed, figures["folder"])
        lines += ["", "![broadphase speed against error](report/fig_broadphase_error.png)"]
    else:
        lines.append(f"No sweep timings for scene 4 at {n} boxes yet, so no time axis.")
    return lines + [""], failures


def best_broadphase_lines(cells: list) -> list:
    honest = [c for c in cells if not c["fallback"]]
    lines = []
    for scene in sorted({c["scene"] for c in honest}):
        n = max(c["objects"] for c in honest if c["scene"] == scene)
        total = fastest(honest, scene, n, lambda c: c["total_mean"])
        search = fastest(honest, scene, n, study_results.update_and_broadphase_ms)
        lines.append(f"- Scene {scene} at {n} boxes: fastest frame **{total[0]}** "
                     f"({fmt(total[1])} ms), fastest update + broadphase **{search[0]}** "
                     f"({fmt(search[1])} ms).")
    return lines + [""]


def late_search_verdict(best: dict, cells: list) -> str:
    """Whether the best late setting pays: the narrowphase work its extra pairs add against
    the on-time searches it takes off the critical path, both from measured times.  The
    narrowphase cost per cached pair comes from the sweep's bvh run of the same scene at
    the nearest n; a frame runs `substeps` on-time searches, which one late search replaces."""
    mine = [c for c in cells if c["scene"] == best["scene"] and c["algo"] == "bvh"
            and c["pairs_median"] > 0]
    if not mine:
        return ""
    cell = min(mine, key=lambda c: abs(c["objects"] - best["objects"]))
    per_pair_ms = cell["narrowphase_mean"] / cell["pairs_median"]
    added_ms = (best["late_pairs_mean"] - best["exact_mean"]) * per_pair_ms
    saved_ms = cell["substeps"] * best["on_time_ms"]
    # The per-pair cost is of the sweep's pairs, most of them touching; an extra pair that
    # does not touch leaves the narrowphase sooner, so only a wide margin decides.
    if added_ms > 5 * saved_ms:
        verdict = "It does not pay"
    elif added_ms < saved_ms:
        verdict = "It pays"
    else:
        verdict = "Too close to call"
    return (f" {verdict}: the sweep's narrowphase took {1e3 * per_pair_ms:.2f} µs per "
            f"cached pair per frame (scene {cell['scene']}, {cell['objects']} boxes, bvh), so "
            f"the {fmt(best['late_pairs_mean'] - best['exact_mean'])} pairs beyond the exact "
            f"ones would add about {fmt(added_ms)} ms a frame, against {fmt(saved_ms)} ms of "
            f"on-time search ({fmt(cell['substeps'])} searches a frame, the sweep's mean K) "
            "taken off the critical path (a pair that does not touch costs less than the "
            "sweep's average pair, so the verdict asks for a margin of 5).")


def latency_section(rows: list, figures: dict, cells: list) -> list:
    if not rows:
        return ["No latency runs yet.", ""]
    body = [[r["scene"], r["algo"], f"{r['growth']:g}", r["frames"], fmt(r["exact_mean"]),
             r["missed_total"], r["missed_frames"], r["missed_max"],
             f"{100 * r['missed_share']:.3f}%", fmt(r["extra_mean"]),
             fmt(r["on_time_extra_mean"]), fmt(r["on_time_ms"]), fmt(r["late_ms"])]
            for r in rows]
    lines = [f"{rows[0]['objects']} boxes. `growth` g: last frame's AABBs grown by g·|v|·dt "
             "(v: each box's velocity after last frame, from Bullet). Missed/extra: against the "
             "exact pairs of this frame's AABBs. Times: medians of writing the AABBs and "
             "finding the pairs, on time (this frame's AABBs) and late (grown).", ""]
    lines += table(["scene", "algo", "growth", "frames", "exact/frame", "missed", "frames w/ miss",
                    "max missed", "missed share", "extra/frame (late)", "extra/frame (on time)",
                    "on-time ms", "late ms"], body)
    lines.append("An exact algorithm's rows show the latency alone; a conservative one (bvh, sap) "
                 "also covers moved boxes with its own extra pairs (bvh's fattened, lazily "
                 "cleaned cache), so it can miss nothing where an exact one misses.")
    for scene in sorted({r["scene"] for r in rows}):
        mine = [r for r in rows if r["scene"] == scene]
        per_algo = []
        for algo in algo_order({r["algo"] for r in mine}):
            clean = [r["growth"] for r in mine if r["algo"] == algo and r["missed_total"] == 0]
            per_algo.append(f"{algo} {min(clean):g}" if clean else f"{algo} none")
        lines.append(f"- Scene {scene}: smallest growth without a miss: " + ", ".join(per_algo)
                     + ".")
        clean = [r for r in mine if r["missed_total"] == 0]
        if not clean:
            least = min(mine, key=lambda r: (r["missed_share"], r["late_ms"]))
            lines.append(f"  A one-frame-late broadphase missed pairs at every growth tried; "
                         f"fewest: {least['algo']} at growth {least['growth']:g}, "
                         f"{least['missed_total']} in {least['frames']} frames "
                         f"({100 * least['missed_share']:.3f}% of the exact pairs).")
            continue
        best = min(clean, key=lambda r: (r["late_pairs_mean"], r["late_ms"]))
        lines.append(
            f"  Best late setting (no miss, fewest pairs for the narrowphase): **{best['algo']}, growth "
            f"{best['growth']:g}**: {fmt(best['late_pairs_mean'])} pairs per frame, "
            f"{best['late_pairs_mean'] / best['exact_mean']:.1f} times the exact "
            f"{fmt(best['exact_mean'])}. Its on-time search costs {fmt(best['on_time_ms'])} ms "
            f"on the frame's critical path; run late it would move off that path, beside the "
            f"previous step (that overlap is not measured here), and take "
            f"{fmt(best['late_ms'])} ms there." + late_search_verdict(best, cells))
    study_plots.latency(rows, figures["folder"])
    return lines + ["", "![late broadphase](report/fig_latency.png)", ""]


# --- the whole report ----------------------------------------------------------

def profile_lines(args, cells: list) -> list:
    """Where this run differs from the full study of issue 6, said up front, with what the
    full sweep would cost at the per-frame times measured here."""
    reduced = [f"{key.replace('_', '-')} {getattr(args, key)} (full: {value})"
               for key, value in args.full_profile.items() if getattr(args, key) != value]
    if not reduced:
        return []
    full = args.full_profile
    hours = sum(c["total_mean"] for c in cells) * full["frames"] * full["repetitions"] / 3.6e6
    cost = (f" At the per-frame times measured below, the full sweep of these {len(cells)} "
            f"(scene, n, algorithm) cells alone would run {hours:.0f} hours here." if cells else "")
    return ["This is a reduced study, smaller than the full one in: " + "; ".join(reduced) +
            "." + cost + " The full study is for a batch of machines (`--shard i/k`).", ""]


def machine_lines(jobs: list, args) -> tuple:
    """(the lines naming the machine, commit and load once; failures when the runs came from
    more than one machine, build or commit: a report is of one of each)."""
    machines = {}
    for job in jobs:
        folder = getattr(job, "folder", None)
        if folder is not None and (folder / "summary.json").exists():
            m = json.loads((folder / "summary.json").read_text())["machine"]
            machines.setdefault(json.dumps(m, sort_keys=True), m)
    if not machines:
        return ["No run yet.", ""], []
    if len(machines) > 1:
        return (["The runs come from more than one machine, build or commit:", ""]
                + [f"- {machine_text(m)}" for m in machines.values()] + [""],
                [f"the runs come from {len(machines)} machines, builds or commits; a report "
                 "is of one (rerun the others into a fresh --out)"])
    return [machine_text(next(iter(machines.values()))) + ".", ""], []


def machine_text(m: dict) -> str:
    return (f"{m['cpu']}, {m['hardware_threads']} hardware threads; GPU: {m['gpu']}; "
            f"{m['compiler']}, {m['build_type']} build; commit {m['git_commit']}")


def fewer_repetitions(cells: list, args) -> str:
    """The sweep cells run fewer times than asked (a long cell cut to fit the session)."""
    short = {}
    for c in cells:
        if c["repetitions"] < args.repetitions:
            short.setdefault(c["repetitions"], []).append(
                f"s{c['scene']} n{c['objects']} {c['algo']}")
    return "".join(f" Run {k} time(s) only, so without a spread: {', '.join(v)}."
                   for k, v in sorted(short.items()))


def shown_command(args, words) -> str:
    """A command line with paths relative to the repository and --out shown as $OUT."""
    return portable(" ".join(map(str, words)), {args.out: "$OUT"})


def invocations(args) -> list:
    log = args.out / "study_invocations.json"
    return json.loads(log.read_text()) if log.exists() else []


def run_argv(argv: list) -> list:
    """An invocation's argv as the report shows it: its own --out as $OUT, and paths that
    start with it from there (it may be a folder of another machine, whose archive this
    report was made from); a binary elsewhere outside this repository by its last two names
    (build/overlap); no --notes (it shapes the report, not the runs, and names a folder of
    the machine that ran them)."""
    own_out = argv[argv.index("--out") + 1] if "--out" in argv[:-1] else None
    shown, words = [], list(argv)
    while words:
        word = words.pop(0)
        if word == "--notes" and words:
            words.pop(0)
            continue
        if own_out and word.startswith(own_out):
            word = "$OUT" + word[len(own_out):]
        elif shown and shown[-1] in ("--overlap", "--emulation"):
            path = pathlib.Path(word)
            if path.is_absolute() and not path.is_relative_to(REPO):
                word = "/".join(path.parts[-2:])
        shown.append(word)
    return shown


def invocation_lines(args) -> list:
    """The study invocations that ran the jobs, each with its start, length and the machine's
    load average when it started."""
    lines = ["The runs came from ($OUT: the study's --out folder, where its runs are kept):", ""]
    for run in invocations(args):
        load = run["load_average_at_start"]
        argv = run_argv(run["argv"])
        lines.append(f"- `{shown_command(args, argv)}`, started {run['started']}, " + (
            f"its jobs took {run['seconds']:.0f} s" if run.get("finished", True) else
            "stopped before its end (its finished runs are used, the others were run again by "
            "a later invocation)") + f"; load average at its start {load}" + (
            " (other jobs were running: their noise is in its timings)." if load >= 0.5
            else " (a quiet machine)."))
    return lines + [""] + beside_lines(invocations(args))


def beside_lines(log: list) -> list:
    """What ran beside what: for each experiment, the runs of other invocations (shards)
    that ran while its runs did, and whether any two runs compared with each other (one
    group) ever ran at once.  From each invocation's job times; invocations from before
    they were kept say nothing."""
    spans = [(index, job) for index, run in enumerate(log) for job in run.get("jobs", [])]
    if not spans:
        return []
    beside, most, clashes = {}, {}, set()
    for index, job in spans:
        others = [(i, o) for i, o in spans if i != index
                  and o["start"] < job["end"] and job["start"] < o["end"]]
        counts = beside.setdefault(job["experiment"], {})
        for _, other in others:
            counts[other["experiment"]] = counts.get(other["experiment"], 0) + 1
            if other["group"] == job["group"]:
                clashes.add(job["group"])
        most[job["experiment"]] = max(most.get(job["experiment"], 0), len(others))
    shards = len({index for index, _ in spans})
    lines = [f"What ran beside what: {len(spans)} runs in {shards} invocation(s) (shards)."
             + (" Every run ran alone." if not any(most.values()) else
                " A run's timings hold the noise of the runs beside it, which share the "
                "machine's cores (and its GPU):"), ""]
    for experiment in sorted(beside):
        if most[experiment]:
            lines.append(f"- {experiment}: other shards' runs beside its runs, counted once for "
                         "each of its runs they met: " + ", ".join(
                             f"{other} {n}" for other, n in sorted(beside[experiment].items()))
                         + f"; at most {most[experiment]} during one of its runs.")
    lines += ["", "Runs compared with each other (one group: a sweep's scene and box count, "
              "an overlap point, a physics cell) " + (
                  "never ran at once." if not clashes else
                  "ran at once in " + ", ".join(sorted(clashes)) + ": those comparisons hold "
                  "each other's noise."), ""]
    return lines


def command_lines(args, jobs: list) -> list:
    """This report's command and one command per experiment."""
    lines = [f"This report: `scripts/study.py {shown_command(args, args.argv)}`.", "",
             "One command per experiment (every command is in `commands.txt`):", "", "```"]
    seen = set()
    for job in jobs:
        if job.experiment not in seen:
            seen.add(job.experiment)
            lines += [shown_command(args, c) for c in job.commands()]
    return lines + ["```", ""]


def keyframe_figure(args, figures: dict) -> list:
    folder = args.out / "keyframes" if args.capture else REPO / "docs" / "keyframes"
    frames = [int(f) for f in args.capture_keyframes.split(",")]
    scenes = sorted({int(s) for s in args.scenes.split(",")})
    images = [(s, [folder / f"scene{s}_frame{f:04d}.png" for f in frames]) for s in scenes]
    if not all(p.exists() for _, paths in images for p in paths):
        return [f"Figure 1: keyframes not found in {folder}.", ""]
    study_plots.keyframes(images, frames, figures["folder"])
    where = folder.relative_to(REPO) if folder.is_relative_to(REPO) else folder
    return [f"Figure 1, keyframes ({where}; boxes amber 1 m, blue small, crimson large):", "",
            "![keyframes](report/fig1_keyframes.png)", ""]


def gpu_lines(jobs: list, pairs: list) -> list:
    """What this report leaves out for want of a GPU, by experiment, and what the CUDA
    emulation checked instead."""
    left = {}
    for job in jobs:
        if job.gpu_algo and not job.done():
            left.setdefault(job.experiment, []).append(job)
    emulated = [r["algo"] for r in pairs if r["algo"].endswith("(CUDA emulation)")]
    if not left and not emulated:
        return []
    lines = ["### What needs a real GPU", ""]
    if left:
        elsewhere = gpu_results.measured_elsewhere()
        lines += ["The machine that ran this study has no GPU, so these figures are not in "
                  "this report" + (f" ({elsewhere} and cited in the claims table)"
                                   if elsewhere else "") + ": " + "; ".join(
                      f"{experiment}: {len(group)} runs of "
                      f"{', '.join(sorted({j.gpu_algo for j in group}))}"
                      for experiment, group in sorted(left.items())) +
                  ". They are the GPU algorithms' timings (on this machine `--algo gpubf` "
                  "runs its CPU fallback, and the CUDA emulation's times are the CPU's). "
                  "On a machine with a CUDA device, `scripts/study.py` with this report's "
                  "options (and `--shard i/k` to share them) runs exactly these jobs into the "
                  "same --out folder; `--no-runs --report` then adds them.", ""]
    if emulated:
        lines += ["Exactness does not need a GPU: " + ", ".join(emulated) + " ran the `.cu` "
                  "kernels through the CUDA emulation build (`cmake --preset cuda-emulation`, "
                  "every CUDA thread on the CPU) in section 3.1, pair for pair against bf; "
                  "those runs are not timed.", ""]
    return lines


def sweep_section(args, runs: list, cells: list, jobs: list, pairs: list, figures: dict,
                  gpu_pending: int) -> list:
    sweep_jobs = [j for j in jobs if j.experiment == "sweep"]
    lines = [f"Scenes {args.scenes}, algorithms {args.algos}, n in {args.objects}, "
             f"{args.repetitions} repetition(s) of {args.frames} frames, seed {args.seed} "
             f"every time, physics only (`--no-tasks`). Every run has the same physics "
             "configuration, today's defaults: `--substeps auto --ccd auto --sleep scene "
             "--solver pile`; CCD's sweeps go through one query tree shared by every "
             "broadphase (physics/ccd_query_broadphase.h), so every broadphase meets the same "
             "queries on the same path. K is chosen each frame from the run's own state, which "
             "the broadphase's pair order nudges: the mean K of each cell is in the stage "
             f"tables. Runs present: {len(runs)} of {len(sweep_jobs)}"
             + ("; the GPU algorithms' runs need a real GPU (see below)." if gpu_pending
                else ".") + fewer_repetitions(cells, args), ""]
    lines += gpu_lines(jobs, pairs)
    lines += keyframe_figure(args, figures)
    if not cells:
        return lines + ["No sweep runs yet.", ""]
    out = args.out
    study_results.write_csv(out / "sweep_runs.csv",
                            [dict(r, folder=portable(r["folder"], {out: "$OUT"})) for r in runs])
    study_results.write_csv(out / "sweep.csv", cells)
    sizes = sorted({c["objects"] for c in cells})
    n_fig = min(sizes, key=lambda n: abs(n - args.figure_objects))
    for scene in sorted({c["scene"] for c in cells}):
        series = study_results.per_frame(runs, scene, n_fig)
        if series:
            name = study_plots.per_frame(scene, n_fig, series, figures["folder"])
            lines += [f"Figure {scene + 1}, scene {scene}, {n_fig} boxes, per frame "
                      "(mean over repetitions; log scale):", "", f"![scene {scene}](report/{name})",
                      ""]
    study_plots.total_against_n(cells, figures["folder"])
    lines += ["Figure 6, total time against n (bars: the repetitions' run means):", "",
              "![total against n](report/fig6_total_against_n.png)", ""]
    lines += ["What the figures say:", ""] + figure_lines(cells, n_fig)
    lines += sweep_tables(cells) + stage_tables(cells)
    lines.append(f"Boxes escaped in any sweep run: {max(c['escaped_max'] for c in cells)}; most "
                 f"sunk at once: {max(c['sunk_max'] for c in cells)}; deepest penetration "
                 f"{fmt(max(c['penetration_max'] for c in cells))} box edges.")
    varied = [f"s{c['scene']} n{c['objects']} {c['algo']}" for c in cells
              if not c["same_state_every_rep"]]
    if any(c["repetitions"] > 1 for c in cells):
        lines.append("Repetitions end in the same state everywhere." if not varied else
                     "Repetitions end in different states in: " + ", ".join(varied) + ".")
    lines += ["", "### The paper's claims, point by point", ""] + claim_lines(cells, gpu_pending)
    return lines + ["### Best broadphase per scene (largest n run)", ""] + best_broadphase_lines(cells)


def timeline_section(args, jobs: list, figures: dict) -> list:
    job = next((j for j in jobs if j.experiment == "timeline"), None)
    if job is None or not job.done():
        return ["No timeline run yet.", ""]
    frame, algo, spans = study_results.timeline_frame(job.folder)
    study_plots.timeline(frame, algo, spans, figures["folder"])
    by_name = {}  # a substep's spans (search, join) summed over the frame's substeps
    for _, name, _, duration in spans:
        if name in TIMELINE_TOTALS:
            by_name[name] = by_name.get(name, 0.0) + duration
    return [f"Scene 4, {args.timeline_objects} boxes, sound and AI tasks on, broadphase {algo} "
            "(asked gpubf" + ("" if algo == "gpubf" else "; no GPU here, so this is its CPU "
                              "fallback") + f"). Frame {frame}, the median-length frame: "
            + ", ".join(f"{name} {fmt(ms)} ms" for name, ms in sorted(by_name.items())) + ".", "",
            "![timeline](report/fig_timeline.png)", "",
            "The timeline draws every substep: on the main lane the physics step, each substep "
            "and, inside it, that substep's broadphase (the pair search and the pair-cache "
            "update) and narrowphase; the sound and AI tasks beside the whole step. The "
            "broadphase figure above is the frame's, summed over its substeps (as frames.csv's "
            "broadphase_ms).", ""]


def write_everything(args, jobs: list) -> list:
    """Writes the tables, figures and REPORT.md; returns the study's failures: a missed
    exact pair (reported), or a report that cannot stand (runs from two machines or
    commits, a note for a section it lacks: then docs/REPORT.md is left as it was)."""
    out = args.out
    figures = {"folder": out / "report"}
    notes = study_notes.Notes(args.notes)
    runs = study_results.sweep_runs(jobs)
    cells = study_results.aggregate_sweep(runs)
    pairs = study_results.pair_errors(jobs)
    physics = study_results.physics_runs(jobs)
    latency = study_results.latency_rows(jobs)
    overlap = study_overlap.overlap_rows(jobs)
    gpu_pending = sum(1 for j in jobs if j.gpu_algo and not j.done())
    machine, blocking = machine_lines(jobs, args)
    failures = []

    title = "Overlap: the study" + (" (quick version)" if args.quick else "")
    lines = [f"# {title}", "",
             "Serpa & Rodrigues, *Parallelizing Broad Phase Collision Detection for Animation in "
             "Games* (SBGames 2014), redone and extended. Every number below was measured by "
             "the commands listed, on the one machine and commit named below; every table is "
             "also a CSV file in `report/` beside this file.", "", "## At a glance", ""]
    lines += study_claims.claims_lines(cells, pairs, physics, overlap, table)
    lines += notes.take("glance")
    lines += ["## Machine and runs", ""] + machine + invocation_lines(args)
    lines += profile_lines(args, cells) + ["## Commands", ""] + command_lines(args, jobs)
    lines += ["## 1. The sweep", ""]
    lines += sweep_section(args, runs, cells, jobs, pairs, figures, gpu_pending)
    lines += notes.take("sweep")
    lines += ["## 2. The async loop: one frame's timeline", ""]
    lines += timeline_section(args, jobs, figures) + notes.take("timeline")
    lines += ["## 3. Speed against error", "", "### 3.1 Broadphase: pairs against the exact "
              "oracle (bf)", "", f"Scene 4, {args.pairs_objects} boxes, {args.pairs_frames} "
              "frames recorded with `overlap record` (bvh, today's default substeps and CCD), each "
              "algorithm's pair cache from `overlap pairs` compared frame by frame with bf's.", ""]
    section, pair_failures = pairs_section(pairs, cells, args.pairs_objects, figures)
    failures += pair_failures
    lines += section + notes.take("pairs")
    lines += ["### 3.2 Physics: substeps, CCD, sleep and the solver", ""]
    lines += study_physics.physics_section(physics, figures, fmt, table, args.physics_objects,
                                           args.seed)
    lines += notes.take("physics")
    lines += ["### 3.3 A broadphase one frame late", ""] + latency_section(latency, figures, cells)
    lines += notes.take("latency")
    lines += ["## 4. The asynchronous frame: where overlap pays", ""]
    lines += study_overlap.overlap_section(overlap, figures, fmt, table) + notes.take("overlap")
    blocking += notes.failures()

    for name, rows in (("pairs.csv", pairs), ("physics.csv", physics), ("latency.csv", latency),
                       ("overlap.csv", overlap)):
        study_results.write_csv(out / name, rows)
    figures["folder"].mkdir(parents=True, exist_ok=True)
    for table_name in ("sweep_runs.csv", "sweep.csv", "pairs.csv", "physics.csv", "latency.csv",
                       "overlap.csv"):
        if (out / table_name).exists():
            shutil.copy(out / table_name, figures["folder"] / table_name)
    text = "\n".join(lines) + "\n"
    (out / "REPORT.md").write_text(text)
    if args.report and not blocking:
        docs = REPO / "docs"
        (docs / "report").mkdir(parents=True, exist_ok=True)
        for image in sorted(figures["folder"].iterdir()):
            shutil.copy(image, docs / "report" / image.name)
        (docs / "REPORT.md").write_text(text)
    return blocking + failures
