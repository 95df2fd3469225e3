#!/usr/bin/python3
"""The study: the paper's sweep redone and extended, with figures and a report.

One command runs every experiment of project issue 6, one `overlap` process
after another (never two at once, so runs do not compete for cores), and then
writes the tables, the figures and REPORT.md from whatever results exist:

  sweep     4 scenes x algorithms x n x repetitions, `overlap run --no-tasks`,
            the same seed every repetition (the paper repeats the same scene
            and averages; only the timings differ between repetitions)
  pairs     a recorded scene-4 stream through `overlap pairs` for every
            algorithm, compared with bf's exact pairs: missed pairs must be 0
  physics   issue 14's speed against error: fixed K x --ccd off|auto|all and
            --substeps auto x --ccd off|auto, every scene, against escapes,
            sinking, penetration and energy drift; where a scene sleeps, the
            same run without sleep and the largest position error sleep caused
  latency   `overlap latency`: a broadphase one frame late on AABBs grown by
            growth * |v| * dt, against the pairs it misses and adds
  timeline  one run with the sound and AI tasks, for the async loop's timeline
  overlap   the async frame against --sync (`overlap run --compare-sync`, one
            process per point): scenes 1 and 4, n x task load, frame times,
            speed-up, the share of the tasks' time hidden and this machine's
            ideal

Every run keeps its own folder under --out; a run whose result exists is not
redone (resumable), and --shard i/k runs only the i-th of k shares of the
stable job list, so k machines, or k processes at once, can share the work
on one --out folder (scripts/study_out_folder.py: what they share, and how
nothing is lost).  The runs whose timings are compared (a sweep's algorithms
at one scene and n, an overlap point's loads, a physics cell's settings) are
in one share, run one after another; the report says what ran beside what.
The runs need only Python's standard library (--runs-only writes nothing
else); the tables, figures (matplotlib) and report are made from the runs,
on any machine (--no-runs, or --from-archive with a GPU machine's archive).  On a machine without a CUDA device the GPU algorithms'
timing runs are skipped (there they would run their CPU fallback, cpusap)
and listed in the report as needing a GPU; their pairs (the exactness
experiment) run through the CUDA emulation build (--emulation, default
build-emulation/overlap) when it is built: the same .cu files on the CPU,
checked pair for pair, never timed.

  scripts/study.py --quick --out /tmp/study_quick          # minutes, small version
  scripts/study.py --out out/study --shard 1/2              # half of the full study
  for i in 1 2 3 4; do scripts/study.py --out out/study --shard $i/4 & done; wait  # 4 at once
  scripts/study.py --out out/study --no-runs --report       # docs/REPORT.md from results
  scripts/study.py --out out/study --experiments overlap    # the overlap-timing study only
  scripts/study.py --from-archive gpu_check.tar.xz --out out/gpu-study --report  # its report

matplotlib: run with /usr/bin/python3 (Debian's python3-matplotlib).
"""
import argparse
import json
import os
import pathlib
import subprocess
import sys
import shutil
import tarfile
import tempfile
import time

import broadphases
from overlap_runs import run_summary
import study_physics
import study_report
import study_results
from study_out_folder import InvocationLog, locked, write_atomically

REPO = pathlib.Path(__file__).resolve().parent.parent

