"""Speed against error, the broadphase's part: its pairs against the exact oracle (§3.1)
and a broadphase one frame late (§3.3), as generated blocks.

Rules, each with its reason:
  * A finder that missed an exact pair is a failure of the study (exit 1), not a row
    to read past.
  * Whether a late search pays is decided from measured times only: the narrowphase
    work its extra pairs add against the on-time searches it takes off the frame's
    critical path, with a margin of 5 (an extra pair that does not touch costs less
    than the sweep's average pair).
"""
import study_claims
import study_plots
import study_results
import study_targets
from study_tables import algo_order, fmt, table


def pair_row(r: dict) -> list:
    return [r["algo"], r["frames"], fmt(r["exact_mean"]), fmt(r["reported_mean"]), r["missed"],
            fmt(r["extra_mean"]), f"{100 * r['extra_share']:.2f}%", r["extra_max"],
            fmt(r["time_ms"])]


def add_sweep_times(pairs: list, cells: list, n: int) -> None:
    """Each pairs row's update + broadphase from the sweep (scene 4 at n), NaN without one."""
    time = {c["algo"]: study_results.update_and_broadphase_ms(c)
            for c in cells if c["scene"] == 4 and c["objects"] == n and not c["fallback"]}
    for r in pairs:
        r["time_ms"] = time.get(r["algo"], float("nan"))


def pairs_block(pairs: list, cells: list, n: int, figures: dict) -> tuple:
    """(the block, its failures: a finder that missed exact pairs)."""
    if not pairs:
        return ["No pair comparison has run yet.", ""], []
    failures = [f"{r['algo']} missed {r['missed']} exact pairs on the scene-4 stream"
                for r in pairs if r["missed"]]
    add_sweep_times(pairs, cells, n)
    order = algo_order(r["algo"] for r in pairs)
    ordered = sorted(pairs, key=lambda r: order.index(r["algo"]))
    lines = table(["algo", "frames", "exact pairs/frame", "reported/frame", "missed (total)",
                   "extra/frame", "extra share", "extra max", "update+bp ms/frame (sweep)"],
                  [pair_row(r) for r in ordered])
    lines += study_targets.lines(study_claims.exactness_targets(pairs), table)
    timed = [r for r in pairs if r["time_ms"] == r["time_ms"] and not r["missed"]]
    if timed:
        study_plots.broadphase_error(timed, figures["folder"])
        lines += ["![broadphase speed against error](report/fig_broadphase_error.png)", ""]
    return lines, failures


def late_search_costs(best: dict, cells: list) -> tuple:
    """(ms the extra pairs add to the narrowphase, ms of on-time search taken off the
    path, the verdict), from the sweep's bvh run of the scene at the nearest n; None
    without one."""
    mine = [c for c in cells if c["scene"] == best["scene"] and c["algo"] == "bvh"
            and c["pairs_median"] > 0]
    if not mine:
        return None
    cell = min(mine, key=lambda c: abs(c["objects"] - best["objects"]))
    per_pair_ms = cell["narrowphase_mean"] / cell["pairs_median"]
    added = (best["late_pairs_mean"] - best["exact_mean"]) * per_pair_ms
    saved = cell["substeps"] * best["on_time_ms"]
    verdict = ("does not pay" if added > 5 * saved else "pays" if added < saved
               else "too close to call")
    return added, saved, verdict


def late_row(scene: int, mine: list, cells: list) -> list:
    """One scene: the smallest growth without a miss per algorithm, and the best late
    setting (no miss, fewest pairs for the narrowphase) with what it costs and saves."""
    clean = {}
    for r in mine:
        if r["missed_total"] == 0:
            clean.setdefault(r["algo"], []).append(r["growth"])
    smallest = ", ".join(f"{a} {min(clean[a]):g}" if a in clean else f"{a} none"
                         for a in algo_order({r["algo"] for r in mine}))
    safe = [r for r in mine if r["missed_total"] == 0]
    if not safe:
        return [scene, smallest, "none", "—", "—", "—", "—", "—"]
    best = min(safe, key=lambda r: (r["late_pairs_mean"], r["late_ms"]))
    costs = late_search_costs(best, cells)
    added, saved, verdict = costs if costs else (float("nan"), float("nan"), "—")
    return [scene, smallest, f"{best['algo']}, growth {best['growth']:g}",
            f"x{best['late_pairs_mean'] / best['exact_mean']:.1f}", fmt(best["on_time_ms"]),
            fmt(added), fmt(saved), verdict]


def latency_row(r: dict) -> list:
    """The report's columns; every column of every row is in latency.csv."""
    return [r["scene"], r["algo"], f"{r['growth']:g}", fmt(r["exact_mean"]), r["missed_total"],
            f"{100 * r['missed_share']:.3f}%", fmt(r["extra_mean"]), fmt(r["on_time_ms"]),
            fmt(r["late_ms"])]


def latency_block(rows: list, figures: dict, cells: list) -> list:
    if not rows:
        return ["No latency runs yet.", ""]
    lines = [f"{rows[0]['objects']} boxes, {rows[0]['frames']} frames. Growth g: last "
             "frame's AABBs grown by g·|v|·dt. Missed and extra: against the exact pairs of "
             "this frame's AABBs. Times: medians of writing the AABBs and finding the pairs.",
             ""]
    lines += table(["scene", "algo", "growth", "exact/frame", "missed", "missed share",
                    "extra/frame (late)", "on-time ms", "late ms"],
                   [latency_row(r) for r in rows])
    scenes = sorted({r["scene"] for r in rows})
    lines += ["The best late setting of each scene (no miss, fewest pairs), what its extra "
              "pairs add to the narrowphase and the on-time search it takes off the path "
              "(ms per frame; pays when it adds less than it saves, does not when over 5x):",
              ""]
    lines += table(["scene", "smallest growth without a miss", "best late setting",
                    "pairs / exact", "on-time ms", "adds ms", "saves ms", "verdict"],
                   [late_row(s, [r for r in rows if r["scene"] == s], cells) for s in scenes])
    study_plots.latency(rows, figures["folder"])
    return lines + ["![late broadphase](report/fig_latency.png)", ""]
