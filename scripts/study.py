#!/usr/bin/python3
"""The study: the paper's sweep redone and extended, with figures and a report.

plan -> run -> collect -> plot -> report.  The plan lists every job of the
experiments the study plans (scripts/study_plan.py); the runs go one
`overlap` process after another (never two at once, so runs do not compete
for cores), each into its own folder under --out; then the results are
collected into CSV files (scripts/study_results.py), drawn
(scripts/study_plots.py) and written as tables into OUT/REPORT.md
(scripts/study_report.py), which ends the study and is named on its last line:

  sweep     4 scenes x algorithms x n x repetitions, `overlap run --no-tasks`,
            the same seed every repetition
  pairs     a recorded scene-4 stream through `overlap pairs` for every
            algorithm, compared with bf's exact pairs: missed pairs must be 0
  physics   fixed K x --ccd off|auto|all and --substeps auto x --ccd off|auto,
            every scene, against escapes, sinking, penetration and energy drift
  latency   `overlap latency`: a broadphase one frame late on grown AABBs
  timeline  one run with the sound and AI tasks, for the async loop's timeline
  overlap   the async frame against --sync (`overlap run --compare-sync`)

The options come from a named profile of scripts/study_profiles.json
(--profile NAME; --quick is --profile quick); any option given here wins.  The
full profile, tens of hours on 2 cores, prints its estimate and runs only with
--full (or a yes on a terminal).  A run whose result exists is not redone
(resumable), and --shard i/k runs only the i-th of k shares of the stable job
list, so k machines (scripts/study_slurm.sh: a Slurm array) or k processes
(GNU parallel) share the work on one --out folder (docs/STUDY.md).  The runs
need only Python's standard library (--runs-only); the report is made from the
runs on any machine with matplotlib (--no-runs, or --from-archive with a GPU
machine's archive).  Without a CUDA device the GPU algorithms' timing runs are
left for a GPU machine, and their pairs run through the CUDA emulation build
(--emulation) when it is built: checked pair for pair, never timed.  --report
also fills the generated blocks of the hand-written docs/REPORT.md.

  scripts/study.py --quick --out /tmp/study_quick          # minutes, small version
  scripts/study.py --full --out out/study --shard 1/2      # half of the full study
  scripts/study.py --profile gpu --out out/study --no-runs --report  # docs/REPORT.md
  scripts/study.py --from-archive gpu_check.tar.xz --out out/gpu-study  # its report

matplotlib: run with /usr/bin/python3 (Debian's python3-matplotlib).
"""
import os
import sys

try:  # a memory limit (ulimit -v) can stop the imports: one line and exit 1, no traceback
    import argparse
    import collections
    import csv
    import pathlib
    import re
    import signal
    import tempfile
    import time

    import broadphases
    from overlap_runs import run_summary
    import study_plan
    import study_profiles
    import study_report
    import study_archive
    from script_cli import (STOPS, BadInput, Parser, Stopped, one_line, run as run_script,
                            shell_word)
    from study_out_folder import (InvocationLog, foreign_folder_problem, locked, read_log,
                                  unmakable_problem, write_atomically)

    REPO = pathlib.Path(__file__).resolve().parent.parent
    PROFILES = study_profiles.load()
except MemoryError:
    os.write(2, b"study: out of memory while starting (a memory limit, ulimit -v?)\n")
    sys.exit(1)

HELP = {
    "scenes": "sweep: scenes", "algos": "sweep: broadphases", "objects": "sweep: box counts",
    "repetitions": "sweep: runs of each (scene, algo, n), same seed",
    "frames": "sweep: frames per run", "figure_objects": "Figures 2-5: n (the nearest one run)",
    "pairs_objects": "pairs: boxes in the scene-4 stream", "pairs_frames": "pairs: frames recorded",
    "pairs_algos": "pairs: broadphases compared with bf", "physics_scenes": "physics: scenes",
    "physics_objects": "physics: boxes", "physics_frames": "physics: frames per run",
    "physics_substeps": "physics: fixed substeps K and/or auto",
    "physics_ccd": "physics: --ccd modes (auto substeps: never all)",
    "physics_algo": "physics: broadphase",
    "physics_seeds": "physics: more seeds for the comparison cells (auto against the old K)",
    "physics_compare_objects": "physics: more box counts for the comparison cells",
    "physics_compare_frames": "physics: frames per run at --physics-compare-objects",
    "latency_scenes": "latency: scenes",
    "latency_objects": "latency: boxes", "latency_frames": "latency: frames per run",
    "latency_algos": "latency: broadphases, one process each",
    "latency_growths": "latency: growth factors of the late AABBs (x |v| dt)",
    "timeline_objects": "timeline: boxes (scene 4)", "timeline_frames": "timeline: frames",
    "overlap_scenes": "overlap: scenes", "overlap_objects": "overlap: box counts",
    "overlap_loads": "overlap: --task-load values (tasks' cost / the physics step)",
    "overlap_frames": "overlap: frames per run (each run is a sync and an async run)",
    "overlap_algo": "overlap: broadphase (gpubf runs cpusap without a GPU, and says so)",
    "overlap_repetitions": "overlap: processes per point (the speed-up's spread between them)",
    "ideal_scenes": "overlap, the frame against the ideal for its cores: scenes",
    "ideal_objects": "overlap, against the ideal: box counts",
    "ideal_loads": "overlap, against the ideal: --task-load values",
    "ideal_threads": "overlap, against the ideal: --threads values, one run each",
    "ideal_frames": "overlap, against the ideal: frames per run (an async run alone)",
    "ideal_repetitions": "overlap, against the ideal: processes per point",
}