# Each profile's values; any option given on the command line wins.
FULL = {
    "scenes": "1,2,3,4", "algos": "bf,sap,bvh,gpubf-paper,gpubf,cpubf,cpusap,gpusap",
    "objects": "500,1250,2000,2750,3500", "repetitions": 5, "frames": 2048,
    "figure_objects": 1250,
    "pairs_objects": 3500, "pairs_frames": 256,
    "pairs_algos": "bf,sap,sap32,bvh,cpubf,cpusap,gpubf,gpubf-paper,gpusap",
    "physics_scenes": "1,2,3,4", "physics_objects": 3500, "physics_frames": 2048,
    "physics_substeps": "1,2,4,8,16,auto", "physics_ccd": "off,auto,all", "physics_algo": "bvh",
    "physics_seeds": "7,123", "physics_compare_objects": "", "physics_compare_frames": 2048,
    "latency_scenes": "1,2,3,4", "latency_objects": 3500, "latency_frames": 2048,
    "latency_algos": "bf,sap,bvh,cpubf,cpusap,gpubf", "latency_growths": "0,1,2",
    "timeline_objects": 1250, "timeline_frames": 64,
    "overlap_scenes": "1,4", "overlap_objects": "500,1250,3500",
    "overlap_loads": "0,0.5,1,1.5,2", "overlap_frames": 48, "overlap_algo": "gpubf",
    "overlap_repetitions": 5,
}
# The small version, minutes on a 2-core machine: what it does not name is FULL's.
QUICK = {**FULL,
         "algos": "bf,bvh,cpubf", "objects": "200,400", "repetitions": 1, "frames": 90,
         "figure_objects": 400, "pairs_objects": 400, "pairs_frames": 90,
         "pairs_algos": "bf,sap,sap32,bvh,cpubf", "physics_scenes": "1,3,4",
         "physics_objects": 400, "physics_frames": 90, "physics_substeps": "1,2,4,8,auto",
         "physics_seeds": "7", "physics_compare_frames": 90, "latency_objects": 400,
         "latency_frames": 90, "latency_algos": "bvh,cpubf", "timeline_objects": 400,
         "timeline_frames": 16, "overlap_objects": "150,300", "overlap_loads": "0,1,2",
         "overlap_frames": 10, "overlap_repetitions": 1}
EXPERIMENTS = ("sweep", "pairs", "physics", "latency", "timeline", "overlap")
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
}


def ints(text: str) -> list:
    return [int(x) for x in text.split(",") if x]


def names(text: str) -> list:
    return [x for x in text.split(",") if x]


def default_substeps(scene: int) -> int:
    """About the mean K --substeps auto chooses (physics/step_policy.h), for the ETA only."""
    return 5 if scene >= 3 else 1


def physics_cells(args) -> list:
    """Every physics run as (scene, substeps text, ccd, sleep, solver, objects, frames, seed).
    The main grid (--physics-objects, --seed): fixed K x each --ccd mode and auto x each but
    all, with the default solver; where the scene sleeps (1, 2) auto with its default CCD once
    more without sleep.  The comparison cells, auto against the K the project fixed before
    (study_physics.old_default_k) with the default solver and Bullet's: at the main size and
    seed, at each --physics-seeds and at each --physics-compare-objects."""
    n, frames, seed = args.physics_objects, args.physics_frames, args.seed
    cells = []
    for scene in ints(args.physics_scenes):
        for substeps in names(args.physics_substeps):
            for ccd in names(args.physics_ccd):
                if not (substeps == "auto" and ccd == "all"):
                    cells.append((scene, substeps, ccd, "scene", "pile", n, frames, seed))
        if scene <= 2 and "auto" in names(args.physics_substeps):
            cells.append((scene, "auto", "auto", "off", "pile", n, frames, seed))
    groups = [(n, frames, s) for s in [seed] + ints(args.physics_seeds)]
    groups += [(m, args.physics_compare_frames, seed) for m in ints(args.physics_compare_objects)]
    for scene in ints(args.physics_scenes):
        k = str(study_physics.old_default_k(scene))
        for objects, count, s in groups:
            for cell in [("auto", ccd, "pile") for ccd in ("off", "auto")] + [
                    (k, ccd, solver) for ccd in ("off", "auto") for solver in ("pile", "bullet")]:
                run = (scene, cell[0], cell[1], "scene", cell[2], objects, count, s)
                if run not in cells:
                    cells.append(run)
    return cells


