"""The study's plan: every job of every experiment, in one stable order.

A job is one or a few `overlap` processes and the file that proves it done
(Job and its kinds below).  plan() lists every job of the experiments asked
for, one planner per experiment, always in the same order: shard_share()
splits that list between shards, so every shard, on every machine and after
any resumption, must compute the same list.  A job's key names its folder
under --out (a run whose result exists is not redone), its weight is its cost
relative to the others (frames x substeps x boxes: the ETA and the shards'
balance), and its group holds the jobs whose timings are compared with each
other, which one shard runs one after another.
"""
import json
import pathlib
import subprocess
import sys

import broadphases
import study_physics
import study_results
from overlap_runs import run_summary
from script_cli import one_line, run_child, signal_name
from study_out_folder import write_atomically

EXPERIMENTS = ("sweep", "pairs", "physics", "latency", "timeline", "overlap")


def ints(text: str) -> list:
    return [int(x) for x in text.split(",") if x]


def names(text: str) -> list:
    return [x for x in text.split(",") if x]


def default_substeps(scene: int) -> int:
    """About the mean K --substeps auto chooses (physics/step_policy.h), for the ETA only."""
    return 5 if scene >= 3 else 1


def gpu_need(algo: str):
    """The GPU algorithm a job of `algo` needs, or None."""
    return algo if algo in broadphases.needs_device() else None


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
    result = run_child(command, capture_output=True, text=True)
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
        except subprocess.CalledProcessError as error:
            said = [line for line in (error.stderr or "").splitlines() if line.strip()]
            how = (f"killed by {signal_name(-error.returncode)}" if error.returncode < 0
                   else f"exit {error.returncode}")
            sys.exit(f"study: failed ({how}): {' '.join(self.commands()[0])}: " +
                     (one_line(said[-1]) if said else "it said nothing"))


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
        self.device = None  # the CUDA emulation's device line, when it runs them
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
        self.finder, self.device = emulation, device

    def device_path(self) -> pathlib.Path:
        return self.folder / f"{self.algo}.device.json"

    def run(self):
        if self.device:  # what ran these pairs, written when they run
            write_atomically(self.device_path(), json.dumps({"device": self.device}) + "\n")
        record, exact, mine = self.commands()
        if not self.stream.exists():
            self.stream.parent.mkdir(parents=True, exist_ok=True)
            check_output(record)
        if not self.exact_path.exists():
            write_atomically(self.exact_path, check_output(exact))
        result = run_child(mine, capture_output=True, text=True)
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



# --- the physics cells ----------------------------------------------------------

def main_physics_cells(args, scene: int) -> list:
    """The main grid of one scene (--physics-objects, --seed): fixed K x each --ccd mode and
    auto x each but all, with the default solver; where the scene sleeps (1, 2), auto with
    its default CCD once more without sleep."""
    n, frames, seed = args.physics_objects, args.physics_frames, args.seed
    substeps = names(args.physics_substeps)
    cells = [(scene, k, ccd, "scene", "pile", n, frames, seed)
             for k in substeps for ccd in names(args.physics_ccd)
             if not (k == "auto" and ccd == "all")]
    if scene <= 2 and "auto" in substeps:
        cells.append((scene, "auto", "auto", "off", "pile", n, frames, seed))
    return cells


def comparison_physics_cells(args, scene: int) -> list:
    """Auto against the K the project fixed before (study_physics.old_default_k), with the
    default solver and Bullet's: at the main size and seed, at each --physics-seeds and at
    each --physics-compare-objects."""
    seed = args.seed
    groups = [(args.physics_objects, args.physics_frames, s)
              for s in [seed] + ints(args.physics_seeds)]
    groups += [(m, args.physics_compare_frames, seed) for m in ints(args.physics_compare_objects)]
    k = str(study_physics.old_default_k(scene))
    settings = [("auto", ccd, "pile") for ccd in ("off", "auto")]
    settings += [(k, ccd, solver) for ccd in ("off", "auto") for solver in ("pile", "bullet")]
    return [(scene, substeps, ccd, "scene", solver, objects, frames, s)
            for objects, frames, s in groups for substeps, ccd, solver in settings]