def gpu_present(overlap: str) -> tuple:
    """(whether gpubf runs on a GPU here, the machine's GPU line), from a one-frame run in
    a folder of this process's own (every shard, on every machine, probes for itself)."""
    with tempfile.TemporaryDirectory(prefix="overlap_gpu_probe.") as probe:
        summary = run_summary(overlap, pathlib.Path(probe),
                              ["--scene", "1", "--algo", "gpubf", "--objects", "8",
                               "--frames", "1", "--no-tasks"])
    return summary["parameters"]["algorithm"] == "gpubf", summary["machine"]["gpu"]


def format_seconds(seconds: float) -> str:
    seconds = int(seconds)
    if seconds >= 3600:
        return f"{seconds // 3600}h{seconds % 3600 // 60:02d}m"
    return f"{seconds // 60}m{seconds % 60:02d}s" if seconds >= 60 else f"{seconds}s"




def emulate_exactness(exactness: list, args) -> bool:
    """Runs these GPU pairs jobs through the CUDA emulation build when it is built."""
    if not (exactness and os.access(args.emulation, os.X_OK)):
        return False
    emulated, device = gpu_present(args.emulation)
    if not (emulated and "emulation" in device):
        return False
    for job in exactness:
        job.use_emulation(args.emulation, device)
    print(f"study: {', '.join(j.algo for j in exactness)}: pairs through {device} "
          f"({args.emulation}), checked, not timed", file=sys.stderr)
    return True


def without_a_gpu(pending: list, args) -> tuple:
    """On a machine whose `overlap` has no CUDA device: (the jobs to run, the GPU jobs left
    for a GPU machine).  The GPU algorithms' pairs run through the CUDA emulation build when
    it is built; their timings would be the CPU fallback's and are left."""
    gpu_jobs = [job for job in pending if job.gpu_algo]
    runnable = [job for job in pending if not job.gpu_algo]
    exactness = [job for job in gpu_jobs if isinstance(job, study_plan.PairsJob)]
    if emulate_exactness(exactness, args):
        runnable += exactness
    return runnable, [job for job in gpu_jobs if job not in runnable]


def pending_jobs(jobs: list, args) -> tuple:
    """(this shard's jobs, those of them to run here, the GPU jobs left for a GPU machine)."""
    shard, shards = args.shard
    mine = study_plan.shard_share(jobs, shard, shards)
    pending = [job for job in mine if not job.done()]
    gpu_pending = []
    if any(job.gpu_algo for job in pending):
        present, gpu = gpu_present(args.overlap)
        if not present:
            pending, gpu_pending = without_a_gpu(pending, args)
            print(f"study: no CUDA device ({gpu}); {len(gpu_pending)} GPU jobs left for a "
                  "machine with one", file=sys.stderr)
    estimate = format_seconds(study_profiles.estimate_seconds(PROFILES, pending))
    print(f"study: shard {shard}/{shards}: {len(mine)} of {len(jobs)} jobs, "
          f"{len(mine) - len(pending) - len(gpu_pending)} already done, {len(pending)} to run"
          + (f", about {estimate} on a 2-core machine" if pending else ""), file=sys.stderr)
    return pending, gpu_pending, estimate


