"""The study's collect, plot and report stages: the runs' results as CSV tables, the
figures drawn from them, and the generated blocks of the report.

OUT/REPORT.md is the generated report: every block under its title, tables,
figures, targets, with no narrative.  With --report the same blocks fill the
markers of the hand-written report (--report-doc, docs/REPORT.md by default:
scripts/study_document.py), whose prose is people's, and its figures and CSVs are
copied into the report/ folder beside it; its citations are then checked.

Rules, each with its reason:
  * Only what exists is read (study_results); a claim whose runs are missing has
    no verdict (study_targets), never a guess.
  * A report is of one machine, build and commit: runs from more than one leave the
    hand-written report as it was (a failure).  When the runs' commit is behind the
    code in the folders it measures, the header says so.
  * write_everything() returns the study's failures (a finder that missed exact pairs,
    a report that cannot stand, a citation that no longer matches): exit 1.
"""
import bisect
import collections
import json
import pathlib
import shutil
import subprocess

import study_claims
import study_document
import study_errors
import study_out_folder
import study_overlap
import study_physics
import study_plots
import study_results
import study_sweep
from overlap_runs import portable
from script_cli import shell_word, write_atomically
from study_tables import fmt, plain, table

REPO = pathlib.Path(__file__).resolve().parent.parent
# The folders whose code the study measures: a commit since the runs' that changes one of
# them may change a figure.
MEASURED = ("engine", "physics", "gpu", "audio_ai_stubs", "render", "CMakeLists.txt")
TITLES = {
    "header": None, "findings": "Findings",
    "sweep": "1. The sweep", "paper_claims": "1.1 The paper's claims, target by target",
    "stages": "1.2 Where the frame goes", "sweep_tables": "1.3 The sweep's tables",
    "timeline": "2. The async loop: one frame's timeline",
    "pairs": "3.1 Broadphase: pairs against the exact oracle (bf)",
    "physics": "3.2 Physics: substeps, CCD, sleep and the solver",
    "latency": "3.3 A broadphase one frame late",
    "solver_order": "3.2.1 The coloured solver against Bullet's serial solver",
    "overlap": "4. The asynchronous frame: where overlap pays",
    "overlap_ideal": "4.1 The frame against the ideal for its cores",
    "search_hidden": "4.2 The search beside the narrowphase",
    "runs": "Machine and runs"}
CSV_TABLES = ("pairs", "physics", "latency", "overlap", "overlap_ideal", "search_hidden",
              "solver_order")
# The coloured solver's comparison with Bullet's serial solver, over the study's physics
# cells: a measurement kept in docs/results/, read when it is there.
SOLVER_ORDER = REPO / "docs" / "results" / "solver_order_error.csv"


# --- the machine, the commit and the runs ---------------------------------------

def machines_of(jobs: list) -> list:
    """The machines the runs name, each field as plain text (study_tables.plain): the
    summaries may be another machine's."""
    found = {}
    for job in jobs:
        folder = getattr(job, "folder", None)
        if folder is not None and (folder / "summary.json").exists():
            m = json.loads((folder / "summary.json").read_text())["machine"]
            found.setdefault(json.dumps(m, sort_keys=True), {
                key: plain(value) if isinstance(value, str) else value
                for key, value in m.items()})
    return list(found.values())


def machine_text(m: dict) -> str:
    return (f"{m['cpu']}, {m['hardware_threads']} hardware threads; GPU: {m['gpu']}; "
            f"{m['compiler']}, {m['build_type']} build; commit {m['git_commit']}")


def short_machine_text(m: dict) -> str:
    gpu = "no GPU" if m["gpu"].startswith("none") else m["gpu"]
    return (f"{m['cpu']}, {m['hardware_threads']} hardware threads, {gpu}; {m['compiler']}, "
            f"{m['build_type']}; commit {m['git_commit']}")


def commits_since(commit: str) -> int:
    """How many commits since `commit` changed the measured folders (-1: not in history)."""
    result = subprocess.run(["git", "-C", str(REPO), "rev-list", "--count",
                             f"{commit.split('-')[0]}..HEAD", "--", *MEASURED],
                            capture_output=True, text=True)
    return int(result.stdout) if result.returncode == 0 else -1