class Job:
    """One unit of work: one or a few `overlap` processes and the file that proves it done.

    Each kind below adds done() (its result exists), commands() (the command
    lines it runs, for commands.txt and the report) and run().  `labels` are
    the job's coordinates (scene, objects, algo, ...) for the tables; `weight`
    is its expected cost relative to the others, for the ETA; `gpu_algo` names
    the GPU algorithm it needs, if any.  `group` names the jobs whose timings
    are compared with each other (a sweep's algorithms at one scene and n, ...):
    a group is one shard's, so its runs never run at once (plan() sets it; a
    job compared with none is a group of its own).
    """

    def __init__(self, experiment, key, weight, labels, gpu_algo=None):
        self.experiment, self.key, self.weight = experiment, key, weight
        self.labels, self.gpu_algo = labels, gpu_algo
        self.group = f"{experiment} {key}"

    def in_group(self, group: str) -> "Job":
        self.group = group
        return self


def check_output(command: list) -> str:
    """Runs `command`, returns its stdout; on failure shows its stderr and stops the study."""
    result = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if result.returncode != 0:
        sys.exit(f"study: failed (exit {result.returncode}): {' '.join(command)}\n{result.stderr}")
    return result.stdout


class RunJob(Job):
    """`overlap run OPTIONS --out FOLDER`; done when FOLDER/summary.json exists."""

    def __init__(self, experiment, key, weight, labels, overlap, folder, options, gpu_algo=None):
        super().__init__(experiment, key, weight, labels, gpu_algo)
        self.overlap, self.folder, self.options = overlap, folder, options

    def done(self):
        return (self.folder / "summary.json").exists()

    def commands(self):
        return [[self.overlap, "run", *self.options, "--capture-every", "0", "--no-wav",
                 "--out", str(self.folder)]]

    def run(self):
        try:
            run_summary(self.overlap, self.folder, self.options)
        except subprocess.CalledProcessError:
            sys.exit("study: failed: " + " ".join(self.commands()[0]) +
                     "\n(run it by hand to see its message)")


class LatencyJob(Job):
    """`overlap latency` for one scene and algorithm; its CSV is the result."""

    def __init__(self, key, weight, labels, overlap, path, options, gpu_algo):
        super().__init__("latency", key, weight, labels, gpu_algo)
        self.overlap, self.path, self.options = overlap, path, options

    def done(self):
        return self.path.exists()

    def commands(self):
        return [[self.overlap, "latency", *self.options]]

    def run(self):
        write_atomically(self.path, check_output(self.commands()[0]))