def run_jobs(jobs: list, args, on_start, on_job) -> tuple:
    """Runs this shard's pending jobs one after another, calling on_start() first when
    there is any and on_job(job, start, end) (wall-clock seconds) after each; returns (the
    jobs run, the GPU jobs left pending).  A profile that asks first stops here (exit 2)
    unless --full or a yes on a terminal confirms its estimate."""
    pending, gpu_pending, estimate = pending_jobs(jobs, args)
    if pending and args.confirm and not study_profiles.confirmed(
            args.profile, f"{len(pending)} jobs, about {estimate} on a 2-core machine"):
        sys.exit(2)
    if pending:
        on_start()
    total_weight = sum(job.weight for job in pending)
    done_weight, started = 0, time.monotonic()
    for index, job in enumerate(pending):
        job_started, wall_started = time.monotonic(), time.time()
        job.run()
        on_job(job, wall_started, time.time())
        done_weight += job.weight
        elapsed = time.monotonic() - started
        left = elapsed / done_weight * (total_weight - done_weight)
        print(f"[{index + 1}/{len(pending)}] {job.experiment} {job.key}: "
              f"{time.monotonic() - job_started:.1f} s; elapsed {format_seconds(elapsed)}, "
              f"about {format_seconds(left)} left", file=sys.stderr)
    return pending, gpu_pending


def parse_shard(text: str) -> tuple:
    """i/k, 1 <= i <= k; k may exceed the jobs (shards past them get none), and costs
    nothing per shard."""
    match = re.fullmatch(r"([0-9]{1,12})/([0-9]{1,12})", text)
    if not match:
        raise argparse.ArgumentTypeError(f"{one_line(text)}: expected i/k, e.g. 1/4")
    shard, shards = int(match[1]), int(match[2])
    if not 1 <= shard <= shards:
        raise argparse.ArgumentTypeError(f"{text}: i must be in 1..k")
    return shard, shards


# overlap's own bounds (`overlap run --help`): a value it would refuse is refused here,
# before anything is planned, run or written; the counts only the study has (repetitions)
# are bounded too, so a typo never plans billions of jobs.
MAX_OBJECTS = 10_000_000  # overlap's --objects: 1..10000000
MAX_FRAMES = 1_000_000  # overlap's --frames: 1..1000000
MAX_REPETITIONS = 1000  # the study's own: processes per point
MAX_THREADS = 1024  # overlap's --threads: 0..1024
MAX_SUBSTEPS = 1000  # overlap's --substeps K: 1..1000
MAX_TASK_LOAD = 100  # overlap's --task-load: [0, 100]
MAX_SEED = 2 ** 64 - 1  # overlap's --seed: 0..2^64-1
# The plan's own bounds: values in one list option, and jobs in the whole plan (the product
# of the lists' lengths and the repetitions, counted before any job is made: a plan too
# large to hold is refused, never built).  The full profile plans 1148 jobs.
MAX_LIST_ITEMS = 1000
MAX_JOBS = 100_000
# A whole number as overlap reads one: plain decimal digits, no sign, no leading zero, no
# '_' and no space (Python's int() takes `1_000`, ` 5` and `05`; overlap refuses them).
WHOLE = re.compile(r"0|[1-9][0-9]{0,19}")
DECIMAL = re.compile(r"(0|[1-9][0-9]{0,8})(\.[0-9]{1,9})?")


def whole(text: str) -> int:
    """argparse type: a whole number spelled as overlap takes it (bounds: check_values)."""
    if not WHOLE.fullmatch(text):
        raise argparse.ArgumentTypeError(
            f"{one_line(repr(text))}: expected a whole number in plain digits (no sign, "
            "leading zero, '_' or space)")
    return int(text)


def int_bounds(key: str) -> tuple:
    """(low, high) of a whole-number option of the profiles, by what it counts."""
    if key.endswith("objects"):
        return 1, MAX_OBJECTS
    if key.endswith("frames"):
        return 1, MAX_FRAMES
    if key.endswith("repetitions"):
        return 1, MAX_REPETITIONS
    raise KeyError(f"no bound for the profiles' option {key}: add one to int_bounds")


def listed(text: str, item, low: float, high: float = None, empty: bool = False,
           also: tuple = ()) -> bool:
    """Whether `text` is comma-separated `item`s (int or float) in [low, high], or words
    of `also`; empty only when allowed."""
    words = [w for w in text.split(",") if w]
    if not words and not empty or len(words) != text.count(",") + 1 and words:
        return False
    for word in words:
        if word in also:
            continue
        if not (WHOLE if item is int else DECIMAL).fullmatch(word):
            return False
        if not low <= item(word) <= (high if high is not None else float("inf")):
            return False
    return True


# What each run option must hold (the algorithms are checked against overlap's catalogue
# once it is read): bad values are refused here, before anything runs or is written.
SCENES = (lambda t: listed(t, int, 1, 4), "scene numbers 1-4, comma-separated")
COUNTS = (lambda t: listed(t, int, 1, MAX_OBJECTS),
          f"box counts 1-{MAX_OBJECTS}, comma-separated")
LOADS = (lambda t: listed(t, float, 0, MAX_TASK_LOAD),
         f"--task-load values 0-{MAX_TASK_LOAD}, comma-separated")
