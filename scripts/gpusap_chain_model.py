#!/usr/bin/python3
"""gpusap's steady frame step by step, and its kernel time refitted by the steps' count: the
model of docs/results/gpu_kernel_cost.md's gpusap sections, its fixed time no longer one
constant scaled by a guessed ratio but a cost for each GPU step of the chain, fitted to the
H100's measured stages; then the predictions for the chain before and after issue 41's cut.

A GPU step is one kernel or one memset the device runs.  The chain's own kernels are one
each; CUB's calls (CUDA 13.0's CUB, sm_90 policies, read from its dispatch code):
  DeviceScan::ExclusiveSum, DeviceSelect::If   2 (an init kernel and the pass)
  DeviceRadixSort, at most one tile            1 (256 threads x 19 four-byte items, fewer
                                                  for wider keys or values)
  DeviceRadixSort, more                        4 + 2 per 8-bit pass (two memsets, a
                                                  histogram and its scan; per pass a memset
                                                  of the look-back and the onesweep kernel)

Two fits of the kernels' events (kernels_us), both on gpusap's rows of the H100 run (commit
d5e40a4, whose chain is `chain("d5e40a4", ...)`), least squares on the relative error:
  per step   kernels = c_step * steps + c_cand * candidates (one axis, as it swept)
  sort steps kernels = c_sort * CUB sort steps + c_cand * candidates (the other steps free)
Those rows hold two chain shapes only (the box sort one tile up to 3500, onesweep from
10^4), so they cannot tell a sort step's cost from the others' (a fit with both gives the
others a negative cost); the two fits bracket it.

The frame around the kernels is scripts/gpu_cost_model.py's: its fitted upload and host
constants, the result block's copy (and the tails' past 4096 changes) at the upload's rate,
and the chain's CUDA calls.

  scripts/gpusap_chain_model.py [--raw docs/results/gpu/h100/raw]
"""
import math
import pathlib
import sys

import gpu_cost_model as model
import gpu_results
from script_cli import Parser, run