def staleness_lines(machine: dict) -> list:
    if machine is None:
        return []
    commit = machine["git_commit"].split("-")[0]
    behind = commits_since(commit)
    if behind == 0:
        return ["The code the runs measured is HEAD's: no commit since theirs changed "
                f"{', '.join(MEASURED)}.", ""]
    if behind < 0:
        return [f"**The runs are of commit {commit}, which is not in this checkout's "
                "history**: the figures may not hold for its code.", ""]
    commits = "1 commit" if behind == 1 else f"{behind} commits"
    return [f"**The runs are behind the code**: {commits} since {commit} changed "
            f"the folders they measure (`git log --oneline {commit}..HEAD -- "
            f"{' '.join(MEASURED)}`); the figures are of {commit}, not of HEAD.", ""]


def profile_lines(args, cells: list) -> list:
    """Which profile the runs are, how many options it changes from the full study, and
    what the full sweep would cost at the per-frame times measured here."""
    reduced = [key for key, value in args.full_profile.items() if getattr(args, key) != value]
    if not reduced:
        return [f"Profile {args.profile}: the full study.", ""]
    full = args.full_profile
    hours = sum(c["total_mean"] for c in cells) * full["frames"] * full["repetitions"] / 3.6e6
    return [f"Profile {args.profile}: smaller than the full study in {len(reduced)} options "
            "(scripts/study_profiles.json; every option is in the command below)." +
            (f" The full sweep of these {len(cells)} cells alone would run "
             f"{hours:.1f} hours here." if cells else ""), ""]


def header_block(args, machine: dict, cells: list, seconds: float) -> list:
    took = [f"The runs took {seconds / 60:.1f} min in all (see *Machine and runs*).", ""] if seconds else []
    return profile_lines(args, cells) + took + staleness_lines(machine)


def invocations(args) -> list:
    return study_out_folder.read_log(args.out)


def shown_command(args, words) -> str:
    """A command line with paths relative to the repository and --out shown as $OUT, each
    word with a character no command line shows (a tab, a newline, a backtick, a byte not
    UTF-8: a path may hold any) in bash's $'...' quoting (script_cli.shell_word)."""
    def shown(word) -> str:
        word = portable(str(word), {args.out: "$OUT"})
        return "$OUT" + shell_word(word[4:]) if word.startswith("$OUT") else shell_word(word)
    return " ".join(map(shown, words))


def run_argv(argv: list) -> list:
    """An invocation's argv as the report shows it: its own --out as $OUT (it may be a
    folder of another machine), a binary outside this repository by its last two names
    (build/overlap), and no --report-doc (it names a file of the machine that ran it)."""
    own_out = argv[argv.index("--out") + 1] if "--out" in argv[:-1] else None
    shown, words = [], iter(argv)  # an iterator: a long argv costs its length, once
    for word in words:
        if word in ("--notes", "--report-doc"):
            next(words, None)
            continue
        if own_out and word.startswith(own_out):
            word = "$OUT" + word[len(own_out):]
        elif shown and shown[-1] in ("--overlap", "--emulation"):
            path = pathlib.Path(word)
            if path.is_absolute() and not path.is_relative_to(REPO):
                word = "/".join(path.parts[-2:])
        shown.append(word)
    return shown


def invocation_line(args, run: dict) -> str:
    load = run["load_average_at_start"]
    return (f"- `{shown_command(args, run_argv(run['argv']))}`, started {plain(run['started'])}, " + (
        f"its jobs took {run['seconds']:.0f} s" if run.get("finished", True) else
        "stopped before its end (its finished runs are used)") +
        f"; load average at its start {load}" +
        (" (other jobs were running)." if load >= 0.5 else " (a quiet machine)."))


class Meetings:
    """How many of a set of jobs' spans each span meets (o.start < j.end and j.start <
    o.end), by bisection on the sorted starts and ends: n log n for n spans, where trying
    every pair took minutes for a long log (every span of a repeated entry meets every
    other).  A span of no length met at its instant is counted as the pairs were."""

    def __init__(self, jobs: list):
        self.starts = sorted(job["start"] for job in jobs)
        self.ends = sorted(job["end"] for job in jobs)
        self.points = collections.Counter(job["start"] for job in jobs
                                          if job["start"] == job["end"])

    def met(self, job: dict) -> int:
        start, end = job["start"], job["end"]
        return (bisect.bisect_left(self.starts, end) - bisect.bisect_right(self.ends, start)
                + (self.points[start] if start == end else 0))