VALUE_CHECKS = {
    "scenes": SCENES, "physics_scenes": SCENES, "latency_scenes": SCENES,
    "overlap_scenes": SCENES, "objects": COUNTS, "overlap_objects": COUNTS,
    "ideal_scenes": SCENES, "ideal_objects": COUNTS,
    "ideal_threads": (lambda t: listed(t, int, 1, MAX_THREADS),
                      f"thread counts 1-{MAX_THREADS}, comma-separated"),
    "ideal_loads": LOADS,
    "physics_compare_objects": (lambda t: listed(t, int, 1, MAX_OBJECTS, empty=True),
                                f"box counts 1-{MAX_OBJECTS}, comma-separated, or nothing"),
    "physics_seeds": (lambda t: listed(t, int, 0, MAX_SEED, empty=True),
                      f"seeds 0-{MAX_SEED}, comma-separated, or nothing"),
    "physics_substeps": (lambda t: listed(t, int, 1, MAX_SUBSTEPS, also=("auto",)),
                         f"substep counts 1-{MAX_SUBSTEPS} and/or auto, comma-separated"),
    "physics_ccd": (lambda t: all(w in ("off", "auto", "all") for w in t.split(",")),
                    "off, auto and/or all, comma-separated"),
    "latency_growths": (lambda t: listed(t, float, 0), "numbers from 0, comma-separated"),
    "overlap_loads": LOADS,
    "capture_keyframes": (lambda t: listed(t, int, 0, MAX_FRAMES - 1),
                          f"frame numbers 0-{MAX_FRAMES - 1}, comma-separated"),
    "threads": (lambda n: 0 <= n <= MAX_THREADS, f"0 (every hardware thread) to {MAX_THREADS}"),
    "seed": (lambda n: 0 <= n <= MAX_SEED, f"a whole number 0-{MAX_SEED}"),
    "capture_objects": (lambda n: 1 <= n <= MAX_OBJECTS, f"a box count 1-{MAX_OBJECTS}"),
    "experiments": (lambda t: all(w in study_plan.EXPERIMENTS for w in t.split(",")),
                    f"one or more of {','.join(study_plan.EXPERIMENTS)}, comma-separated"),
}
ALGO_LISTS = ("algos", "pairs_algos", "latency_algos", "physics_algo", "overlap_algo")


def given_twice(text: str):
    """The first item of a comma-separated list that repeats one before it (numbers by
    value: 1 and 1.0 are one), or None."""
    seen = set()
    for word in text.split(","):
        try:
            key = float(word)
        except ValueError:
            key = word
        if key in seen:
            return word
        seen.add(key)
    return None


def check_values(args, parser: argparse.ArgumentParser) -> None:
    full = study_profiles.options(PROFILES, "full")
    for key in [*VALUE_CHECKS, *ALGO_LISTS]:  # first: what follows reads every value
        value = getattr(args, key)
        if isinstance(value, str) and value.count(",") >= MAX_LIST_ITEMS:
            parser.error(f"--{key.replace('_', '-')}: {value.count(',') + 1} values; at most "
                         f"{MAX_LIST_ITEMS} in a list")
    for key in [*VALUE_CHECKS, *(k for k, v in full.items() if type(v) is int)]:
        if key in VALUE_CHECKS:
            holds, must = VALUE_CHECKS[key]
        else:
            low, high = int_bounds(key)
            holds, must = (lambda n, lo=low, hi=high: lo <= n <= hi), f"{low}-{high}"
        if not holds(getattr(args, key)):
            parser.error(f"--{key.replace('_', '-')} {one_line(repr(getattr(args, key)))}: "
                         f"expected {must}")
    for key in [*VALUE_CHECKS, *ALGO_LISTS]:  # a list item twice would run its jobs twice
        value = getattr(args, key)
        if isinstance(value, str) and (twice := given_twice(value)) is not None:
            parser.error(f"--{key.replace('_', '-')} {one_line(value)}: {one_line(twice)} is "
                         "given twice; name each once")
    if args.report and not args.report_doc.is_file():
        parser.error(f"--report-doc {args.report_doc}: no such file (--report fills its "
                     "generated blocks)")


def check_plan_size(args, parser: argparse.ArgumentParser) -> None:
    """At most MAX_JOBS jobs, counted before the plan is made (--check-only included)."""
    sizes = study_plan.plan_sizes(args)
    total = sum(sizes.values())
    if total > MAX_JOBS:
        largest = max(sizes, key=sizes.get)
        parser.error(f"the options plan {total} jobs ({largest}: {sizes[largest]}), over the "
                     f"{MAX_JOBS} a study takes (the full profile plans 1148): fewer list "
                     "values or repetitions")