class PairsJob(Job):
    """One algorithm's pairs on the recorded scene-4 stream against bf's, frame by frame.

    Writes pairs/<algo>.csv: frame, exact, reported, missed, extra.  The stream
    and bf's pairs are made by whichever job needs them first.
    """

    def __init__(self, key, weight, overlap, folder, stream, record_options, frames, algo,
                 gpu_algo):
        super().__init__("pairs", key, weight, {"algo": algo}, gpu_algo)
        self.overlap, self.folder, self.stream, self.frames = overlap, folder, stream, frames
        self.record_options, self.algo = record_options, algo
        self.finder = overlap  # the binary that runs `pairs --algo algo`: see use_emulation()
        self.path = folder / f"{algo}.csv"
        self.exact_path = folder / "bf_pairs.csv"

    def done(self):
        return self.path.exists()

    def commands(self):
        record = [self.overlap, "record", *self.record_options, "--out", str(self.stream)]
        return [record, [self.overlap, "pairs", "--algo", "bf", "--input", str(self.stream)],
                [self.finder, "pairs", "--algo", self.algo, "--input", str(self.stream)]]

    def use_emulation(self, emulation: str, device: str) -> None:
        """Runs this GPU algorithm's pairs through the CUDA emulation build: the kernels'
        pairs are checked; the emulation's time is never a result."""
        self.finder = emulation
        self.device_path().parent.mkdir(parents=True, exist_ok=True)
        write_atomically(self.device_path(), json.dumps({"device": device}) + "\n")

    def device_path(self) -> pathlib.Path:
        return self.folder / f"{self.algo}.device.json"

    def run(self):
        record, exact, mine = self.commands()
        if not self.stream.exists():
            self.stream.parent.mkdir(parents=True, exist_ok=True)
            check_output(record)
        if not self.exact_path.exists():
            write_atomically(self.exact_path, check_output(exact))
        result = subprocess.run(mine, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        if result.returncode != 0 or "instead" in result.stderr:
            sys.exit(f"study: {' '.join(mine)} failed or did not run {self.algo}:\n{result.stderr}")
        exact_frames = pairs_by_frame(self.exact_path.read_text())
        reported_frames = pairs_by_frame(result.stdout)
        rows = ["frame,exact,reported,missed,extra"]
        for frame in range(self.frames + 1):  # the start and after each frame
            exact_pairs = exact_frames.get(frame, set())
            reported = reported_frames.get(frame, set())
            rows.append(f"{frame},{len(exact_pairs)},{len(reported)},"
                        f"{len(exact_pairs - reported)},{len(reported - exact_pairs)}")
        write_atomically(self.path, "\n".join(rows) + "\n")


class SleepErrorJob(Job):
    """Where sleep moved the boxes: `overlap record` with --sleep on and off, the box
    centres (the AABBs' centres) compared frame by frame; writes sleep_error.json."""

    def __init__(self, key, weight, labels, overlap, folder, record_options):
        super().__init__("physics_sleep", key, weight, labels)
        self.overlap, self.folder, self.record_options = overlap, folder, record_options
        self.path = folder / "sleep_error.json"

    def done(self):
        return self.path.exists()

    def commands(self):
        return [[self.overlap, "record", *self.record_options, "--sleep", sleep, "--out",
                 str(self.folder / f"sleep_{sleep}.aabbs")] for sleep in ("on", "off")]

    def run(self):
        self.folder.mkdir(parents=True, exist_ok=True)
        for command in self.commands():
            check_output(command)
        on, off = (study_results.box_centres(self.folder / f"sleep_{s}.aabbs") for s in ("on", "off"))
        write_atomically(self.path, json.dumps(study_results.position_error(on, off), indent=2))
        for sleep in ("on", "off"):  # large, and only these numbers were wanted
            (self.folder / f"sleep_{sleep}.aabbs").unlink()


def pairs_by_frame(csv_text: str) -> dict:
    """`overlap pairs` CSV (frame,a,b) as {frame: {(a, b)}}; frames without pairs are absent."""
    frames = {}
    for line in csv_text.splitlines()[1:]:
        frame, a, b = line.split(",")
        frames.setdefault(int(frame), set()).add((int(a), int(b)))
    return frames


def plan(args) -> list:
    """Every job of the study, in a stable order (sharding depends on it)."""
    out, overlap, seed = args.out, args.overlap, str(args.seed)
    threads = ["--threads", str(args.threads)] if args.threads else []
    jobs = []
    if "sweep" in args.experiments:
        for scene in ints(args.scenes):
            for n in ints(args.objects):
                for algo in names(args.algos):
                    for rep in range(args.repetitions):
                        key = f"s{scene}_n{n}_{algo}_r{rep}"
                        jobs.append(RunJob(
                            "sweep", key, args.frames * default_substeps(scene) * n,
                            {"scene": scene, "objects": n, "algo": algo, "rep": rep}, overlap,
                            out / "sweep" / key,
                            ["--scene", str(scene), "--objects", str(n), "--algo", algo,
                             "--frames", str(args.frames), "--seed", seed, "--no-tasks", *threads],
                            algo if algo in broadphases.needs_device() else None
                            ).in_group(f"sweep s{scene} n{n}"))
    if "pairs" in args.experiments:
        n, frames = args.pairs_objects, args.pairs_frames
        stream = out / "streams" / f"scene4_seed{seed}_n{n}_f{frames}.aabbs"
        record = ["--scene", "4", "--objects", str(n), "--frames", str(frames), "--seed", seed]
        for algo in names(args.pairs_algos):
            jobs.append(PairsJob(f"pairs_{algo}", frames * n, overlap, out / "pairs", stream,
                                 record, frames, algo, algo if algo in broadphases.needs_device() else None))
    if "physics" in args.experiments:
        for scene, substeps, ccd, sleep, solver, n, frames, cell_seed in physics_cells(args):
            key = (f"s{scene}_n{n}_k{substeps}_ccd-{ccd}" + ("" if sleep == "scene" else "_nosleep")
                   + ("" if solver == "pile" else f"_{solver}")
                   + ("" if cell_seed == args.seed else f"_seed{cell_seed}"))
            k = default_substeps(scene) if substeps == "auto" else int(substeps)
            main = n == args.physics_objects and cell_seed == args.seed
            jobs.append(RunJob(
                "physics", key, frames * k * n * (1 if ccd == "off" else 2),
                {"scene": scene, "objects": n, "substeps": substeps, "ccd": ccd, "solver": solver,
                 "seed": cell_seed, "sleep_error_cell": main and sleep == "scene"}, overlap,
                out / "physics" / key,
                ["--scene", str(scene), "--objects", str(n), "--algo", args.physics_algo,
                 "--frames", str(frames), "--seed", str(cell_seed), "--substeps", substeps,
                 "--ccd", ccd, "--sleep", sleep, "--solver", solver, "--no-tasks", *threads]
            ).in_group(f"physics s{scene} n{n} seed{cell_seed}"))
            if sleep == "off":  # where the positions of the runs with and without sleep differ
                record = ["--scene", str(scene), "--objects", str(n), "--frames", str(frames),
                          "--seed", seed, "--substeps", substeps, "--ccd", ccd]
                jobs.append(SleepErrorJob(f"s{scene}_n{n}_sleep_error", 2 * frames * k * n,
                                          {"scene": scene, "objects": n}, overlap,
                                          out / "physics" / f"s{scene}_n{n}_sleep_error", record
                                          ).in_group(f"physics s{scene} n{n} seed{cell_seed}"))
    if "latency" in args.experiments:
        n, frames = args.latency_objects, args.latency_frames
        for scene in ints(args.latency_scenes):
            for algo in names(args.latency_algos):
                key = f"s{scene}_n{n}_{algo}"
                jobs.append(LatencyJob(
                    key, 2 * frames * default_substeps(scene) * n,
                    {"scene": scene, "objects": n, "algo": algo}, overlap,
                    out / "latency" / f"{key}.csv",
                    ["--scene", str(scene), "--objects", str(n), "--frames", str(frames),
                     "--seed", seed, "--algo", algo, "--growth", args.latency_growths, *threads],
                    algo if algo in broadphases.needs_device() else None
                ).in_group(f"latency s{scene}"))
    if "timeline" in args.experiments:
        n, frames = args.timeline_objects, args.timeline_frames
        # gpubf with the tasks beside it: on a machine without a GPU it runs
        # cpusap, and the summary (and so the figure) says so.
        jobs.append(RunJob("timeline", "timeline", frames * 8 * n, {}, overlap, out / "timeline",
                           ["--scene", "4", "--objects", str(n), "--algo", "gpubf",
                            "--frames", str(frames), "--seed", seed, *threads]))
    if "overlap" in args.experiments:
        frames = args.overlap_frames
        for scene in ints(args.overlap_scenes):
            for n in ints(args.overlap_objects):
                for load in names(args.overlap_loads):
                    for rep in range(args.overlap_repetitions):
                        key = f"s{scene}_n{n}_load{load}_r{rep}"
                        # The sync run, the async run and the calibration's frames.
                        weight = ((2 * frames + 6) * default_substeps(scene) * n
                                  * (1 + float(load)))
                        jobs.append(RunJob(
                            "overlap", key, weight,
                            {"scene": scene, "objects": n, "load": float(load), "rep": rep},
                            overlap, out / "overlap" / key,
                            ["--scene", str(scene), "--objects", str(n), "--algo",
                             args.overlap_algo, "--frames", str(frames), "--seed", seed,
                             "--task-load", load, "--compare-sync", *threads]
                        ).in_group(f"overlap s{scene} n{n}"))
    if args.capture:
        for scene in ints(args.scenes):
            jobs.append(CaptureJob(scene, overlap, out / "keyframes", args.capture_objects,
                                   args.capture_keyframes))
    return jobs


class CaptureJob(Job):
    """`overlap capture` of one scene's keyframes (Figure 1), when asked to re-capture."""

    def __init__(self, scene, overlap, folder, objects, keyframes):
        weight = (max(ints(keyframes)) + 1) * default_substeps(scene) * objects
        super().__init__("capture", f"capture_s{scene}", weight, {"scene": scene})
        self.scene, self.overlap, self.folder = scene, overlap, folder
        self.objects, self.keyframes = objects, keyframes

    def done(self):
        return all((self.folder / f"scene{self.scene}_frame{f:04d}.png").exists()
                   for f in ints(self.keyframes))

    def commands(self):
        return [[self.overlap, "capture", "--scene", str(self.scene), "--objects",
                 str(self.objects), "--keyframes", self.keyframes, "--capture-size", "400x300",
                 "--algo", "bvh", "--out", str(self.folder)]]

    def run(self):
        check_output(self.commands()[0])


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


def without_a_gpu(pending: list, args) -> tuple:
    """On a machine whose `overlap` has no CUDA device: (the jobs to run, the GPU jobs left
    for a GPU machine).  The GPU algorithms' pairs run through the CUDA emulation build when
    it is built; their timings would be the CPU fallback's and are left."""
    gpu_jobs = [job for job in pending if job.gpu_algo]
    runnable = [job for job in pending if not job.gpu_algo]
    exactness = [job for job in gpu_jobs if isinstance(job, PairsJob)]
    if exactness and os.access(args.emulation, os.X_OK):
        emulated, device = gpu_present(args.emulation)
        if emulated and "emulation" in device:
            for job in exactness:
                job.use_emulation(args.emulation, device)
            runnable += exactness
            print(f"study: {', '.join(j.algo for j in exactness)}: pairs through {device} "
                  f"({args.emulation}), checked, not timed", file=sys.stderr)
    left = [job for job in gpu_jobs if job not in runnable]
    return runnable, left


def shard_share(jobs: list, shard: int, shards: int) -> list:
    """Shard `shard`'s jobs (1-based, of `shards`), in plan order: whole groups (the jobs
    compared with each other run in one shard, one after another), the heaviest group first
    to the lightest-loaded shard.  It depends on the plan alone, so every shard, on every
    machine and after any resumption, computes the same split."""
    groups = {}
    for job in jobs:
        groups.setdefault(job.group, []).append(job)
    load = [0.0] * shards
    owner = {}
    for group, members in sorted(groups.items(), key=lambda g: -sum(j.weight for j in g[1])):
        lightest = load.index(min(load))
        owner[group] = lightest + 1
        load[lightest] += sum(job.weight for job in members)
    return [job for job in jobs if owner[job.group] == shard]


def run_jobs(jobs: list, args, on_start, on_job) -> tuple:
    """Runs this shard's pending jobs one after another, calling on_start() first when
    there is any and on_job(job, start, end) (wall-clock seconds) after each; returns (the
    jobs run, the GPU jobs left pending)."""
    shard, shards = args.shard
    mine = shard_share(jobs, shard, shards)
    pending = [job for job in mine if not job.done()]
    gpu_pending = []
    if any(job.gpu_algo for job in pending):
        present, gpu = gpu_present(args.overlap)
        if not present:
            pending, gpu_pending = without_a_gpu(pending, args)
            print(f"study: no CUDA device ({gpu}); {len(gpu_pending)} GPU jobs left for a "
                  "machine with one", file=sys.stderr)
    print(f"study: shard {shard}/{shards}: {len(mine)} of {len(jobs)} jobs, "
          f"{len(mine) - len(pending) - len(gpu_pending)} already done, {len(pending)} to run",
          file=sys.stderr)
    if pending:
        on_start()
    total_weight = sum(job.weight for job in pending)
    done_weight = 0
    started = time.monotonic()
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
    try:
        shard, shards = (int(x) for x in text.split("/"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--shard {text}: expected i/k, e.g. 1/4")
    if not 1 <= shard <= shards:
        raise argparse.ArgumentTypeError(f"--shard {text}: i must be in 1..k")
    return shard, shards


def parse_args(argv: list) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--overlap", default=str(REPO / "build" / "overlap"),
                        help="the overlap binary (default: build/overlap)")
    parser.add_argument("--emulation", default=str(REPO / "build-emulation" / "overlap"),
                        help="without a GPU, the CUDA emulation build's overlap that checks "
                        "gpubf's and gpubf-paper's pairs (default: build-emulation/overlap, "
                        "used when built)")
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("out/study"),
                        help="folder for every run, table and figure (default out/study)")
    parser.add_argument("--quick", action="store_true",
                        help="the small version: minutes on a 2-core machine")
    parser.add_argument("--experiments", default=",".join(EXPERIMENTS),
                        help="comma-separated subset of " + ",".join(EXPERIMENTS))
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
                        "it): unpacked into --out, with the options those runs were made "
                        "with; implies --no-runs")
    parser.add_argument("--no-runs", action="store_true",
                        help="run nothing; tables, figures and report from existing results")
    parser.add_argument("--report", action="store_true",
                        help="also write docs/REPORT.md with its figures in docs/report/")
    parser.add_argument("--notes", type=pathlib.Path, default=REPO / "docs" / "report_notes",
                        help="folder of the report's hand-written notes, KEY.md for section KEY "
                        "(default docs/report_notes)")
    parser.add_argument("--seed", type=int, default=42, help="every run's seed (default 42)")
    parser.add_argument("--threads", type=int, default=0,
                        help="oneTBB thread cap passed to every run (0: all hardware threads)")
    parser.add_argument("--capture", action="store_true",
                        help="re-capture Figure 1's keyframes instead of docs/keyframes/")
    parser.add_argument("--capture-objects", type=int, default=1250,
                        help="--capture: boxes (default 1250)")
    parser.add_argument("--capture-keyframes", default="0,512,1024,2047",
                        help="Figure 1's frames (default 0,512,1024,2047)")
    for key, value in FULL.items():
        parser.add_argument("--" + key.replace("_", "-"), type=type(value), default=None,
                            help=f"{HELP[key]} (default {value}; --quick {QUICK[key]})")
    args = parser.parse_args(argv)
    profile = QUICK if args.quick else FULL
    for key, value in profile.items():
        if getattr(args, key) is None:
            setattr(args, key, value)
    args.experiments = names(args.experiments)
    unknown = set(args.experiments) - set(EXPERIMENTS)
    if unknown:
        parser.error(f"--experiments: unknown {','.join(sorted(unknown))}")
    args.overlap = str(pathlib.Path(args.overlap).resolve())
    args.emulation = str(pathlib.Path(args.emulation).resolve())
    if not (args.no_runs or args.from_archive) and not os.access(args.overlap, os.X_OK):
        parser.error(f"--overlap {args.overlap}: not an executable (build it first)")
    return args