def radix_steps(items: int, key_bytes: int, value_bytes: int, bits: int) -> tuple:
    """(other steps, sort steps) of one CUB radix sort of `items` over `bits` bits."""
    dominant = max(4, key_bytes, value_bytes)
    single_tile = 256 * max(1, 19 * 4 // dominant)
    if items == 0:
        return 0, 0
    if items <= single_tile:
        return 0, 1  # one kernel, but a sort's
    return 0, 4 + 2 * math.ceil(bits / 8)


def capacities(n: int, pairs: float) -> tuple:
    """gpusap's steady entry and pair capacities (its header: 2 a box at first; grown to 5/4
    of a frame's count plus 64, at least doubling)."""
    entry_room = 2 * n  # about 1.33 entries a box on the scene-4 streams, under the first guess
    pair_room = 2 * n if pairs <= 2 * n else max(int(pairs * 5 / 4) + 64, 4 * n)
    return entry_room, pair_room


STEPS = {  # design: (its own kernels and memsets, CUB scans and selections, CUDA calls a frame)
    # the H100's: 2 memsets, centre bounds, sort keys, candidate counts, sweep, toIndexPairs
    "d5e40a4": (7, 3, 42),
    # main at eebdbb4: memset, bounds, spans, entries, counts, memset of the pairs, sweep, pack
    "before": (8, 4, 36),
    # this branch: bounds (and the fills), entries (atomics), sweep, pack (zeroes the counters)
    "after": (4, 3, 28),
}


def chain(design: str, n: int, pairs: float) -> dict:
    """The GPU steps of a steady frame of `design` at n boxes and `pairs` pairs."""
    own, cub_calls, calls = STEPS[design]
    bw = n.bit_length()
    max_slabs = min(max(n // 32, 1), 1024)
    entry_room, pair_room = capacities(n, pairs)
    if design == "d5e40a4":  # 32-bit keys of n boxes; the exact pair count, known after a round trip
        sorts = [radix_steps(n, 4, 4, 32), radix_steps(int(pairs), 8, 0, 32 + bw)]
    elif design == "before":  # keys (slab, min): 32 + the slab's bits
        sorts = [radix_steps(entry_room, 8, 4, 32 + (max_slabs - 1).bit_length()),
                 radix_steps(pair_room, 8, 0, 32 + bw)]
    else:  # the slab's bits dropped from the bottom: 32 bits sorted
        sorts = [radix_steps(entry_room, 8, 4, 32), radix_steps(pair_room, 8, 0, 32 + bw)]
    sort_steps = sum(s for _, s in sorts)
    other = own + 2 * cub_calls
    return {"other": other, "sort": sort_steps, "steps": other + sort_steps, "calls": calls}


FITS = {
    "per step": lambda r: [r["steps"], r["candidates"]],
    "sort steps": lambda r: [r["sort"], r["candidates"]],
}


def measured_rows(raw: pathlib.Path) -> list:
    rows = []
    for r in gpu_results.bench_rows(raw):
        if r["algorithm"] == "gpusap" and r.get("kernels_us"):
            n = int(r["n"])
            row = chain("d5e40a4", n, float(r["pairs_mean"]))
            row.update(n=n, y=float(r["kernels_us"]), candidates=model.candidates(n))
            rows.append(row)
    return rows


def kernels(coef: list, fit: str, row: dict) -> float:
    return sum(c * t for c, t in zip(coef, FITS[fit](row)))


def frame(fitted: dict, coef: dict, design: str, n: int, pairs: float, changes) -> dict:
    """The stages of `design`'s steady frame at n (µs), through both kernel fits."""
    up = fitted[("upload", "gpubf, gpusap")]
    h0, per_call, _ = fitted[("host", "gpubf, gpusap")]
    steps = chain(design, n, pairs)
    steps["candidates"] = model.candidates(n, slabs=True)
    tail = max(0.0, (changes or 0) - 4096) * 8
    copies = [model.HEAD_BYTES] + ([tail / 2, tail / 2] if tail else [])
    stages = {"upload": up[0] + up[1] * 32 * n,
              "download": sum(up[0] + up[1] * b for b in copies),
              "host": h0 + per_call * (steps["calls"] + (5 if tail else 0))}
    rest = sum(stages.values())
    for fit in FITS:
        stages["kernels, " + fit] = kernels(coef[fit], fit, steps)
        stages["frame, " + fit] = rest + stages["kernels, " + fit]
    stages.update(steps)
    return stages


# Pairs a box on the H100's streams (its benchmark's pairs_mean; 1.3·10^4 between its
# neighbours, 10^5 from docs/results/gpusap_candidates.csv), and gpubf's launch to finish there.
PAIRS_PER_BOX = {3500: 4.19, 10**4: 4.15, 13000: 4.2, 3 * 10**4: 4.34, 10**5: 4.01,
                 10**6: 3.57}
GPUBF_US = {3500: 70, 10**4: 215, 3 * 10**4: 2550}


def main() -> None:
    parser = Parser(description=__doc__.splitlines()[0])
    parser.add_argument("--raw", type=gpu_results.raw_folder, default=gpu_results.MACHINES[0],
                        help="one machine's raw folder (default: the newest machine's)")
    raw = parser.parse_args().raw
    rows = measured_rows(raw)
    coef = {fit: model.solve(rows, terms) for fit, terms in FITS.items()}
    print("Kernel fits on gpusap's H100 rows (commit d5e40a4's chain):\n")
    print("| fit | constants |\n|---|---|")
    print(f"| per step | {coef['per step'][0]:.3g} µs a step + {coef['per step'][1]:.3g} µs a "
          f"candidate |")
    c = coef["sort steps"]
    print(f"| sort steps | {c[0]:.3g} µs a CUB sort step + {c[1]:.3g} µs a candidate |")
    print("\n| n | steps (sort) | measured kernels | per step | error | sort steps | error |")
    print("|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        a, b = kernels(coef["per step"], "per step", r), kernels(coef["sort steps"], "sort steps", r)
        print(f"| {r['n']} | {r['steps']} ({r['sort']}) | {r['y']:.0f} | {a:.0f} | "
              f"{a / r['y'] - 1:+.0%} | {b:.0f} | {b / r['y'] - 1:+.0%} |")
    fitted = model.fit(model.stage_rows(raw))
    stage_rows = model.stage_rows(raw)
    print("\nPREDICTIONS (not measurements), µs, launch to finish; cpusap 16t is the H100's:\n")
    print("| n | design | steps (sort) | calls | kernels, per step / sort steps | upload | "
          "download | host | **frame** | cpusap 16t / frame | gpubf measured |")
    print("|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for n in PAIRS_PER_BOX:
        changes = model.changes(stage_rows, n)
        for design in ("before", "after"):
            s = frame(fitted, coef, design, n, PAIRS_PER_BOX[n] * n, changes)
            frames = (s["frame, per step"], s["frame, sort steps"])
            cpusap = model.CPUSAP_16T_US.get(n)
            ratio = " / ".join(f"{cpusap / f:.1f}x" for f in frames) if cpusap else "-"
            print(f"| {n} | {design} | {s['steps']} ({s['sort']}) | {s['calls']} | "
                  f"{s['kernels, per step']:.0f} / {s['kernels, sort steps']:.0f} | "
                  f"{s['upload']:.0f} | {s['download']:.0f} | {s['host']:.0f} | "
                  f"**{frames[0]:.0f} / {frames[1]:.0f}** | {ratio} | "
                  f"{GPUBF_US.get(n, '-')} |")


if __name__ == "__main__":
    sys.exit(run(main))