def check_algorithms(args) -> None:
    """Every algorithm named is one of overlap's (after broadphases.load)."""
    known = broadphases.names()
    for key in ALGO_LISTS:
        value = getattr(args, key)
        if not value:
            raise BadInput(f"--{key.replace('_', '-')} '': names no broadphase; name one or "
                           f"more of {args.overlap}'s ({', '.join(known)})")
        unknown = [a for a in value.split(",") if a not in known]
        if unknown:
            raise BadInput(f"--{key.replace('_', '-')} {one_line(value)}: "
                           f"{one_line(','.join(repr(a) for a in unknown))} "
                           f"is not a broadphase of {args.overlap} ({', '.join(known)})")


def add_run_options(parser: argparse.ArgumentParser) -> None:
    """One option per profile key, its default the profile's (None here: filled after)."""
    full, quick = (study_profiles.options(PROFILES, name) for name in ("full", "quick"))
    for key, value in full.items():
        counted = type(value) is int
        bounds = "; %d-%d" % int_bounds(key) if counted else ""
        parser.add_argument("--" + key.replace("_", "-"), type=whole if counted else str,
                            default=None,
                            help=f"{HELP[key]} (full: {value}; quick: {quick[key]}{bounds})")


def apply_profile(args, parser: argparse.ArgumentParser) -> None:
    """The profile's values for every option not given; --quick and --full name theirs."""
    asked = [name for name, given in (("quick", args.quick), ("full", args.full)) if given]
    if len(set(asked) | {args.profile} - {None}) > 1:
        named = ([f"--profile {args.profile}"] if args.profile else []) + [f"--{n}" for n in asked]
        parser.error(f"{' and '.join(named)} name different profiles")
    args.profile = args.profile or (asked[0] if asked else "full")
    args.quick = args.profile == "quick"
    args.confirm = study_profiles.needs_confirmation(PROFILES, args.profile)
    for key, value in study_profiles.options(PROFILES, args.profile).items():
        if getattr(args, key) is None:
            setattr(args, key, value)
    args.full_profile = study_profiles.options(PROFILES, "full")


def parse_args(argv: list) -> argparse.Namespace:
    parser = Parser(description=__doc__.splitlines()[0], epilog=(
        f"Bounds: each option's below; at most {MAX_LIST_ITEMS} values in a list option, and "
        f"at most {MAX_JOBS} jobs in the plan (the product of the lists' lengths and the "
        "repetitions; the full profile plans 1148), refused before anything is planned."))
    parser.add_argument("--overlap", default=str(REPO / "build" / "overlap"),
                        help="the overlap binary (default: build/overlap)")
    parser.add_argument("--emulation", default=str(REPO / "build-emulation" / "overlap"),
                        help="without a GPU, the CUDA emulation build's overlap that checks "
                        "gpubf's and gpubf-paper's pairs (default: build-emulation/overlap, "
                        "used when built)")
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("out/study"),
                        help="folder for every run, table and figure (default out/study)")
    parser.add_argument("--profile", choices=study_profiles.names(PROFILES),
                        help="the named option set of scripts/study_profiles.json (default "
                        "full, which asks first)")
    parser.add_argument("--quick", action="store_true",
                        help="--profile quick: the small version, minutes on a 2-core machine")
    parser.add_argument("--full", action="store_true",
                        help="--profile full without asking: the whole study, tens of hours "
                        "on a 2-core machine (its estimate is printed first)")
    parser.add_argument("--experiments", default=",".join(study_plan.EXPERIMENTS),
                        help="comma-separated subset of " + ",".join(study_plan.EXPERIMENTS))
    parser.add_argument("--shard", type=parse_shard, default=(1, 1),
                        help="i/k: run the i-th of k shares of the stable job list (1-based; "
                        "jobs compared with each other are in one share)")
    parser.add_argument("--runs-only", action="store_true",
                        help="run the jobs and write no tables, figures or report: the "
                        "standard library is all it needs (make the report later, where "
                        "matplotlib is, with --no-runs or --from-archive)")
    parser.add_argument("--from-archive", type=pathlib.Path, metavar="TAR",
                        help="make the report from the runs in TAR (a .tar.xz holding a study "
                        "--out folder as ./study, as scripts/gpu_check.sh --study returns "
                        "it): unpacked as --out (which must be absent, empty or an earlier "
                        "unpack: docs/STUDY.md), with the run options those runs were made "
                        "with (never a path, a program or --report); implies --no-runs")
    parser.add_argument("--check-only", action="store_true",
                        help="check the options, --out and its log, overlap's broadphases and "
                        "the plan as a study would, then exit (0: they hold) without running "
                        "or writing anything (scripts/study_slurm.sh checks so before it "
                        "submits)")
    parser.add_argument("--no-runs", action="store_true",
                        help="run nothing; tables, figures and report from existing results")
    parser.add_argument("--report", action="store_true",
                        help="also fill the generated blocks of --report-doc (the hand-written "
                        "report) and copy its figures and CSVs into the report/ beside it")
    parser.add_argument("--report-doc", type=pathlib.Path, default=REPO / "docs" / "REPORT.md",
                        help="the report --report fills (default docs/REPORT.md)")
    parser.add_argument("--seed", type=whole, default=42,
                        help=f"every run's seed, 0-{MAX_SEED} (default 42)")
    parser.add_argument("--threads", type=whole, default=0,
                        help=f"oneTBB thread cap passed to every run, 0-{MAX_THREADS} (0: all "
                        "hardware threads)")
    parser.add_argument("--capture", action="store_true",
                        help="re-capture Figure 1's keyframes instead of docs/keyframes/")
    parser.add_argument("--capture-objects", type=whole, default=1250,
                        help=f"--capture: boxes, 1-{MAX_OBJECTS} (default 1250)")
    parser.add_argument("--capture-keyframes", default="0,512,1024,2047",
                        help="Figure 1's frames (default 0,512,1024,2047)")
    add_run_options(parser)
    args = parser.parse_args(argv)
    apply_profile(args, parser)
    check_values(args, parser)
    args.experiments = study_plan.names(args.experiments)
    check_plan_size(args, parser)
    args.overlap = str(pathlib.Path(args.overlap).resolve())
    args.emulation = str(pathlib.Path(args.emulation).resolve())
    blocked = next((p for p in [args.out, *args.out.parents] if os.path.exists(p)), None)
    if blocked is not None and not blocked.is_dir():
        parser.error(f"--out {args.out}: {blocked} is not a folder")
    if not os.access(args.overlap, os.X_OK):  # the report too asks it for its broadphases
        parser.error(f"--overlap {args.overlap}: not an executable (build it first)")
    return args


