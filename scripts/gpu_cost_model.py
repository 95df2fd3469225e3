#!/usr/bin/python3
"""The GPU cost model of docs/results/gpu_kernel_cost.md, its constants fitted to what a GPU
machine measured, its error stated, and its predictions for gpusap as built (slabs, one
round trip) before a GPU measures it.

The model splits a GPU finder's frame, launch() to finish() on the host, into the stages
the benchmark times (overlap_bench_broadphase's upload_us, kernels_us, download_us, and
what is left of launch_to_finish_us: the host's part), each linear in what
scripts/gpu_kernel_cost.sh and the emulation count.  The copies' and the host's constants
are shared by gpubf and gpusap (pinned memory, the same calls), gpubf-paper has its own
(pageable memory, its host XOR); the kernels' and the downloads' are each finder's own (a
download event of gpubf and gpusap holds more than the copy: list overflows, waits):

  upload    u0 + bytes_to_device / up_rate
  download  d0 + bytes_from_device / down_rate
  kernels   gpubf:       k0 + words * per_word, words = n(n-1)/64 (the pair bits)
            gpubf-paper: k0 + pairs * per_pair, pairs = n(n-1)/2
            gpusap:      k0 + n * per_box + candidates * per_candidate, or with no box
                         term; candidates as counted on these streams along one axis
                         (docs/results/gpusap_candidates.csv, log-log between its sizes)
  host      gpubf, gpusap: h0 + api_calls * per_call + host_entries_sorted * per_entry
            (changes sorted on the host after a list overflow); gpubf-paper: h0 +
            bytes_from_device * per_byte (its host XOR over what it copied back)

Each is fitted by least squares on the relative error (every n weighs the same), over every
row of the machine's benchmark but gpusap's download and host at 10^6, where a resweep ran
inside them; the error is each row's model / measured - 1.  A row the fit leaves far off
is a stage the model does not describe (it says what to look for).

  scripts/gpu_cost_model.py [--raw docs/results/gpu/h100/raw]
"""
import math
import pathlib
import re
import statistics
import sys

import gpu_results
from results_files import read_csv
from script_cli import Parser, run

CANDIDATES = pathlib.Path(__file__).resolve().parent.parent / "docs/results/gpusap_candidates.csv"


def candidate_table() -> dict:
    """{n: (entries, candidates on one axis, candidates in slabs), each a box}, read from
    docs/results/gpusap_candidates.csv (counted on the scene-4 streams)."""
    return {int(r["n"]): (float(r["entries_per_box"]), float(r["candidates_one_axis"]),
                          float(r["candidates_slabs"])) for r in read_csv(CANDIDATES)}


def per_box(n: float, which: int) -> float:
    """A candidate table's column at n, interpolated log-log between the counted sizes."""
    table = candidate_table()
    sizes = sorted(table)
    lo = max([s for s in sizes if s <= n] or sizes[:1])
    hi = min([s for s in sizes if s >= n] or sizes[-1:])
    if lo == hi:
        return table[lo][which]
    t = math.log(n / lo) / math.log(hi / lo)
    return table[lo][which] * (table[hi][which] / table[lo][which]) ** t


def candidates(n: float, slabs: bool = False) -> float:
    """The sweep's candidates at n: along one axis (gpusap as the H100 ran it) or within
    the slabs of a second axis (gpusap as built now)."""
    return n * per_box(n, 2 if slabs else 1)


def solve(rows: list, terms) -> list:
    """Least squares of sum(c_i * term_i(row)) against row["y"], each row weighted by
    1 / y (relative error): the coefficients, by the normal equations."""
    k = len(terms(rows[0]))
    a = [[0.0] * k for _ in range(k)]
    b = [0.0] * k
    for row in rows:
        x, w = terms(row), 1.0 / row["y"] ** 2
        for i in range(k):
            b[i] += w * x[i] * row["y"]
            for j in range(k):
                a[i][j] += w * x[i] * x[j]
    for col in range(k):  # Gaussian elimination with partial pivoting
        pivot = max(range(col, k), key=lambda r: abs(a[r][col]))
        a[col], a[pivot], b[col], b[pivot] = a[pivot], a[col], b[pivot], b[col]
        for r in range(col + 1, k):
            f = a[r][col] / a[col][col]
            b[r] -= f * b[col]
            for c in range(col, k):
                a[r][c] -= f * a[col][c]
    coef = [0.0] * k
    for r in reversed(range(k)):
        coef[r] = (b[r] - sum(a[r][c] * coef[c] for c in range(r + 1, k))) / a[r][r]
    return coef