def beside_counts(spans: list) -> tuple:
    """({experiment: {other experiment: runs met}}, the groups whose runs met each other),
    counting only the runs of other invocations (shards)."""
    def meetings(key) -> dict:
        grouped = {}
        for index, job in spans:
            grouped.setdefault(key(index, job), []).append(job)
        return {name: Meetings(jobs) for name, jobs in grouped.items()}
    by_experiment = meetings(lambda index, job: job["experiment"])
    own_experiment = meetings(lambda index, job: (index, job["experiment"]))
    by_group = meetings(lambda index, job: job["group"])
    own_group = meetings(lambda index, job: (index, job["group"]))
    beside, clashes = {}, set()
    for index, job in spans:
        for other, all_of_it in by_experiment.items():
            own = own_experiment.get((index, other))
            met = all_of_it.met(job) - (own.met(job) if own else 0)
            if met > 0:
                counts = beside.setdefault(job["experiment"], {})
                counts[other] = counts.get(other, 0) + met
        if by_group[job["group"]].met(job) - own_group[(index, job["group"])].met(job) > 0:
            clashes.add(job["group"])
    return beside, clashes


def beside_lines(log: list) -> list:
    """What ran beside what: for each experiment, the other shards' runs that ran while its
    runs did, and whether any two runs compared with each other (one group) ran at once."""
    spans = [(index, job) for index, run in enumerate(log) for job in run.get("jobs", [])]
    if not spans:
        return []
    beside, clashes = beside_counts(spans)
    shards = len({index for index, _ in spans})
    lines = [f"What ran beside what: {len(spans)} runs in {shards} invocation(s) (shards)."
             + ("" if beside else " Every run ran alone."), ""]
    lines += [f"- {experiment}: other shards' runs beside its runs: " + ", ".join(
        f"{other} {n}" for other, n in sorted(counts.items())) + "."
        for experiment, counts in sorted(beside.items())] + ([""] if beside else [])
    return lines + ["Runs compared with each other (one group) " + (
        "never ran at once." if not clashes else "ran at once in " + ", ".join(sorted(clashes))
        + ": those comparisons hold each other's noise."), ""]


def command_lines(args, jobs: list) -> list:
    lines = [f"This report: `scripts/study.py {shown_command(args, args.argv)}`.", "",
             "One command per experiment (every command is in `commands.txt`):", "", "```"]
    seen = set()
    for job in jobs:
        if job.experiment not in seen:
            seen.add(job.experiment)
            lines += [shown_command(args, c) for c in job.commands()]
    return lines + ["```", ""]


def runs_block(args, jobs: list, machines: list) -> list:
    lines = [f"- {machine_text(m)}" for m in machines] + [""]
    lines += ["The runs came from ($OUT: the study's --out folder):", ""]
    lines += [invocation_line(args, run) for run in invocations(args)] + [""]
    return lines + beside_lines(invocations(args)) + command_lines(args, jobs)


# --- the timeline --------------------------------------------------------------

def timeline_block(args, jobs: list, figures: dict) -> list:
    job = next((j for j in jobs if j.experiment == "timeline"), None)
    if job is None or not job.done():
        return ["No timeline run yet.", ""]
    frame, algo, spans = study_results.timeline_frame(job.folder)
    study_plots.timeline(frame, algo, spans, figures["folder"])
    study_results.write_csv(figures["folder"] / "fig_timeline.csv",
                            [{"lane": lane, "span": name, "start_ms": start, "ms": duration}
                             for lane, name, start, duration in spans])
    totals = {}
    for lane, name, _, duration in spans:
        totals[(lane, name)] = totals.get((lane, name), 0.0) + duration
    return ([f"Scene 4, {args.timeline_objects} boxes, sound and AI tasks on, broadphase {algo}"
             + ("" if algo == "gpubf" else " (gpubf asked; no GPU here: its CPU fallback)")
             + f". Frame {frame}, the median-length frame; each span summed over the frame:",
             ""] + table(["lane", "span", "ms in the frame"],
                         [[lane, name, fmt(ms)] for (lane, name), ms in sorted(totals.items())])
            + ["![timeline](report/fig_timeline.png)", ""])


# --- the whole report ----------------------------------------------------------

def collect(jobs: list) -> dict:
    runs = study_results.sweep_runs(jobs)
    cells = study_results.aggregate_sweep(runs)
    return {"runs": runs, "cells": cells, "stages": study_results.stage_rows(cells),
            "pairs": study_results.pair_errors(jobs),
            "physics": study_results.physics_runs(jobs),
            "latency": study_results.latency_rows(jobs),
            "overlap": study_overlap.overlap_rows(jobs),
            "overlap_ideal": study_overlap.ideal_rows(jobs),
            "search_hidden": study_overlap.hidden_rows(cells)}


