"""The report's first screen: the paper's three claims and ours, each with its figure,
the verdict the figures give and the section that holds them.

Every verdict is computed from the same rows the sections print; where the
runs a claim needs are missing (the GPU's, on a machine without one) the
verdict says so and the row gives what was measured instead, labelled: the
CPU twin's figure from this report's runs, then each GPU machine's from its
raw files in docs/results/gpu/ (scripts/gpu_results.py), named as that
machine's and not this report's, until the study itself runs on a GPU.
"""
import broadphases
import gpu_results
import study_physics
from study_results import update_and_broadphase_ms

PUBLISHED_CPU = ("bf", "sap", "bvh")  # Bullet's broadphases, the paper's BF, SAP and BVH
NEAR = 1.25  # "near": at most this factor slower


def ratio_range(cells: list, algo: str, other: str, value) -> tuple:
    """(cells compared, cells where algo is faster, min ratio, max ratio) over (scene, n)."""
    by_key = {(c["scene"], c["objects"], c["algo"]): c for c in cells if not c["fallback"]}
    ratios = [value(by_key[(s, n, a)]) / value(by_key[(s, n, other)])
              for (s, n, a) in by_key if a == algo and (s, n, other) in by_key]
    if not ratios:
        return 0, 0, float("nan"), float("nan")
    return len(ratios), sum(r < 1 for r in ratios), min(ratios), max(ratios)


def gpu_measured(cells: list) -> list:
    return [a for a in broadphases.needs_device() if any(c["algo"] == a and not c["fallback"] for c in cells)]


def cite_gpu_machines(rows: list, gpu: list) -> list:
    """Without a GPU in this report's runs, each paper claim's row also gives each GPU
    machine's figure and verdict (docs/results/gpu/), newest first, each marked as that
    machine's."""
    for raw in () if gpu else gpu_results.MACHINES:
        cited = gpu_results.claim_figures(NEAR, raw)
        for number, row in enumerate(rows, start=1):
            if number in cited:
                row[1] += ". " + cited[number][0]
                row[2] += "; " + cited[number][1]
    return rows


def paper_rows(cells: list) -> list:
    rows = []
    gpu = gpu_measured(cells)
    stand_in = gpu[0] if gpu else "cpubf"
    who = stand_in if gpu else "no GPU lent: its CPU twin cpubf"
    total = lambda c: c["total_mean"]  # noqa: E731
    compared, faster, low, high = ratio_range(cells, stand_in, "bf", update_and_broadphase_ms)
    rows.append(["Paper 1: GPU-BF beats BF everywhere",
                 f"{who}: update + broadphase x{low:.2f}-x{high:.2f} of bf's, faster in "
                 f"{faster} of {compared} cells" if compared else "not run",
                 ("holds" if compared and faster == compared else "does not hold")
                 + ("" if gpu else " for the CPU twin; untested on a GPU in this study"), "§1"])
    near = []
    for other in ("sap", "bvh"):
        compared, _, low, high = ratio_range(cells, stand_in, other, total)
        if compared:
            near.append((other, low, high))
    verdict = "holds" if near and all(hi <= NEAR for _, _, hi in near) else "does not hold"
    rows.append([f"Paper 2: GPU-BF is near SAP and BVH (whole frame, at most x{NEAR} of theirs)",
                 f"{who}: " + "; ".join(f"x{lo:.2f}-x{hi:.2f} of {o}'s" for o, lo, hi in near)
                 if near else "not run",
                 verdict
                 + ("" if gpu else "; untested on a GPU in this study"), "§1"])
    scene4 = [c for c in cells if c["scene"] == 4 and not c["fallback"]]
    if scene4:
        n = max(c["objects"] for c in scene4)
        at_n = sorted((c for c in scene4 if c["objects"] == n), key=total)
        best = at_n[0]
        rows.append(["Paper 3: GPU-BF does best in scene 4 (mixed sizes)",
                     f"fastest whole frame at {n} boxes: {best['algo']} "
                     f"({best['total_mean']:.0f} ms; next {at_n[1]['algo']} "
                     f"{at_n[1]['total_mean']:.0f})" if len(at_n) > 1 else best["algo"],
                     ("holds" if best["algo"] in broadphases.needs_device() else "does not hold")
                     + ("" if gpu else " among the algorithms run; untested on a GPU in this study"), "§1"])
    return cite_gpu_machines(rows, gpu)