# The options an archive's recorded invocation gives the report made from its runs: those
# that shape the runs, by their full names, each value checked (`True`: a flag).  Nothing
# else it names is taken: no path, no program, no flag that writes (--overlap, --out,
# --report, --report-doc, --runs-only...), no abbreviation.
def archive_options() -> dict:
    full = study_profiles.options(PROFILES, "full")
    return {**{"--" + key.replace("_", "-"): type(value) for key, value in full.items()},
            "--profile": str, "--quick": True, "--full": True, "--experiments": str,
            "--seed": int, "--threads": int, "--capture": True, "--capture-objects": int,
            "--capture-keyframes": str}


# A recorded value of a list-like option: names and numbers, never a path or an option.
RUN_VALUE = re.compile(r"[A-Za-z0-9_.,+-]{0,1000}")
# What a recorded invocation names that is not the runs': left out without a word, the
# value of one that takes a value with it (a path of the machine that ran it: any bytes).
NOT_THE_RUNS = ("--overlap", "--emulation", "--out", "--shard", "--from-archive", "--notes",
                "--report-doc", "--runs-only", "--no-runs", "--report", "--check-only")
NOT_THE_RUNS_FLAGS = ("--runs-only", "--no-runs", "--report", "--check-only")


def recorded_options(argv: list) -> list:
    """The run-shaping options of a recorded argv (its first word the script), as
    `--name=value` words; raises BadArchive for a value that is not the option's."""
    allowed, kept, left = archive_options(), [], []
    words = collections.deque(argv[1:])  # popped from the left: linear in a long argv
    while words:
        word = words.popleft()
        name, has_value, value = word.partition("=")
        kind = allowed.get(name)
        if kind is None:
            if name in NOT_THE_RUNS and name not in NOT_THE_RUNS_FLAGS and not has_value \
                    and words:
                words.popleft()  # its value, whatever it holds: never an option here
            if name in NOT_THE_RUNS or not name.startswith("--"):
                continue
            left.append(one_line(name)[:60])
            continue
        if kind is True:
            if has_value:
                raise study_archive.BadArchive(f"its recorded flag {word!r} takes no value")
            kept.append(name)
            continue
        if not has_value:
            if not words:
                raise study_archive.BadArchive(f"its recorded option {name} has no value")
            value = words.popleft()
        if kind is int and not re.fullmatch(r"-?[0-9]{1,9}", value) or \
                kind is str and not RUN_VALUE.fullmatch(value):
            raise study_archive.BadArchive(
                f"its recorded {name} {value[:60]!r} is not a value of that option")
        kept.append(f"{name}={value}")
    if left:
        print(f"study: --from-archive: the recorded options {', '.join(left)} are not the "
              "runs' own; left out", file=sys.stderr)
    return kept