def physics_cells(args) -> list:
    """Every physics run as (scene, substeps text, ccd, sleep, solver, objects, frames, seed):
    each scene's main grid, then each scene's comparison cells not already in it."""
    cells = []
    for scene in ints(args.physics_scenes):
        cells += main_physics_cells(args, scene)
    seen = set(cells)  # a set: linear in the cells, however long the lists
    for scene in ints(args.physics_scenes):
        added = [c for c in comparison_physics_cells(args, scene) if c not in seen]
        cells += added
        seen.update(added)
    return cells


# --- one planner per experiment ----------------------------------------------------

class Plan:
    """What every planner shares: the --out folder, the binary, the seed and thread cap."""

    def __init__(self, args):
        self.args, self.out, self.overlap = args, args.out, args.overlap
        self.seed = str(args.seed)
        self.threads = ["--threads", str(args.threads)] if args.threads else []

    def scene_options(self, scene, n, frames, seed=None) -> list:
        return ["--scene", str(scene), "--objects", str(n), "--frames", str(frames),
                "--seed", self.seed if seed is None else str(seed)]


def sweep_jobs(p: Plan) -> list:
    a, jobs = p.args, []
    for scene in ints(a.scenes):
        for n in ints(a.objects):
            for algo in names(a.algos):
                for rep in range(a.repetitions):
                    key = f"s{scene}_n{n}_{algo}_r{rep}"
                    options = ["--scene", str(scene), "--objects", str(n), "--algo", algo,
                               "--frames", str(a.frames), "--seed", p.seed, "--no-tasks",
                               *p.threads]
                    jobs.append(RunJob(
                        "sweep", key, a.frames * default_substeps(scene) * n,
                        {"scene": scene, "objects": n, "algo": algo, "rep": rep}, p.overlap,
                        p.out / "sweep" / key, options, gpu_need(algo)
                    ).in_group(f"sweep s{scene} n{n}"))
    return jobs


def pairs_jobs(p: Plan) -> list:
    n, frames = p.args.pairs_objects, p.args.pairs_frames
    stream = p.out / "streams" / f"scene4_seed{p.seed}_n{n}_f{frames}.aabbs"
    record = p.scene_options(4, n, frames)
    return [PairsJob(f"pairs_{algo}", frames * n, p.overlap, p.out / "pairs", stream, record,
                     frames, algo, gpu_need(algo)) for algo in names(p.args.pairs_algos)]


def physics_key(args, cell: tuple) -> str:
    scene, substeps, ccd, sleep, solver, n, _, seed = cell
    return (f"s{scene}_n{n}_k{substeps}_ccd-{ccd}" + ("" if sleep == "scene" else "_nosleep")
            + ("" if solver == "pile" else f"_{solver}")
            + ("" if seed == args.seed else f"_seed{seed}"))


def physics_run(p: Plan, cell: tuple) -> "RunJob":
    scene, substeps, ccd, sleep, solver, n, frames, seed = cell
    a = p.args
    k = default_substeps(scene) if substeps == "auto" else int(substeps)
    main = n == a.physics_objects and seed == a.seed
    key = physics_key(a, cell)
    options = ["--scene", str(scene), "--objects", str(n), "--algo", a.physics_algo,
               "--frames", str(frames), "--seed", str(seed), "--substeps", substeps,
               "--ccd", ccd, "--sleep", sleep, "--solver", solver, "--no-tasks", *p.threads]
    labels = {"scene": scene, "objects": n, "substeps": substeps, "ccd": ccd, "solver": solver,
              "seed": seed, "sleep_error_cell": main and sleep == "scene"}
    return RunJob("physics", key, frames * k * n * (1 if ccd == "off" else 2), labels,
                  p.overlap, p.out / "physics" / key, options)