def async_row(overlap: list) -> list:
    at_one = [r for r in overlap if r["scene"] == 4 and r["load"] == 1]
    at_zero = [r for r in overlap if r["load"] == 0]
    if not at_one:
        return ["Ours: the asynchronous frame pays", "not run", "—", "§4"]
    low = min(r["speedup"] for r in at_one)
    high = max(r["speedup"] for r in at_one)
    ideal = min(r["async_over_ideal"] for r in at_one), max(r["async_over_ideal"] for r in at_one)
    slower = [r for r in at_zero if r["speedup_max"] < 1.0]
    return ["Ours: the asynchronous frame pays (tasks beside the physics step)",
            f"scene 4, task load 1: speed-up (sync / async) x{low:.2f}-x{high:.2f}; async "
            f"takes x{ideal[0]:.2f}-x{ideal[1]:.2f} of this machine's ideal frame",
            ("holds" if low > 1.0 else "does not hold")
            + ("; slower at task load 0 somewhere" if slower else "; no slower at task load 0"),
            "§4"]


def exactness_row(pairs: list) -> list:
    exact = [r for r in pairs if r["algo"].split(" ")[0] in broadphases.exact() and
             r["algo"].split(" ")[0] != "bf"]
    if not exact:
        return ["Ours: the exact broadphases are exact", "not run", "—", "§3.1"]
    wrong = [r for r in exact if r["missed"] or r["extra_mean"]]
    frames = exact[0]["frames"]
    return ["Ours: the exact broadphases are exact",
            f"{', '.join(r['algo'] for r in exact)}: "
            f"{sum(r['missed'] for r in exact)} missed, "
            f"{sum(r['extra_max'] for r in exact)} extra against bf over {frames} frames",
            "holds" if not wrong else "does not hold: " + ", ".join(r["algo"] for r in wrong),
            "§3.1"]


def physics_row(physics: list) -> list:
    cells = study_physics.default_against_old(physics)
    if not cells:
        return ["Ours: speed against error", "not run", "—", "§3.2"]
    met = [c for c in cells if not study_physics.compare(c[3], c[4])[2]]
    times = [study_physics.compare(c[3], c[4])[0] for c in cells]
    return ["Ours: the automatic substeps and CCD cost less than the old fixed K, "
            "with no more error",
            f"time x{min(times):.2f}-x{max(times):.2f} of the old default; "
            f"{len(met)} of {len(cells)} (scene, boxes, seed) cells meet the target",
            "holds" if len(met) == len(cells) else
            f"holds in {len(met)} of {len(cells)} cells", "§3.2"]


def cpu_row(cells: list) -> list:
    honest = [c for c in cells if not c["fallback"]]
    lines, wins, scenes = [], 0, sorted({c["scene"] for c in honest})
    for scene in scenes:
        n = max(c["objects"] for c in honest if c["scene"] == scene)
        at_n = {c["algo"]: c for c in honest if c["scene"] == scene and c["objects"] == n}
        peers = [at_n[a] for a in PUBLISHED_CPU if a in at_n]
        if "cpusap" not in at_n or not peers:
            continue
        best = min(peers, key=update_and_broadphase_ms)
        ratio = update_and_broadphase_ms(at_n["cpusap"]) / update_and_broadphase_ms(best)
        wins += ratio < 1
        lines.append(f"s{scene}: x{ratio:.2f} of {best['algo']}")
    if not lines:
        return ["Ours: cpusap against the published CPU broadphases", "not run", "—", "§1"]
    n = max(c["objects"] for c in honest)
    return ["Ours: cpusap against the published CPU broadphases (Bullet's bf, sap, bvh)",
            f"update + broadphase at {n} boxes against the best of them: " + ", ".join(lines),
            f"faster in {wins} of {len(lines)} scenes", "§1"]


def claims_lines(cells: list, pairs: list, physics: list, overlap: list, table) -> list:
    rows = paper_rows(cells) + [async_row(overlap), exactness_row(pairs), physics_row(physics),
                                cpu_row(cells)]
    return table(["claim", "figure", "verdict", "section"], rows)