# What an invocation's argv names that belongs to its machine or shapes only the report:
# options followed by a value, then flags.  The rest are the runs' options.
PLACE_OPTIONS = ("--overlap", "--emulation", "--out", "--notes", "--shard", "--from-archive")
REPORT_FLAGS = ("--runs-only", "--no-runs", "--report")


def options_of_runs(out: pathlib.Path) -> list:
    """The options the runs kept in `out` were made with: its first invocation's, less
    its paths, its shard and the flags that shape only the report."""
    log = out / "study_invocations.json"
    if not log.exists():
        raise SystemExit(f"study: {out} has no study_invocations.json: not a study's --out")
    words, kept = list(json.loads(log.read_text())[0]["argv"][1:]), []
    while words:
        word = words.pop(0)
        if word in PLACE_OPTIONS:
            words.pop(0)
        elif word not in REPORT_FLAGS:
            kept.append(word)
    return kept


def unpack_study(archive: pathlib.Path, out: pathlib.Path) -> None:
    """The archive's ./study folder as `out`, replacing it whole; on a bad archive, a clear
    error (exit 2) and `out` as it was."""
    def refuse(problem: str):
        print(f"study: --from-archive {archive}: {problem}", file=sys.stderr)
        sys.exit(2)
    if not archive.is_file():
        refuse("no such file")
    out.parent.mkdir(parents=True, exist_ok=True)
    scratch = pathlib.Path(tempfile.mkdtemp(prefix=f".{out.name}.unpack-", dir=out.parent))
    try:
        try:
            with tarfile.open(archive) as tar:
                members = [m for m in tar.getmembers()
                           if pathlib.PurePosixPath(m.name).parts[:1] in (("study",), (".", "study"))
                           or m.name in ("study", "./study")]
                if not members:
                    refuse("holds no ./study folder (a study's --out)")
                if any(".." in pathlib.PurePosixPath(m.name).parts or m.name.startswith("/")
                       or not (m.isfile() or m.isdir()) for m in members):
                    refuse("names a path outside ./study, or a link")
                tar.extractall(scratch, members)
        except (tarfile.TarError, OSError, EOFError) as error:
            refuse(f"cannot be read ({error})")
        if not (scratch / "study" / "study_invocations.json").exists():
            refuse("its ./study has no study_invocations.json: no study ran into it")
        if out.exists():
            shutil.rmtree(out)
        (scratch / "study").rename(out)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def main(argv: list) -> int:
    args = parse_args(argv)
    if args.from_archive:
        unpack_study(args.from_archive, args.out)
        at = argv.index("--from-archive") if "--from-archive" in argv else None
        given = argv[:at] + argv[at + 2:] if at is not None else [
            w for w in argv if not w.startswith("--from-archive=")]
        argv = options_of_runs(args.out) + given + ["--no-runs"]
        args = parse_args(argv)
    broadphases.load(args.overlap)
    args.argv = argv
    args.full_profile = FULL
    args.out.mkdir(parents=True, exist_ok=True)
    jobs = plan(args)
    write_atomically(args.out / "commands.txt",
                     "".join(" ".join(map(str, c)) + "\n" for job in jobs for c in job.commands()))
    started = time.time()
    invocation = {"argv": ["scripts/study.py", *argv], "started": time.strftime(
        "%Y-%m-%d %H:%M:%S", time.localtime(started)), "seconds": None,
        "load_average_at_start": round(os.getloadavg()[0], 2), "finished": False, "jobs": []}
    log = InvocationLog(args.out, invocation)

    def job_ran(job, start: float, end: float) -> None:  # for the report's "what ran beside what"
        invocation["jobs"].append({"group": job.group, "experiment": job.experiment,
                                   "key": job.key, "start": round(start, 2),
                                   "end": round(end, 2)})
        log.write()

    # Logged before the runs and again after them: a stopped study still names its runs;
    # an invocation that runs nothing (everything done) is not logged, so regenerating the
    # report leaves it as it was.
    ran, gpu_pending = ([], []) if args.no_runs else run_jobs(jobs, args, log.write, job_ran)
    if ran:
        invocation.update(seconds=round(time.time() - started, 1), finished=True,
                          gpu_jobs_pending=len(gpu_pending))
        log.write()
    if args.runs_only:
        return 0
    with locked(args.out):  # the shard that takes it last has every other shard's results
        failures = study_report.write_everything(args, jobs)
    for failure in failures:
        print(f"study: FAILED: {failure}", file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
