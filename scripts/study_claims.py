"""The findings: one line per claim (the claim, its verdict, the figure, the runs a
timed cell stands on, the machine, the section), the report's first table.

Rules, each with its reason:
  * A claim's verdict is study_targets.verdict() of its section's own targets, the
    list the section prints: a verdict cannot contradict its section, and a claim none
    of whose targets ran has no verdict.
  * The machine and commit are named once, above the table; a row names its machine by
    a short label, so no row mixes machines.  Without a GPU in this study's runs, the
    GPU machines' figures (docs/results/gpu/, scripts/gpu_results.py) are rows of their
    own, labelled as those machines'.
  * No cell is over CELL_LIMIT characters: the table is read at a glance.
"""
import broadphases
import gpu_results
import study_overlap
import study_physics
from study_results import update_and_broadphase_ms
import study_targets
from study_tables import base_name
from study_targets import Target, not_run

PUBLISHED_CPU = ("bf", "sap", "bvh")  # Bullet's broadphases, the paper's BF, SAP and BVH
NEAR = 1.25  # "near": at most this factor slower
SHARE = 10.0  # %: a broadphase worth moving off the CPU takes at least this much of a frame
PAPER_GPU = ("gpubf-paper", "gpubf")  # the paper's GPU-BF and ours
CELL_LIMIT = 160


def honest(cells: list) -> list:
    return [c for c in cells if not c["fallback"]]


def ratios(cells: list, algo: str, other: str, value) -> list:
    """algo's value over other's, in every (scene, n) where both ran."""
    by_key = {(c["scene"], c["objects"], c["algo"]): c for c in honest(cells)}
    return [value(by_key[(s, n, a)]) / value(by_key[(s, n, other)])
            for (s, n, a) in by_key if a == algo and (s, n, other) in by_key]


def span(values: list) -> str:
    return f"x{min(values):.2f}-x{max(values):.2f}"


def beats_bf(cells: list, algo: str) -> Target:
    name = f"{algo}'s update + broadphase below bf's in every (scene, n)"
    found = ratios(cells, algo, "bf", update_and_broadphase_ms)
    if not found:
        return not_run(name, "not run" + ("" if algo == "cpubf" else ": needs a GPU"))
    below = sum(r < 1 for r in found)
    return Target(name, f"{span(found)} of bf's; below in {below} of {len(found)} cells",
                  below == len(found))


def near_sap_and_bvh(cells: list, algo: str) -> Target:
    name = f"{algo}'s whole frame at most x{NEAR} of sap's and of bvh's in every (scene, n)"
    total = lambda c: c["total_mean"]  # noqa: E731
    found = {other: ratios(cells, algo, other, total) for other in ("sap", "bvh")}
    if not all(found.values()):
        return not_run(name, "not run" + ("" if algo == "cpubf" else ": needs a GPU"))
    return Target(name, "; ".join(f"{span(v)} of {o}'s" for o, v in found.items()),
                  all(max(v) <= NEAR for v in found.values()))


def largest(cells: list, scene: int) -> list:
    """The honest cells of the scene's largest n."""
    mine = [c for c in honest(cells) if c["scene"] == scene]
    n = max((c["objects"] for c in mine), default=None)
    return [c for c in mine if c["objects"] == n]


def best_in_scene4(cells: list) -> Target:
    name = "a GPU finder has the fastest whole frame in scene 4 at the largest n"
    ranked = sorted(largest(cells, 4), key=lambda c: c["total_mean"])
    if not any(c["algo"] in broadphases.needs_device() for c in ranked):
        return not_run(name, "not run: needs a GPU")
    text = ", ".join(f"{c['algo']} {c['total_mean']:.0f} ms" for c in ranked[:3])
    return Target(name, f"{ranked[0]['objects']} boxes: {text}",
                  ranked[0]["algo"] in broadphases.needs_device())


def cpusap_against_bullet(cells: list) -> Target:
    name = "cpusap's update + broadphase below the best of bf, sap and bvh, every scene, largest n"
    found = []
    for scene in sorted({c["scene"] for c in honest(cells)}):
        at_n = {c["algo"]: c for c in largest(cells, scene)}
        peers = [at_n[a] for a in PUBLISHED_CPU if a in at_n]
        if "cpusap" in at_n and peers:
            best = min(peers, key=update_and_broadphase_ms)
            found.append(update_and_broadphase_ms(at_n["cpusap"]) / update_and_broadphase_ms(best))
    if not found:
        return not_run(name)
    return Target(name, f"{span(found)} of the best of them in {len(found)} scenes",
                  max(found) < 1)