def stage_rows(raw: pathlib.Path) -> list:
    """The GPU finders' rows of the benchmark with every stage timed."""
    rows = []
    for r in gpu_results.bench_rows(raw):
        if r["algorithm"] in gpu_results.GPU_FINDERS and r.get("kernels_us"):
            row = {k: float(r[k]) for k in ("launch_to_finish_us", "upload_us", "kernels_us",
                                             "download_us", "bytes_to_device",
                                             "bytes_from_device", "api_calls",
                                             "host_entries_sorted")}
            row.update(n=int(r["n"]), algo=r["algorithm"])
            row["host_us"] = row["launch_to_finish_us"] - sum(
                row[k] for k in ("upload_us", "kernels_us", "download_us"))
            rows.append(row)
    return rows


KERNEL_TERMS = {
    "gpubf": lambda r: [1.0, r["n"] * (r["n"] - 1) / 64],
    "gpubf-paper": lambda r: [1.0, r["n"] * (r["n"] - 1) / 2],
    "gpusap": lambda r: [1.0, r["n"], candidates(r["n"])],
    "gpusap, no box term": lambda r: [1.0, candidates(r["n"])],
}
def family(algo: str) -> str:
    """Whose copy and host constants a finder shares."""
    return "gpubf-paper" if algo == "gpubf-paper" else "gpubf, gpusap"


STAGES = {  # stage: (measured column, constants shared by, terms for a finder)
    "upload": ("upload_us", family, lambda algo: lambda r: [1.0, r["bytes_to_device"]]),
    "kernels": ("kernels_us", lambda algo: algo, KERNEL_TERMS.get),
    "download": ("download_us", lambda algo: algo,
                 lambda algo: lambda r: [1.0, r["bytes_from_device"]]),
    "host": ("host_us", family, lambda algo: (lambda r: [1.0, r["bytes_from_device"]])
             if algo == "gpubf-paper" else
             (lambda r: [1.0, r["api_calls"], r["host_entries_sorted"]])),
}


def resweep_row(row: dict) -> bool:
    """gpusap's row at 10^6: its frame overflowed the pair room and swept again inside the
    download's events (the finder at d5e40a4 re-recorded the count's event after the
    resweep) and on the host's time (the reallocation); its kernels' events hold one sweep."""
    return row["algo"] == "gpusap" and row["n"] >= 10**6


def fit(rows: list, clean: bool = True) -> dict:
    """{(stage, who): coefficients}: `who` a finder or the finders sharing constants.
    clean: the resweep's download and host left out of their stages' fits."""
    fitted = {}
    for stage, (column, shared, terms) in STAGES.items():
        for who in sorted({shared(r["algo"]) for r in rows}):
            used = [dict(r, y=r[column]) for r in rows if shared(r["algo"]) == who
                    and not (clean and stage in ("download", "host") and resweep_row(r))]
            fitted[(stage, who)] = solve(used, terms(used[0]["algo"]))
    gpusap = [dict(r, y=r["kernels_us"]) for r in rows if r["algo"] == "gpusap"]
    fitted[("kernels", "gpusap, no box term")] = solve(gpusap, KERNEL_TERMS["gpusap, no box term"])
    return fitted


def model(fitted: dict, row: dict) -> dict:
    """The model's stages (µs) for a row's finder, n, bytes and calls."""
    return {stage: sum(c * t for c, t in zip(fitted[(stage, shared(row["algo"]))],
                                             terms(row["algo"])(row)))
            for stage, (_, shared, terms) in STAGES.items()}


def error_table(fitted: dict, rows: list) -> tuple:
    lines = ["| finder | n | stage | measured (µs) | model (µs) | error |", "|---|---:|---|---:|---:|---:|"]
    errors = {}
    for row in rows:
        predicted = model(fitted, row)
        for stage, column in (("upload", "upload_us"), ("kernels", "kernels_us"),
                              ("download", "download_us"), ("host", "host_us")):
            error = predicted[stage] / row[column] - 1
            if stage == "kernels" and row["algo"] == "gpusap":
                bare = fitted[("kernels", "gpusap, no box term")]
                other = sum(c * t for c, t in zip(bare, KERNEL_TERMS["gpusap, no box term"](row)))
                errors.setdefault("kernels, gpusap without its box term", []).append(
                    (abs(other / row[column] - 1), row["algo"], row["n"]))
            if not (stage in ("download", "host") and resweep_row(row)):
                errors.setdefault(stage, []).append((abs(error), row["algo"], row["n"]))
            lines.append(f"| {row['algo']} | {row['n']} | {stage} | {row[column]:.1f} | "
                         f"{predicted[stage]:.1f} | {error:+.0%} |")
        if not resweep_row(row):  # the whole frame, launch to finish
            frame = sum(predicted.values()) / row["launch_to_finish_us"] - 1
            errors.setdefault("frame", []).append((abs(frame), row["algo"], row["n"]))
            if row["algo"] == "gpusap":
                bare = fitted[("kernels", "gpusap, no box term")]
                other = sum(predicted.values()) - predicted["kernels"] + sum(
                    c * t for c, t in zip(bare, KERNEL_TERMS["gpusap, no box term"](row)))
                errors.setdefault("gpusap's frame without its box term", []).append(
                    (abs(other / row["launch_to_finish_us"] - 1), row["algo"], row["n"]))
    return lines, errors