# What the report raises when a run file lacks what it reads (a key, a column, a type):
# from an archive that is the archive's fault, refused as bad input.
REPORT_READ_ERRORS = (LookupError, TypeError, ValueError, AttributeError, ArithmeticError,
                      csv.Error)


def file_read_when(error: BaseException, study: pathlib.Path) -> str:
    """The archive's experiment folder (study/sweep, study/physics...) whose runs the report
    was reading when `error` came: the innermost frame holding a path (or a job's folder)
    under `study`.  Only the experiment: a table that reads its runs first and uses them
    after holds the last run read, not the one that lacked the value."""
    found = None
    trace = error.__traceback__
    while trace is not None:
        for value in trace.tb_frame.f_locals.values():
            inner = value if isinstance(value, dict) else vars(value) if hasattr(
                value, "__dict__") and not isinstance(value, type) else {}
            for path in (value, inner.get("path"), inner.get("folder")):
                if isinstance(path, (str, pathlib.PurePath)) and str(path).startswith(
                        str(study) + os.sep):
                    found = pathlib.Path(path)
        trace = trace.tb_next
    if found is None:
        return "its runs"
    return "study/" + found.relative_to(study).parts[0] + ": a run's files"


def archive_report(combined: list, study: pathlib.Path) -> list:
    """The report made from the unpacked runs in the scratch folder `study`, before --out
    is replaced (so what the report cannot read refuses the archive, --out as it was);
    returns its failures.  Its paths are shown as $OUT, as in --out itself."""
    args = parse_args(combined)
    shown = list(combined)
    for index, word in enumerate(shown[:-1]):
        if word == "--out":
            shown[index + 1] = str(study)
    args.out, args.report, args.argv = study, False, shown
    broadphases.load(args.overlap)
    check_algorithms(args)
    jobs = study_plan.plan(args)
    try:
        with locked(args.out):
            failures = study_report.write_everything(args, jobs)
    except REPORT_READ_ERRORS as error:
        where = file_read_when(error, study)
        problem = one_line(str(error))[:200]
        raise study_archive.BadArchive(f"{where} do not hold what the report reads "
                                       f"({type(error).__name__}: {problem})")
    # commands.txt as --out will hold it (its paths --out's own), written here, before
    # the swap: nothing is left to write into --out once it is the new unpack.
    final = parse_args(combined)
    final.argv = combined
    with locked(args.out):
        write_atomically(study / "commands.txt", commands_text(study_plan.plan(final)))
    return failures


def planned_frames(combined: list, study: pathlib.Path) -> dict:
    """{run folder under `study`: its --frames} for each `overlap run` of the plan the
    report is made from (the archive's recorded options, then this command's own): what
    the unpack bounds those runs' files by (study_archive.check_runs)."""
    args = parse_args(combined)
    args.out = study
    broadphases.load(args.overlap)
    return {job.folder.relative_to(study).as_posix():
            int(job.options[job.options.index("--frames") + 1])
            for job in study_plan.plan(args) if isinstance(job, study_plan.RunJob)}


def commands_text(jobs: list) -> str:
    """commands.txt: one command a line, a word with a tab, a newline, a backtick or a
    byte not UTF-8 (--out may hold any) in bash's $'...' quoting (script_cli.shell_word)."""
    return "".join(" ".join(map(shell_word, c)) + "\n" for job in jobs for c in job.commands())


def options_from_archive(argv: list) -> tuple:
    """(study.py's argv for the report from --from-archive's runs: the archive's run
    options, then this command's own (which win), then --no-runs; the report's failures).
    The archive is unpacked into --out only when they parse and the report is made from
    its runs (in the scratch folder)."""
    args = parse_args(argv)

    def options_of(log: list) -> list:
        combined = recorded_options(log[0]["argv"]) + without_archive(argv) + ["--no-runs"]
        parse_args(combined)  # a bad combination exits 2 here, --out untouched
        return combined
    try:
        return study_archive.unpack(args.from_archive, args.out, options_of, archive_report,
                                    planned_frames)
    except study_archive.BadArchive as problem:
        raise BadInput(f"--from-archive {args.from_archive}: {problem}")
    except study_archive.BadOut as problem:
        raise BadInput(f"--out {problem}")


def without_archive(argv: list) -> list:
    words, kept = list(argv), []
    while words:
        word = words.pop(0)
        if word == "--from-archive":
            words[:1] = []
        elif not word.startswith("--from-archive="):
            kept.append(word)
    return kept