def fastest_shares(stages: list) -> list:
    """(update + broadphase %, algorithm) of each scene's fastest whole frame, largest n."""
    shares = []
    for scene in sorted({r["scene"] for r in stages}):
        n = max(r["objects"] for r in stages if r["scene"] == scene)
        best = min((r for r in stages if r["scene"] == scene and r["objects"] == n),
                   key=lambda r: r["total"])
        shares.append((best["update_broadphase_pct"], best["algo"]))
    return shares


def broadphase_share(stages: list) -> Target:
    """The premise: what a faster broadphase, GPU or not, can save is at most its share."""
    name = (f"update + broadphase at least {SHARE:g}% of the frame (each scene's fastest "
            "whole frame, largest n)")
    shares = fastest_shares(stages)
    if not shares:
        return not_run(name)
    values = [s for s, _ in shares]
    who = sorted({a for _, a in shares})
    return Target(name, f"{min(values):.1f}-{max(values):.1f}% ({', '.join(who)})",
                  min(values) >= SHARE)


def sweep_targets(cells: list, stages: list) -> dict:
    """The sweep's targets, by claim: the sweep section prints them, the findings judge by
    them."""
    return {"premise": [broadphase_share(stages)],
            "paper1": [beats_bf(cells, a) for a in PAPER_GPU],
            "twin1": [beats_bf(cells, "cpubf")],
            "paper2": [near_sap_and_bvh(cells, a) for a in PAPER_GPU],
            "twin2": [near_sap_and_bvh(cells, "cpubf")],
            "paper3": [best_in_scene4(cells)],
            "cpusap": [cpusap_against_bullet(cells)]}


def no_miss_target(pairs: list) -> Target:
    name = "no finder misses a pair"
    if not pairs:
        return not_run(name)
    missed = sum(r["missed"] for r in pairs)
    return Target(name, f"{missed} missed over {pairs[0]['frames']} frames", missed == 0)


def exactness_targets(pairs: list) -> list:
    """The pairs section's targets: the exact finders (bf aside) report exactly bf's pairs,
    and no finder misses one."""
    name = "the exact finders report bf's pairs: 0 missed, 0 extra"
    exact = [r for r in pairs if base_name(r["algo"]) in broadphases.exact()
             and base_name(r["algo"]) != "bf"]
    if not exact:
        return [not_run(name), no_miss_target(pairs)]
    wrong = [r["algo"] for r in exact if r["missed"] or r["extra_mean"]]
    figure = (f"{len(exact)} finders, {sum(r['missed'] for r in exact)} missed, "
              f"{sum(r['extra_max'] for r in exact)} extra")
    return [Target(name, figure + (f"; wrong: {', '.join(wrong)}" if wrong else ""), not wrong),
            no_miss_target(pairs)]


def summary_figure(targets: list) -> str:
    """A claim's figure: its one target's, or how many of its targets were met."""
    ran = [t for t in targets if t.met is not None]
    if len(targets) == 1 or not ran:
        return targets[0].figure if len(targets) == 1 else "not run"
    return f"{sum(t.met for t in ran)} of {len(ran)} targets met" + (
        f" ({len(targets) - len(ran)} not run)" if len(ran) < len(targets) else "")


def row(claim: str, targets: list, machine: str, section: str, runs: str = "—") -> list:
    return [claim, study_targets.verdict(targets) or "—", summary_figure(targets), runs,
            machine, section]


def runs_a_cell(rows: list) -> str:
    """The runs behind each timed cell of `rows` (their `repetitions`), "1" or "2-3";
    "—" when none ran."""
    counts = sorted({r["repetitions"] for r in rows})
    if not counts:
        return "—"
    return str(counts[0]) if len(counts) == 1 else f"{counts[0]}-{counts[-1]}"