H100_SIZES = (500, 1250, 2000, 2750, 3500, 10**4, 3 * 10**4, 10**5, 10**6)
CPUSAP_16T_US = {10**4: 1899, 3 * 10**4: 5420, 10**6: 194073}  # the H100's, bench-big/-million
HEAD_BYTES = 32 + 4096 * 8  # gpusap's result block: four counts and 4096 changes


def changes(rows: list, n: int):
    """The changes a frame of the H100's streams makes at n: from gpusap's measured copy back
    (its tails past 4096 a list), interpolated per box between the sizes with tails;
    None where no list outgrew its head (at most 2 x 4096 changes)."""
    known = {r["n"]: (r["bytes_from_device"] - 65560) / 8 + 2 * 4096 for r in rows
             if r["algo"] == "gpusap" and r["bytes_from_device"] > 65560}
    if n in known:
        return known[n]
    lo = max((k for k in known if k < n), default=None)
    hi = min((k for k in known if k > n), default=None)
    if lo is None or hi is None:
        return None
    t = math.log(n / lo) / math.log(hi / lo)
    return n * known[lo] / lo * (known[hi] / hi / (known[lo] / lo)) ** t


def built_design(fitted: dict, rows: list, n: int) -> dict:
    """gpusap as built (slabs, one round trip), its stages through the fitted constants:
    upload 32n bytes; kernels: the fixed time scaled from 10 to 12 kernels and CUB calls,
    the per-box rate on n, the per-candidate rate on the slabs' candidates; one copy back of
    the result block, two more past 4096 changes (8 bytes a change), each at the pinned
    upload's fitted rate (a copy gpusap's old download events did not time alone); host:
    36 calls, 41 with tails."""
    up = fitted[("upload", "gpubf, gpusap")]
    k0, per_box, per_candidate = fitted[("kernels", "gpusap")]
    bare = fitted[("kernels", "gpusap, no box term")]
    h0, per_call, _ = fitted[("host", "gpubf, gpusap")]
    change = changes(rows, n)
    tail = max(0.0, (change or 0) - 4096) * 8
    copies = [HEAD_BYTES] + ([tail / 2, tail / 2] if tail else [])
    fixed = 12 / 10
    stages = {"upload": up[0] + up[1] * 32 * n,
              "kernels": k0 * fixed + per_box * n + per_candidate * candidates(n, slabs=True),
              "kernels, no box term": bare[0] * fixed + bare[1] * candidates(n, slabs=True),
              "download": sum(up[0] + up[1] * b for b in copies),
              "host": h0 + per_call * (41 if tail else 36)}
    for kernels in ("kernels", "kernels, no box term"):
        stages["frame, " + kernels] = sum(stages[s] for s in ("upload", kernels, "download",
                                                               "host"))
    stages["changes"] = change
    return stages