def sleep_error_job(p: Plan, cell: tuple) -> "SleepErrorJob":
    """Where the positions of the runs with and without sleep differ (a no-sleep cell)."""
    scene, substeps, ccd, _, _, n, frames, _ = cell
    k = default_substeps(scene) if substeps == "auto" else int(substeps)
    record = [*p.scene_options(scene, n, frames), "--substeps", substeps, "--ccd", ccd]
    key = f"s{scene}_n{n}_sleep_error"
    return SleepErrorJob(key, 2 * frames * k * n, {"scene": scene, "objects": n}, p.overlap,
                         p.out / "physics" / key, record)


def physics_jobs(p: Plan) -> list:
    jobs = []
    for cell in physics_cells(p.args):
        scene, n, seed = cell[0], cell[5], cell[7]
        group = f"physics s{scene} n{n} seed{seed}"
        jobs.append(physics_run(p, cell).in_group(group))
        if cell[3] == "off":
            jobs.append(sleep_error_job(p, cell).in_group(group))
    return jobs


def latency_jobs(p: Plan) -> list:
    a, jobs = p.args, []
    n, frames = a.latency_objects, a.latency_frames
    for scene in ints(a.latency_scenes):
        for algo in names(a.latency_algos):
            key = f"s{scene}_n{n}_{algo}"
            options = [*p.scene_options(scene, n, frames), "--algo", algo,
                       "--growth", a.latency_growths, *p.threads]
            jobs.append(LatencyJob(
                key, 2 * frames * default_substeps(scene) * n,
                {"scene": scene, "objects": n, "algo": algo}, p.overlap,
                p.out / "latency" / f"{key}.csv", options, gpu_need(algo)
            ).in_group(f"latency s{scene}"))
    return jobs


def timeline_jobs(p: Plan) -> list:
    """gpubf with the tasks beside it: on a machine without a GPU it runs cpusap, and the
    summary (and so the figure) says so."""
    n, frames = p.args.timeline_objects, p.args.timeline_frames
    options = ["--scene", "4", "--objects", str(n), "--algo", "gpubf", "--frames", str(frames),
               "--seed", p.seed, *p.threads]
    return [RunJob("timeline", "timeline", frames * 8 * n, {}, p.overlap, p.out / "timeline",
                   options)]


def overlap_job(p: Plan, scene: int, n: int, load: str, rep: int) -> "RunJob":
    a = p.args
    frames = a.overlap_frames
    key = f"s{scene}_n{n}_load{load}_r{rep}"
    # The sync run, the async run and the calibration's frames.
    weight = (2 * frames + 6) * default_substeps(scene) * n * (1 + float(load))
    options = ["--scene", str(scene), "--objects", str(n), "--algo", a.overlap_algo,
               "--frames", str(frames), "--seed", p.seed, "--task-load", load,
               "--compare-sync", *p.threads]
    return RunJob("overlap", key, weight,
                  {"scene": scene, "objects": n, "load": float(load), "rep": rep},
                  p.overlap, p.out / "overlap" / key, options).in_group(f"overlap s{scene} n{n}")


def ideal_job(p: Plan, scene: int, n: int, load: str, threads: int, rep: int) -> "RunJob":
    """One async run (no --compare-sync) at --threads `threads`: its frame against the
    ideal for the cores it had, the CPU time of all its threads over the frame / threads
    (frames.csv's cpu_ms; study_overlap.ideal_rows)."""
    a = p.args
    frames = a.ideal_frames
    key = f"s{scene}_n{n}_load{load}_t{threads}_r{rep}"
    # The run's frames and the calibration's.
    weight = (frames + 6) * default_substeps(scene) * n * (1 + float(load))
    options = ["--scene", str(scene), "--objects", str(n), "--algo", a.overlap_algo,
               "--frames", str(frames), "--seed", p.seed, "--task-load", load,
               "--threads", str(threads)]
    return RunJob("overlap_ideal", key, weight,
                  {"scene": scene, "objects": n, "load": float(load), "threads": threads,
                   "rep": rep}, p.overlap, p.out / "overlap_ideal" / key,
                  options).in_group(f"overlap_ideal s{scene} n{n}")