def run_and_log(jobs: list, args, argv: list) -> None:
    """Runs this shard's jobs, logged in OUT/study_invocations.json before the runs and
    again after them: a stopped study still names its runs; an invocation that runs
    nothing (everything done) is not logged, so regenerating the report leaves it as it
    was.  Each job's start and end are kept for the report's "what ran beside what"."""
    started, clock = time.time(), time.monotonic()  # the duration by a clock never set back
    invocation = {"argv": ["scripts/study.py", *argv], "started": time.strftime(
        "%Y-%m-%d %H:%M:%S", time.localtime(started)), "seconds": None,
        "load_average_at_start": round(os.getloadavg()[0], 2), "finished": False, "jobs": []}
    log = InvocationLog(args.out, invocation)

    def job_ran(job, start: float, end: float) -> None:
        invocation["jobs"].append({"group": job.group, "experiment": job.experiment,
                                   "key": job.key, "start": round(start, 2),
                                   "end": round(max(start, end), 2)})  # a clock set back
        log.write()

    ran, gpu_pending = run_jobs(jobs, args, log.write, job_ran)
    if ran:
        invocation.update(seconds=round(time.monotonic() - clock, 1), finished=True,
                          gpu_jobs_pending=len(gpu_pending))
        log.write()
        print(f"study: {len(ran)} jobs ran in {format_seconds(time.monotonic() - clock)}",
              file=sys.stderr)


def report(args, jobs: list) -> int:
    """Collect, plot and write the report; it names its report last (exit 1 on a failure)."""
    with locked(args.out):  # the shard that takes it last has every other shard's results
        failures = study_report.write_everything(args, jobs)
    for failure in failures:
        print(f"study: FAILED: {failure}", file=sys.stderr)
    written = [args.out / "REPORT.md"] + ([args.report_doc] if args.report else [])
    print("study: report: " + " and ".join(map(one_line, written)) +
          f" (tables as CSV and figures in {one_line(args.out / 'report')})", file=sys.stderr)
    return 1 if failures else 0


def from_archive(argv: list) -> int:
    """--from-archive: the report is made in the scratch unpack (archive_report), then
    --out is replaced by it; here only commands.txt (and with --report the hand-written
    report's blocks, made again from --out's runs) follow."""
    argv, failures = options_from_archive(argv)  # --out replaced: the stops held from there
    args = parse_args(argv)
    if args.report:
        return report_from_unpack(args, argv)
    for failure in failures:
        print(f"study: FAILED: {failure}", file=sys.stderr)
    print(f"study: report: {one_line(args.out / 'REPORT.md')} (tables as CSV and figures in "
          f"{one_line(args.out / 'report')})", file=sys.stderr)
    return 1 if failures else 0


def report_from_unpack(args, argv: list) -> int:
    """--from-archive --report, once --out is the new unpack: the hand-written report's
    blocks from --out's runs, a stop let in again (it stops only this, and says so)."""
    try:
        signal.pthread_sigmask(signal.SIG_UNBLOCK, STOPS)
        broadphases.load(args.overlap)
        check_algorithms(args)
        args.argv = argv
        return report(args, study_plan.plan(args))
    except Stopped as stop:
        raise Stopped(stop.signum, f"--out {one_line(args.out)} is the archive's unpack, whole; "
                      f"--report-doc {one_line(args.report_doc)} was not filled")


def main(argv: list) -> int:
    args = parse_args(argv)
    if args.from_archive and args.check_only:
        raise BadInput("--check-only checks a study's options; --from-archive's are checked "
                       "by the unpack itself, before --out is touched")
    if args.from_archive:  # the unpack has its own rule for --out (study_archive.py)
        return from_archive(argv)
    if problem := foreign_folder_problem(args.out) or unmakable_problem(args.out):
        raise BadInput(f"--out {one_line(args.out)}: {problem}")
    read_log(args.out)  # a log that is not the study's: refused before any job runs
    broadphases.load(args.overlap)
    check_algorithms(args)
    args.argv = argv
    jobs = study_plan.plan(args)
    if args.check_only:
        print(f"study: options checked: {len(jobs)} jobs planned into {one_line(args.out)}; nothing run "
              "or written", file=sys.stderr)
        return 0
    if not args.no_runs:  # a study refused (the full one, not confirmed) writes nothing
        run_and_log(jobs, args, argv)
    with locked(args.out):  # the lock first: what marks --out as a study's folder
        write_atomically(args.out / "commands.txt", commands_text(jobs))
    if args.runs_only:
        print(f"study: runs in {one_line(args.out)}; the report from them: scripts/study.py "
              f"--profile {args.profile} --out {one_line(args.out)} --no-runs", file=sys.stderr)
        return 0
    return report(args, jobs)


if __name__ == "__main__":
    sys.exit(run_script(lambda: main(sys.argv[1:]), "study"))