def predictions(fitted: dict, rows: list) -> list:
    """gpusap as built at the H100's sizes, and gpubf's next step at 3500.  Predictions, to
    be measured."""
    lines = ["| n | changes | upload | kernels, box term | download | host | **frame** | "
             "kernels, no box term | **frame** | cpusap 16t / frame | target |",
             "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
    for n in H100_SIZES:
        p = built_design(fitted, rows, n)
        change = "≤ 8192" if p["changes"] is None else f"{p['changes']:.0f}"
        frames = (p["frame, kernels"], p["frame, kernels, no box term"])
        target, ratio = "", "-"
        if n in CPUSAP_16T_US:
            ratio = " / ".join(f"{CPUSAP_16T_US[n] / f:.1f}x" for f in frames)
            target = "≥ 10x cpusap 16t"
        if n == 10**6:
            target += ", ≤ 5000 µs"
        lines.append(f"| {n} | {change} | {p['upload']:.0f} | {p['kernels']:.0f} | "
                     f"{p['download']:.0f} | {p['host']:.0f} | **{frames[0]:.0f}** | "
                     f"{p['kernels, no box term']:.0f} | **{frames[1]:.0f}** | {ratio} | "
                     f"{target} |")
    lines += ["", "| design | n | upload | kernels | download | host | launch to finish |",
              "|---|---:|---:|---:|---:|---:|---:|"]
    # gpubf as built: one graph launch and one wait (2 calls), one kernel that sorts the
    # changes in its last block.  The fit cannot tell which of the old two kernels its fixed
    # kernel time was: without it (the sort kernel's, gone) and with it (the search's, kept).
    for what, calls, fixed in (("gpubf, the model as fitted (10 calls, 2 kernels)", 10, True),
                               ("gpubf as built, fixed kernel time gone (2 calls, 1 kernel)", 2,
                                False),
                               ("gpubf as built, fixed kernel time kept (2 calls, 1 kernel)", 2,
                                True)):
        row = {"n": 3500, "algo": "gpubf", "bytes_to_device": 112000,
               "bytes_from_device": 65568, "api_calls": calls, "host_entries_sorted": 0}
        s = model(fitted, row)
        if not fixed:
            s["kernels"] -= fitted[("kernels", "gpubf")][0]
        lines.append(f"| {what} | 3500 | {s['upload']:.0f} | {s['kernels']:.0f} | "
                     f"{s['download']:.0f} | {s['host']:.0f} | **{sum(s.values()):.0f}** |")
    return lines


UNITS = {"upload": ["µs", "µs a byte"], "download": ["µs", "µs a byte"],
         "kernels gpubf": ["µs", "µs a word"], "kernels gpubf-paper": ["µs", "µs a pair"],
         "kernels gpusap": ["µs", "µs a box", "µs a candidate"],
         "kernels gpusap, no box term": ["µs", "µs a candidate"],
         "host gpubf, gpusap": ["µs", "µs a call", "µs a sorted entry"],
         "host gpubf-paper": ["µs", "µs a byte copied back"]}


def print_constants(fitted: dict) -> None:
    print("| stage | constants shared by | fitted |\n|---|---|---|")
    for (stage, who), coef in fitted.items():
        units = UNITS.get(f"{stage} {who}", UNITS.get(stage))
        print(f"| {stage} | {who} | " + " + ".join(f"{c:.4g} {u}" for c, u in zip(coef, units))
              + (f" ({1e-3 / coef[1]:.1f} GB/s)" if stage in ("upload", "download") else "")
              + " |")


def print_errors(fitted: dict, rows: list) -> None:
    lines, errors = error_table(fitted, rows)
    print("\nThe model against every measured stage:\n\n" + "\n".join(lines) + "\n")
    print("Error, |model / measured - 1| over the rows: " + "; ".join(
        f"{stage} median {statistics.median(e for e, _, _ in errs):.0%}, largest "
        f"{max(errs)[0]:.0%} ({max(errs)[1]} at {max(errs)[2]})"
        for stage, errs in errors.items()) + ".\n")


def print_resweep(fitted: dict, rows: list) -> None:
    """The frames that overflowed and swept again, and the fits with and without them."""
    for r in [r for r in rows if resweep_row(r)]:
        second = fitted[("kernels", "gpusap")][2] * candidates(r["n"])
        print(f"The resweep at {r['n']}, modelled as a second one-axis sweep in the download: "
              f"{model(fitted, r)['download'] + second:.0f} µs against {r['download_us']:.0f} "
              f"measured ({(model(fitted, r)['download'] + second) / r['download_us'] - 1:+.0%}).")
    polluted = fit(rows, clean=False)
    print("Fitted with the resweep's download and host: gpusap download "
          + " + ".join(f"{c:.4g}" for c in polluted[("download", "gpusap")])
          + " a byte; host " + " + ".join(f"{c:.4g}" for c in polluted[("host", "gpubf, gpusap")])
          + " (fixed, a call, a sorted entry).")
    small = [r for r in rows if not resweep_row(r)]
    k = solve([dict(r, y=r["kernels_us"]) for r in small if r["algo"] == "gpusap"],
              KERNEL_TERMS["gpusap"])
    print("gpusap's kernels fitted without the 10^6 row: " + " + ".join(
        f"{c:.4g} {u}" for c, u in zip(k, ["µs", "µs a box", "µs a candidate"])) + ".\n")


def main() -> None:
    parser = Parser(description=__doc__.splitlines()[0])
    parser.add_argument("--raw", type=gpu_results.raw_folder, default=gpu_results.MACHINES[0],
                        help="one machine's raw folder (default: the newest machine's)")
    raw = parser.parse_args().raw
    rows = stage_rows(raw)
    fitted = fit(rows)
    m = gpu_results.machine(raw)
    print(f"Fitted to {gpu_results.folder(raw.resolve())} ({m['gpu']}, commit "
          f"{m['git_commit'][:7]}): {len(rows)} rows of GPU finders.\n")
    print_constants(fitted)
    print_errors(fitted, rows)
    print_resweep(fitted, rows)
    print("PREDICTIONS (not measurements), µs:\n\n" + "\n".join(predictions(fitted, rows)))


if __name__ == "__main__":
    sys.exit(run(main))