def overlap_jobs(p: Plan) -> list:
    """The async frame against --sync at each point, then the frame against the ideal for
    its cores at each (scene, n, load, threads) of the --ideal-* options."""
    a = p.args
    return ([overlap_job(p, scene, n, load, rep) for scene in ints(a.overlap_scenes)
             for n in ints(a.overlap_objects) for load in names(a.overlap_loads)
             for rep in range(a.overlap_repetitions)]
            + [ideal_job(p, scene, n, load, threads, rep) for scene in ints(a.ideal_scenes)
               for n in ints(a.ideal_objects) for load in names(a.ideal_loads)
               for threads in ints(a.ideal_threads) for rep in range(a.ideal_repetitions)])


def capture_jobs(p: Plan) -> list:
    a = p.args
    return [CaptureJob(scene, p.overlap, p.out / "keyframes", a.capture_objects,
                       a.capture_keyframes) for scene in ints(a.scenes)]


PLANNERS = {"sweep": sweep_jobs, "pairs": pairs_jobs, "physics": physics_jobs,
            "latency": latency_jobs, "timeline": timeline_jobs, "overlap": overlap_jobs}


def plan_sizes(args) -> dict:
    """{experiment: how many jobs plan(args) lists for it}, counted from the options alone
    (products of list lengths and repetitions; the physics cells, a few per list item, are
    listed), so a plan too large to hold is refused before a job is made."""
    a, sizes = args, {}
    counts = {
        "sweep": lambda: len(ints(a.scenes)) * len(ints(a.objects)) * len(names(a.algos))
        * a.repetitions,
        "pairs": lambda: len(names(a.pairs_algos)),
        "physics": lambda: sum(1 + (cell[3] == "off") for cell in physics_cells(a)),
        "latency": lambda: len(ints(a.latency_scenes)) * len(names(a.latency_algos)),
        "timeline": lambda: 1,
        "overlap": lambda: len(ints(a.overlap_scenes)) * len(ints(a.overlap_objects))
        * len(names(a.overlap_loads)) * a.overlap_repetitions
        + len(ints(a.ideal_scenes)) * len(ints(a.ideal_objects)) * len(names(a.ideal_loads))
        * len(ints(a.ideal_threads)) * a.ideal_repetitions}
    for experiment in EXPERIMENTS:
        if experiment in a.experiments:
            sizes[experiment] = counts[experiment]()
    if a.capture:
        sizes["capture"] = len(ints(a.scenes))
    return sizes


def plan(args) -> list:
    """Every job of the study, in a stable order (sharding depends on it)."""
    p = Plan(args)
    jobs = [job for experiment in EXPERIMENTS if experiment in args.experiments
            for job in PLANNERS[experiment](p)]
    return jobs + (capture_jobs(p) if args.capture else [])


def shard_share(jobs: list, shard: int, shards: int) -> list:
    """Shard `shard`'s jobs (1-based, of `shards`), in plan order: whole groups (the jobs
    compared with each other run in one shard, one after another), the heaviest group first
    to the lightest-loaded shard.  It depends on the plan alone, so every shard, on every
    machine and after any resumption, computes the same split.  Only the shards given a
    group are kept (the rest are empty, the lowest first to take one): a k far above the
    number of groups costs nothing, and shards past them get no job."""
    groups = {}
    for job in jobs:
        groups.setdefault(job.group, []).append(job)
    load = []  # of shards 1..len(load); every later shard is empty
    owner = {}
    for group, members in sorted(groups.items(), key=lambda g: -sum(j.weight for j in g[1])):
        lightest = min(range(len(load)), key=load.__getitem__) if load else None
        if lightest is None or (len(load) < shards and load[lightest] > 0):
            load.append(0.0)
            lightest = len(load) - 1
        owner[group] = lightest + 1
        load[lightest] += sum(job.weight for job in members)
    return [job for job in jobs if owner[job.group] == shard]