def run_seconds(args) -> float:
    return sum(run.get("seconds") or 0 for run in invocations(args))


def blocks_of(args, jobs: list, data: dict, machine: dict, figures: dict) -> tuple:
    """({block name: lines}, failures): every generated block, figures drawn as it goes."""
    d = data
    targets = study_claims.sections_targets(d["cells"], d["stages"], d["pairs"], d["physics"],
                                            d["overlap"], d["overlap_ideal"], fmt)
    commit = short_machine_text(machine) if machine else "no run yet"
    pairs, failures = study_errors.pairs_block(d["pairs"], d["cells"], args.pairs_objects,
                                               figures)
    blocks = {
        "header": header_block(args, machine, d["cells"], run_seconds(args)),
        "findings": study_claims.findings_lines(
            targets, machine, commit, table,
            {"sweep": study_claims.runs_a_cell(d["cells"]),
             "overlap": study_claims.runs_a_cell(d["overlap"]),
             "ideal": study_claims.runs_a_cell(d["overlap_ideal"])}),
        "sweep": study_sweep.sweep_block(args, d["runs"], d["cells"], jobs, d["pairs"],
                                         figures),
        "paper_claims": study_sweep.claims_block(targets, d["cells"]),
        "stages": study_sweep.stages_block(d["stages"], d["cells"], targets, figures),
        "sweep_tables": study_sweep.tables_block(d["cells"]),
        "timeline": timeline_block(args, jobs, figures),
        "pairs": pairs,
        "physics": study_physics.physics_section(d["physics"], figures, fmt, table,
                                                 args.physics_objects, args.seed),
        "solver_order": d["solver_order_lines"],
        "latency": study_errors.latency_block(d["latency"], figures, d["cells"]),
        "overlap": study_overlap.overlap_section(d["overlap"], figures, fmt, table),
        "overlap_ideal": study_overlap.ideal_section(d["overlap_ideal"], fmt, table),
        "search_hidden": study_overlap.hidden_section(d["search_hidden"], fmt, table)}
    blocks["runs"] = runs_block(args, jobs, machines_of(jobs))
    return blocks, failures


def generated_report(args, blocks: dict) -> str:
    lines = [f"# Overlap: the study (profile {args.profile})", "",
             "The generated tables and figures alone; docs/REPORT.md is the report written "
             "around them (`scripts/study.py --report` fills its blocks).", ""]
    for name, content in blocks.items():
        lines += ([f"## {TITLES[name]}", ""] if TITLES[name] else []) + content
    return "\n".join(lines) + "\n"


def publish(args, blocks: dict, figures: dict) -> list:
    """Fills the hand-written report's blocks and copies the figures and CSVs beside it;
    returns its problems (markers that name no block, citations that do not match)."""
    doc = args.report_doc
    text, problems = study_document.fill(doc.read_text(), blocks)
    if problems:
        return [f"{doc}: {p}; {doc} left as it was" for p in problems]
    beside = doc.parent / "report"
    beside.mkdir(parents=True, exist_ok=True)
    made = {path.name for path in figures["folder"].iterdir()}
    for stale in beside.iterdir():  # a figure or table this study no longer makes
        if stale.name not in made and stale.suffix in (".png", ".svg", ".csv"):
            stale.unlink()
    for path in sorted(figures["folder"].iterdir()):
        shutil.copy(path, beside / path.name)
    write_atomically(doc, text)
    return study_document.check(doc)


def write_everything(args, jobs: list) -> list:
    """Writes the CSVs, figures and OUT/REPORT.md, and with --report the hand-written
    report's blocks; returns the study's failures."""
    figures = {"folder": args.out / "report"}
    figures["folder"].mkdir(parents=True, exist_ok=True)
    data = collect(jobs)
    data["solver_order_lines"], data["solver_order"] = study_physics.solver_order_section(
        SOLVER_ORDER, fmt, table, str(SOLVER_ORDER.relative_to(REPO)))
    machines = machines_of(jobs)
    blocking = ([] if len(machines) <= 1 else
                [f"the runs come from {len(machines)} machines, builds or commits; a report "
                 "is of one (rerun the others into a fresh --out)"])
    for name in CSV_TABLES:
        study_results.write_csv(figures["folder"] / f"{name}.csv", data[name])
    blocks, failures = blocks_of(args, jobs, data, machines[0] if machines else None, figures)
    write_atomically(args.out / "REPORT.md", generated_report(args, blocks))
    if args.report and not blocking:
        failures += publish(args, blocks, figures)
    return blocking + failures