def per_finder_rows(claim: str, targets: list, machine: str, runs: str) -> list:
    """A paper claim for each GPU finder: one row per finder that ran, one row (with no
    verdict) when none did."""
    ran = [(algo, t) for algo, t in zip(PAPER_GPU, targets) if t.met is not None]
    if not ran:
        return [row(claim, targets[:1], machine, "§1")]
    return [row(f"{claim} ({algo})", [t], machine, "§1", runs) for algo, t in ran]


def this_machine_rows(s: dict, machine: str, runs: dict) -> list:
    """`runs`: runs a cell of the sweep, the overlap runs and the ideal runs."""
    sweep = runs["sweep"]

    def timed(claim: str, key: str, section: str, how_many: str) -> list:
        ran = any(t.met is not None for t in s[key])
        return row(claim, s[key], machine, section, how_many if ran else "—")

    return (
        [timed("Premise: the broadphase is a large part of the frame", "premise", "§1.2",
               sweep)]
        + per_finder_rows("Paper 1: GPU-BF beats BF everywhere", s["paper1"], machine, sweep)
        + [timed("Paper 1 for GPU-BF's CPU twin (cpubf)", "twin1", "§1", sweep)]
        + per_finder_rows("Paper 2: GPU-BF is near SAP and BVH", s["paper2"], machine, sweep)
        + [timed("Paper 2 for GPU-BF's CPU twin (cpubf)", "twin2", "§1", sweep),
           timed("Paper 3: GPU-BF does best in scene 4 (mixed sizes)", "paper3", "§1", sweep),
           timed("Ours: cpusap beats Bullet's CPU broadphases", "cpusap", "§1", sweep),
           timed("Ours: the asynchronous frame pays", "overlap", "§4", runs["overlap"]),
           timed("Ours: the frame is near the ideal for its cores", "overlap_ideal", "§4.1",
                 runs["ideal"]),
           row("Ours: the exact finders are exact", s["pairs"], machine, "§3.1"),
           row("Ours: the default substeps and CCD cost less than the old fixed K, "
               "no more error", s["physics"], machine, "§3.2")])


def gpu_machine_rows() -> tuple:
    """(legend lines, rows) of the GPU machines' figures measured outside the study."""
    legend, rows = [], []
    for raw in gpu_results.MACHINES:
        found = gpu_results.machine_findings(NEAR, SHARE, raw)
        if not found:
            continue
        label, description = found["label"], found["description"]
        legend.append(f"**{label}**: {description}.")
        rows += [row(claim, [target], label, found["where"]) for claim, target in found["rows"]]
    return legend, rows


def machine_label(machine: dict) -> str:
    if machine is None:
        return "this study"
    if machine["gpu"].startswith("none"):
        return f"{machine['hardware_threads']}-thread CPU, no GPU"
    return machine["gpu"].split(" (")[0].removeprefix("NVIDIA ") + " host"


def findings_lines(sections: dict, machine: dict, commit_line: str, table, runs: dict) -> list:
    """The machines, once, then the findings table.  `sections`: each claim's targets;
    `runs`: runs_a_cell() of the sweep's, the overlap's and the ideal's rows."""
    label = machine_label(machine)
    legend = [f"**{label}**: this study's runs; {commit_line}"]
    rows = this_machine_rows(sections, label, runs)
    if not any(t.met is not None for key in ("paper1", "paper2", "paper3")
               for t in sections[key]):
        more, gpu_rows = gpu_machine_rows()
        legend += more
        rows += gpu_rows
    lines = ["Machines:", ""] + [f"- {entry}" for entry in legend] + [""]
    note = ["", "*runs a cell*: the runs of each timed cell behind a timing verdict. On a "
            "machine shared with other jobs, a verdict on one run a cell can turn from one "
            "study to the next (--profile with more repetitions settles it)."]
    return lines + table(["claim", "verdict", "figure", "runs a cell", "machine", "section"],
                         rows) + note


def sections_targets(cells: list, stages: list, pairs: list, physics: list, overlap: list,
                     ideal: list, fmt) -> dict:
    """Every claim's targets, each from its own section's module."""
    found = sweep_targets(cells, stages)
    found.update(overlap=study_overlap.targets(overlap),
                 overlap_ideal=study_overlap.ideal_targets(ideal),
                 pairs=exactness_targets(pairs),
                 physics=study_physics.targets(physics, fmt))
    if not found["physics"]:
        found["physics"] = [not_run("the default costs less than the old fixed K")]
    return found
