#!/usr/bin/python3
"""The GPU machine's figures, read from the raw files kept in docs/results/gpu/raw/.

The tables of docs/results/gpu/README.md are this script's output (run it and
paste; every figure comes from a raw file, none is typed), and the study's
claims table cites the same figures through claim_figures() while the study's
own runs have no GPU.  The files are what the GPU machine wrote:

  probe_*.log        the finder alone, launch() + finish(), per (stream, finder)
  bench_*.csv        overlap_bench_broadphase: update + findPairs with Bullet's pair cache
  */summary.json     overlap run; */timeline.json.gz its spans (Perfetto)

  scripts/gpu_results.py [--raw docs/results/gpu/raw]
"""
import argparse
import csv
import gzip
import json
import pathlib
import statistics

REPO = pathlib.Path(__file__).resolve().parent.parent
RAW = REPO / "docs" / "results" / "gpu" / "raw"
FOLDER = "docs/results/gpu/"
FINDERS = ("cpubf", "cpusap", "gpubf", "gpubf-paper")
BENCH_ALGOS = ("sap", "bvh", "cpubf", "cpusap", "gpubf", "gpubf-paper")
FRAME_RUNS = (("demo", "demo (`overlap run`, 1000 boxes)"),
              ("async_gpubf", "3500 boxes, task load 1, `--compare-sync`"),
              ("async_cpusap", "3500 boxes, task load 1, `--compare-sync`"))


def commented_csv(path: pathlib.Path) -> list:
    """A CSV whose first lines may be '#' comments, as rows of strings."""
    lines = [line for line in path.read_text().splitlines() if not line.startswith("#")]
    return list(csv.DictReader(lines))


def machine(raw: pathlib.Path = RAW) -> dict:
    """The GPU machine as its benchmark recorded it (GPU, CPU, threads, commit)."""
    return json.loads((raw / "bench_paper.json").read_text())["machine"]


def finder_rows(raw: pathlib.Path = RAW) -> list:
    return [row for path in sorted(raw.glob("probe_*.log")) for row in commented_csv(path)]


def bench_rows(raw: pathlib.Path = RAW) -> list:
    return [row for name in ("bench_paper.csv", "bench_big.csv")
            for row in commented_csv(raw / name)]


def bench_median_us(raw: pathlib.Path = RAW) -> dict:
    """{(n, algorithm): median µs per frame} of the benchmark."""
    return {(int(r["n"]), r["algorithm"]): float(r["median_us"]) for r in bench_rows(raw)}


def frame_summary(run: str, raw: pathlib.Path = RAW) -> dict:
    return json.loads((raw / run / "summary.json").read_text())


def search_span_us(run: str, raw: pathlib.Path = RAW):
    """The median of the timeline's search spans (one per substep), µs; None without a trace."""
    path = raw / run / "timeline.json.gz"
    if not path.exists():
        return None
    trace = json.loads(gzip.decompress(path.read_bytes()))
    events = trace["traceEvents"] if isinstance(trace, dict) else trace
    return statistics.median(e["dur"] for e in events
                             if e.get("ph") == "X" and e["name"] == "search")


def cell(value) -> str:
    return "-" if value is None else f"{value:.0f}"


