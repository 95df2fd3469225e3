#!/usr/bin/python3
"""The GPU cost model of docs/results/gpu_kernel_cost.md, its constants fitted to what a GPU
machine measured, its error stated, and its predictions for the designs not yet built.

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
            gpusap:      k0 + n * per_box + candidates * per_candidate, candidates =
                         96 (n / 3500)^(5/3) * 3500: one sweep axis, 96 a box at 3500
                         (cpusap's count on these streams), growing as n^(2/3) a box
  host      gpubf, gpusap: h0 + api_calls * per_call + host_entries_sorted * per_entry
            (changes sorted on the host after a list overflow); gpubf-paper: h0 +
            bytes_from_device * per_byte (its host XOR over what it copied back)

Each is fitted by least squares on the relative error (every n weighs the same), over every
row of the machine's benchmark; the error is each row's model / measured - 1.  A row the
fit leaves far off is a stage the model does not describe (it says what to look for).

  scripts/gpu_cost_model.py [--raw docs/results/gpu/h100/raw]
"""
import argparse
import pathlib
import statistics

import gpu_results

CANDIDATES_AT_3500 = 96  # a box's candidates on one sweep axis at 3500 boxes (gpu/sap_sweep.h)
# cpusap's slabs of a second axis cut them so on the same streams: 96 -> 17 at 3500,
# 199 -> 25 at 10000 (docs/results/gpu_kernel_cost.md), the new design's cut for gpusap.
SECOND_AXIS_CUT = (96 / 17, 199 / 25)


def candidates(n: float) -> float:
    return CANDIDATES_AT_3500 * (n / 3500) ** (2 / 3) * n


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


def fit(rows: list) -> dict:
    """{(stage, who): coefficients}: `who` a finder or the finders sharing constants."""
    fitted = {}
    for stage, (column, shared, terms) in STAGES.items():
        for who in sorted({shared(r["algo"]) for r in rows}):
            used = [dict(r, y=r[column]) for r in rows if shared(r["algo"]) == who]
            fitted[(stage, who)] = solve(used, terms(used[0]["algo"]))
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
            errors.setdefault(stage, []).append((abs(error), row["algo"], row["n"]))
            lines.append(f"| {row['algo']} | {row['n']} | {stage} | {row[column]:.1f} | "
                         f"{predicted[stage]:.1f} | {error:+.0%} |")
    return lines, errors


def predictions(fitted: dict) -> list:
    """The designs of the GPU finders' next step, through the fitted model: each one's
    assumption is stated with it.  Predictions, to be measured."""
    lines = ["| design | n | upload | kernels | download | host | launch to finish |",
             "|---|---:|---:|---:|---:|---:|---:|"]

    def line(what, n, algo, to_device, from_device, calls, kernels=None, download=None):
        row = {"n": n, "algo": algo, "bytes_to_device": to_device,
               "bytes_from_device": from_device, "api_calls": calls, "host_entries_sorted": 0}
        stages = model(fitted, row)
        stages["kernels"] = stages["kernels"] if kernels is None else kernels
        stages["download"] = stages["download"] if download is None else download
        total = sum(stages[s] for s in ("upload", "kernels", "download", "host"))
        lines.append(f"| {what} | {n} | {stages['upload']:.0f} | {stages['kernels']:.0f} | "
                     f"{stages['download']:.0f} | {stages['host']:.0f} | **{total:.0f}** |")

    sap, bf = fitted[("kernels", "gpusap")], fitted[("kernels", "gpubf")]
    pinned = fitted[("upload", "gpubf, gpusap")]  # a pinned copy; PCIe is as fast both ways
    for n, to_device, from_device in ((3500, 112000, 65560), (30000, 960000, 140976),
                                      (1000000, 32000000, 7817808)):
        line("gpusap, the model as fitted (42-52 calls)", n, "gpusap", to_device, from_device,
             42 if n < 10**6 else 52)
        cut = min(SECOND_AXIS_CUT)
        sweep = sap[1] * n + sap[2] * candidates(n) / cut
        download = pinned[0] + pinned[1] * from_device
        line(f"gpusap, a second axis (candidates / {cut:.1f}), one graph launch, the changes "
             "in one pinned copy at the upload's rate (6 calls), the fitted fixed kernel time",
             n, "gpusap",
             to_device, from_device, 6, sap[0] + sweep, download)
        line("the same with no mid-frame round trip: fixed kernel time as gpubf's", n,
             "gpusap", to_device, from_device, 6, bf[0] + sweep, download)
    line("gpubf, the model as fitted (10 calls)", 3500, "gpubf", 112000, 65568, 10)
    line("gpubf, one graph launch (4 calls)", 3500, "gpubf", 112000, 65568, 4)
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--raw", type=pathlib.Path, default=gpu_results.MACHINES[0])
    raw = parser.parse_args().raw
    rows = stage_rows(raw)
    fitted = fit(rows)
    m = gpu_results.machine(raw)
    print(f"Fitted to {gpu_results.folder(raw.resolve())} ({m['gpu']}, commit "
          f"{m['git_commit'][:7]}): {len(rows)} rows of GPU finders.\n")
    print("| stage | constants shared by | fitted |\n|---|---|---|")
    names = {"upload": ["µs", "µs a byte"], "download": ["µs", "µs a byte"],
             "kernels gpubf": ["µs", "µs a word"], "kernels gpubf-paper": ["µs", "µs a pair"], "kernels gpubf-paper": ["µs", "µs a pair"],
             "kernels gpusap": ["µs", "µs a box", "µs a candidate"],
             "host gpubf, gpusap": ["µs", "µs a call", "µs a sorted entry"],
             "host gpubf-paper": ["µs", "µs a byte copied back"]}
    for (stage, who), coef in fitted.items():
        units = names.get(f"{stage} {who}", names.get(stage))
        print(f"| {stage} | {who} | " + " + ".join(f"{c:.4g} {u}" for c, u in zip(coef, units))
              + (f" ({1e-3 / coef[1]:.1f} GB/s)" if stage in ("upload", "download") else "")
              + " |")
    lines, errors = error_table(fitted, rows)
    print("\nThe model against every measured stage:\n\n" + "\n".join(lines) + "\n")
    print("Error, |model / measured - 1| over the rows: " + "; ".join(
        f"{stage} median {statistics.median(e for e, _, _ in errs):.0%}, largest "
        f"{max(errs)[0]:.0%} ({max(errs)[1]} at {max(errs)[2]})"
        for stage, errs in errors.items()) + ".\n")
    print("PREDICTIONS (not measurements), µs:\n\n" + "\n".join(predictions(fitted)))


if __name__ == "__main__":
    main()