def table(headers: list, rows: list) -> list:
    return (["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
            + ["| " + " | ".join(map(str, row)) + " |" for row in rows])


def finder_table(raw: pathlib.Path = RAW) -> list:
    rows = finder_rows(raw)
    by = {(int(r["n"]), r["algo"]): r for r in rows}
    sizes = sorted({n for n, _ in by})
    lines = []
    for n in sizes:
        line = [n]
        for algo in FINDERS:
            row = by.get((n, algo))
            line.append(cell(float(row["host_med_us"]) if row else None))
            if algo.startswith("gpubf"):
                line.append(cell(float(row["search_med_us"]) if row else None))
        line.append(", ".join(sorted({r["exact_vs_ref"] for r in rows if int(r["n"]) == n})))
        lines.append(line)
    return table(["n", "cpubf", "cpusap", "gpubf", "gpubf events", "gpubf-paper",
                  "gpubf-paper events", "pairs against the reference"], lines)


def bench_table(raw: pathlib.Path = RAW) -> list:
    median = bench_median_us(raw)
    sizes = sorted({n for n, _ in median})
    return table(["n", *BENCH_ALGOS], [[n, *(cell(median.get((n, a))) for a in BENCH_ALGOS)]
                                       for n in sizes])


def frame_table(raw: pathlib.Path = RAW) -> list:
    rows = []
    for run, what in FRAME_RUNS:
        summary = frame_summary(run, raw)
        timings = summary["timings_ms"]
        median = {k: timings[f"{k}_ms"]["median"] for k in (
            "total", "physics", "narrowphase", "solver", "ccd_query", "broadphase", "search")}
        compare = summary.get("compare_sync")
        span = search_span_us(run, raw)
        rows.append([what, summary["parameters"]["algorithm"], f"{median['total']:.1f}",
                     f"{median['physics']:.1f}", f"{median['narrowphase']:.1f}",
                     f"{median['solver']:.1f}", f"{median['ccd_query']:.1f}",
                     f"{median['broadphase']:.2f}", f"{median['search']:.2f}", cell(span),
                     f"{compare['speedup']:.2f}" + (" (same state)" if compare["identical_state"]
                                                    else " (states differ)")
                     if compare else "-", summary["state_hash"]])
    return table(["run", "algo", "frame", "physics", "narrowphase", "solver", "CCD queries",
                  "broadphase", "search", "search span (us)", "sync/async speed-up",
                  "state hash"], rows)


def machine_name(raw: pathlib.Path = RAW) -> str:
    """"H200" from "NVIDIA H200 (sm_90, 132 SMs)"."""
    return machine(raw)["gpu"].split(" (")[0].removeprefix("NVIDIA ")


def measured_elsewhere(raw: pathlib.Path = RAW) -> str:
    """Where the GPU finders' figures measured outside the study are, for the report; empty
    when the raw files are absent."""
    if not (raw / "bench_paper.json").exists():
        return ""
    return (f"the {machine_name(raw)} machine's, measured outside the study at commit "
            f"{machine(raw)['git_commit'][:7]}, are in {FOLDER}")


def ratio_range(median: dict, algo: str, other: str, sizes: list) -> tuple:
    ratios = [median[(n, algo)] / median[(n, other)] for n in sizes
              if (n, algo) in median and (n, other) in median]
    return (min(ratios), max(ratios)) if ratios else None


def claim_figures(near: float, raw: pathlib.Path = RAW) -> dict:
    """The GPU machine's figures for the paper's claims, as the claims table cites them:
    {claim number: (figure, verdict)}; empty when the raw files are absent.  Only its
    benchmark's sizes of the paper (500-3500 boxes, generated scene-4 streams) count."""
    if not (raw / "bench_paper.csv").exists():
        return {}
    gpu = machine_name(raw)
    where = (f"The {gpu} machine's figures (commit {machine(raw)['git_commit'][:7]}, {FOLDER}; "
             "not this report's runs)")
    median = {k: v for k, v in bench_median_us(raw).items() if k[0] <= 3500}
    sizes = sorted({n for n, _ in median})
    span = f"{sizes[0]}-{sizes[-1]} boxes"
    figures = {1: (f"{where}: bf is not in its benchmark", f"{gpu} machine: not measured")}
    near_text, verdicts = [], []
    for algo in ("gpubf-paper", "gpubf"):
        ranges = [(o, ratio_range(median, algo, o, sizes)) for o in ("sap", "bvh")]
        near_text.append(f"{algo} " + ", ".join(f"x{lo:.2f}-x{hi:.2f} of {o}'s"
                                                 for o, (lo, hi) in ranges))
        verdicts.append(f"{algo} " + ("holds" if all(hi <= near for _, (_, hi) in ranges)
                                      else "does not hold"))
    figures[2] = (f"{where}, broadphase alone (update + pairs with Bullet's pair cache, not the "
                  f"whole frame) at {span}: " + "; ".join(near_text),
                  f"{gpu} machine, broadphase alone: " + ", ".join(verdicts))
    largest = [(a, median[(sizes[-1], a)]) for a in BENCH_ALGOS if (sizes[-1], a) in median]
    largest.sort(key=lambda pair: pair[1])
    frames = sorted(((frame_summary(run, raw)["parameters"]["algorithm"],
                      frame_summary(run, raw)["timings_ms"]["total_ms"]["median"])
                     for run, _ in FRAME_RUNS[1:]), key=lambda pair: pair[1])
    figures[3] = (f"{where}: at {sizes[-1]} boxes the fastest broadphase is {largest[0][0]} "
                  f"({largest[0][1]:.0f} µs; next {largest[1][0]} {largest[1][1]:.0f}); whole "
                  f"frame (median; only these two run there): " + ", ".join(f"{a} {ms:.0f} ms"
                                                               for a, ms in frames),
                  f"{gpu} machine: fastest broadphase {largest[0][0]}, fastest whole frame "
                  f"{frames[0][0]}")
    return figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--raw", type=pathlib.Path, default=RAW)
    raw = parser.parse_args().raw
    m = machine(raw)
    print(f"Machine: {m['gpu']}; {m['cpu']}, {m['hardware_threads']} hardware threads; "
          f"{m['compiler']}, {m['build_type']}, commit {m['git_commit']}.\n")
    for title, lines in (("The finder alone", finder_table(raw)),
                         ("The benchmark", bench_table(raw)), ("The frame", frame_table(raw))):
        print(f"{title}:\n\n" + "\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
