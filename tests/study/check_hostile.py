"""The study's scripts against hostile input: archives built here to break them, --out
folders that are not theirs to replace, signals while unpacking, shard counts past the
jobs, abbreviated options and bad arguments.  One behaviour per --case (each a ctest test
study.CASE, tests/study/CMakeLists.txt):

  unpack_replaces_only_unpacks    --from-archive refuses an --out that is ., .., a link to
                                  a parent, a file or a folder with files in it; it replaces
                                  an earlier unpack (and an empty folder) whole
  archive_gives_only_run_options  an archive's recorded argv gives no program (--overlap=
                                  its own script), no path (--report-doc), no flag that
                                  writes (--report, its abbreviation --repo); a bad value of
                                  a run option refuses the archive
  hostile_archives_refused        links out, absolute and '..' names, devices, a huge sparse
                                  member, too many members, bad JSON, non-UTF-8 text, empty
                                  lists, wrong types: one line, exit 2, --out as it was and
                                  nothing left beside it; setuid bits and group/other write
                                  bits never reach the disk
  unpack_signals_leave_whole_out  SIGINT and SIGTERM at every phase of an unpack, and
                                  SIGKILL: --out is the old unpack or the new one, whole,
                                  and no scratch folder is left behind (a killed run's is
                                  removed by the next unpack)
  archive_machine_text_plain      an archive's machine fields and start times (Markdown,
                                  HTML, newlines, a long name) reach the report as plain
                                  text, on one line
  shard_count_costs_nothing       --shard 1/1000000000 runs in a small address space; shards
                                  past the jobs get none
  no_abbreviated_options          every script of scripts/ and tests/ refuses a prefix of
                                  each of its options as an unknown option
  bad_arguments_one_line          every script answers a missing file, a bad folder, a bad
                                  value and a file not UTF-8 with one line naming it, exit
                                  2, no traceback
  unpack_stop_never_lost          SIGTERM anywhere in a 40000-member unpack: exit 143, no
                                  scratch folder, --out whole
  ignored_signals_stay_ignored    nohup's SIGHUP and an ignored SIGINT stay ignored
  archive_runs_lacking_what_the_report_reads_refused   runs' files without what the
                                  report reads, numbers beyond a double: exit 2, --out kept
  long_invocation_log_costs_linear_time   20000 invocations: a report in seconds
  study_log_of_wrong_shape_refused   a --out log not a study's: exit 2 before any run
  scripts_with_shebang_executable every #! script executable, on disk and in git
  slurm_checks_before_submitting  study_slurm.sh: bad options (a --profile or --help after
                                  --) refused, nothing submitted
  slurm_jobs_run_the_checked_words   what study_slurm.sh submits is word for word what
                                  it checked, whatever bytes --out holds, under LANG=C
  slurm_stop_says_what_was_submitted   a stop of study_slurm.sh: one line, 128 + the
                                  signal, a fresh --out removed when nothing was submitted
  memory_limit_not_bad_input      under ulimit -v: exit 1, one line, never exit 2
  stop_after_the_end_changes_nothing   a stop signal in a script's interpreter teardown:
                                  main()'s exit status, never a death by that signal
  oversized_plan_refused_quickly  a list of 20000 values, a plan of 2 million jobs: refused
                                  in one line before the plan is made, in a small address space
  unpack_keeps_a_study_run_into_its_folder   a study run into an unpack makes it a study's:
                                  the next --from-archive refuses it, the runs kept
  archive_members_of_the_kind_the_study_writes_over_refused   a commands.txt, REPORT.md,
                                  lock or marker folder, a report file: exit 2, --out kept
  unpack_stop_after_the_swap_is_no_stop   nothing runs once --out is the new unpack (its
                                  commands.txt came with it); a stop then is no stop
  study_finishes_in_an_out_of_any_bytes   an --out with a tab, a newline, a non-UTF-8 byte
  archive_csv_not_finite_refused  NaN/infinity in the latency and pairs CSVs: exit 2
  archive_frames_bounded_by_the_runs_frames   a frames.csv past its run's frames: exit 2
  archive_run_frames_not_the_plans_refused   a run's summary.json frames not those its
                                  recorded options plan: exit 2, --out kept
  archive_of_an_out_of_any_bytes_reported   the archive of a study whose --out held a
                                  tab, a newline, a byte not UTF-8, a backtick: reported,
                                  its paths shown escaped

Exit 77 (ctest's skip) when a case needs the report and this interpreter has no matplotlib.
"""
import argparse
import importlib.util
import io
import json
import os
import pathlib
import re
import resource
import shutil
import signal
import stat
import subprocess
import sys
import tarfile
import time

REPO = pathlib.Path(__file__).resolve().parents[2]
STUDY = REPO / "scripts" / "study.py"
PYTHON = sys.executable
MARKER = ".study-archive"


def check(condition: bool, message: str) -> None:
    if not condition:
        sys.exit("FAIL: " + message)


def study(*words, cwd=None, **popen) -> subprocess.CompletedProcess:
    return subprocess.run([PYTHON, str(STUDY), *map(str, words)], capture_output=True,
                          text=True, cwd=cwd, **popen)


def one_line_refusal(result, *words) -> None:
    check(result.returncode == 2, f"exit {result.returncode}, expected 2:\n{result.stderr}")
    check(result.stderr.count("\n") == 1 and "Traceback" not in result.stderr,
          f"not one line:\n{result.stderr}")
    for word in words:
        check(word in result.stderr, f"{word!r} not in {result.stderr!r}")


def invocation(argv: list) -> dict:
    return {"argv": ["scripts/study.py", *argv], "started": "2026-01-01 00:00:00",
            "load_average_at_start": 0.1, "finished": True, "seconds": 1.0, "jobs": []}


# A study of no run: the report says so; enough for the unpack and the options.
NO_RUNS = ["--quick", "--threads", "1", "--experiments", "sweep", "--scenes", "1",
           "--objects", "40", "--algos", "bf", "--frames", "2", "--figure-objects", "40"]


def add(tar: tarfile.TarFile, name: str, data: bytes = b"", **fields) -> None:
    info = tarfile.TarInfo(name)
    info.size, info.mtime = len(data), time.time()
    for key, value in fields.items():
        setattr(info, key, value)
    tar.addfile(info, io.BytesIO(data) if info.isfile() else None)


def archive(path: pathlib.Path, files: dict, log=None, extra=(), mode="w:xz") -> pathlib.Path:
    """A study archive: ./study with its invocation log (or `log`, bytes or a value) and
    `files` (name under study/ -> bytes), then `extra` (callables adding members)."""
    log = [invocation(NO_RUNS)] if log is None else log
    with tarfile.open(path, mode) as tar:
        add(tar, "./study", type=tarfile.DIRTYPE, mode=0o755)
        add(tar, "./study/study_invocations.json",
            log if isinstance(log, bytes) else json.dumps(log).encode())
        for name, data in files.items():
            add(tar, f"./study/{name}", data)
        for adding in extra:
            adding(tar)
    return path


def snapshot(folder: pathlib.Path) -> dict:
    return {p.relative_to(folder).as_posix(): p.read_bytes() if p.is_file() else None
            for p in sorted(folder.rglob("*"))} if folder.exists() else None


def scratch_left(parent: pathlib.Path) -> list:
    return [p.name for p in parent.iterdir() if ".unpack-" in p.name]


def earlier_unpack(out: pathlib.Path, which: bytes, files: int = 0) -> None:
    out.mkdir(parents=True)
    (out / MARKER).write_text("an earlier unpack\n")
    (out / "study_invocations.json").write_text(json.dumps([invocation(NO_RUNS)]))
    (out / "which").write_bytes(which)
    for i in range(files):
        (out / f"old_{i}.csv").write_text("a\n")


def case_unpack_replaces_only_unpacks(args) -> None:
    work = args.out
    tar = archive(work / "new.tar.xz", {"which": b"new"})
    home = work / "home"
    (home / "thesis").mkdir(parents=True)
    (home / "thesis" / "chapter1.tex").write_text("years of work\n")
    (home / "notes.txt").write_text("keep me\n")
    os.symlink("..", home / "up")
    os.symlink(home, home / "thesis" / "home_link")
    before = snapshot(home)
    for out, problem in [(".", "current folder"), ("..", "current folder"),
                         ("up", "current folder"), ("thesis/home_link", "current folder"),
                         ("thesis", "not an earlier unpack"), ("notes.txt", "not a folder"),
                         (str(home), "current folder")]:
        cwd = home / "thesis" if out == "thesis/home_link" else home
        out = "home_link" if out == "thesis/home_link" else out
        result = study("--from-archive", tar, "--overlap", args.overlap, "--out", out, cwd=cwd)
        one_line_refusal(result, f"--out {out}", problem)
        check(snapshot(home) == before, f"--out {out} changed the folder:\n{result.stderr}")
        check(not scratch_left(home) and not scratch_left(work), f"--out {out} left scratch")
    inside = work / "holds_archive"
    earlier_unpack(inside, b"old")
    shutil.copy(tar, inside / "a.tar.xz")
    result = study("--from-archive", inside / "a.tar.xz", "--overlap", args.overlap, "--out",
                   inside)
    one_line_refusal(result, "holds the archive")

    if importlib.util.find_spec("matplotlib") is None:
        return
    for name, prepare in [("earlier", lambda p: earlier_unpack(p, b"old", files=3)),
                          ("empty", lambda p: p.mkdir()), ("absent", lambda p: None)]:
        out = work / name
        prepare(out)
        result = study("--from-archive", tar, "--overlap", args.overlap, "--out", out)
        check(result.returncode == 0, f"--out {name}: exit {result.returncode}:\n{result.stderr}")
        check((out / "which").read_bytes() == b"new" and (out / MARKER).is_file()
              and not list(out.glob("old_*")), f"--out {name} is not the new unpack, whole")
        check(not scratch_left(work), f"--out {name}: scratch left: {scratch_left(work)}")


def case_archive_gives_only_run_options(args) -> None:
    if importlib.util.find_spec("matplotlib") is None:
        sys.exit(77)
    work = args.out
    out = work / "out" / "gpu-study"
    ran = work / "tool_ran"
    doc = work / "REPORT_not_asked.md"
    tool = f"#!/bin/sh\ntouch {ran}\nexec {args.overlap} \"$@\"\n".encode()
    hostile = NO_RUNS + [f"--overlap={out}/tool.sh", "--repo", "--report", "--report-doc", doc,
                         f"--report-doc={doc}", "--emulation", f"{out}/tool.sh", "--runs-only"]

    def executable_tool(tar):
        add(tar, "./study/tool.sh", tool, mode=0o755)
    tar = archive(work / "hostile.tar.xz", {}, log=[invocation(list(map(str, hostile)))],
                  extra=[executable_tool])
    checkout_report = (REPO / "docs" / "REPORT.md").read_bytes()
    result = study("--from-archive", tar, "--overlap", args.overlap, "--out", out)
    check(result.returncode == 0, f"exit {result.returncode}:\n{result.stderr}")
    check(not ran.exists(), "the archive's own program ran")
    check(not doc.exists(), "the archive's --report-doc was written")
    check((REPO / "docs" / "REPORT.md").read_bytes() == checkout_report,
          "the archive's --report (or --repo) rewrote docs/REPORT.md")
    check("docs/REPORT.md" not in result.stderr, "the report names docs/REPORT.md: --report "
          f"came from the archive:\n{result.stderr}")
    check("--repo" in result.stderr and "left out" in result.stderr,
          "the recorded abbreviation is not named as left out")
    check((out / "REPORT.md").exists(), "no report from the archive's runs")
    for bad, problem in [("--threads=abc", "--threads"), ("--scenes=../../x", "--scenes"),
                         ("--quick=yes", "--quick"), ("--profile=nosuch", "--profile")]:
        before = snapshot(out)
        tar = archive(work / "bad.tar.xz", {}, log=[invocation(NO_RUNS + [bad])])
        result = study("--from-archive", tar, "--overlap", args.overlap, "--out", out)
        check(result.returncode == 2 and problem in result.stderr and "Traceback" not in
              result.stderr, f"recorded {bad}: exit {result.returncode}:\n{result.stderr}")
        check(snapshot(out) == before and not scratch_left(out.parent),
              f"recorded {bad}: --out was touched")


def hostile_archives(work: pathlib.Path) -> list:
    """(name, archive, words its refusal names)."""
    made = []

    def member(name: str, **fields):
        return lambda tar: add(tar, name, b"x" if "type" not in fields else b"", **fields)

    for name, adding, words in [
            ("symlink_out", member("./study/link", type=tarfile.SYMTYPE, linkname="/etc"), "link"),
            ("symlink_up", member("./study/up", type=tarfile.SYMTYPE, linkname="../../.."), "link"),
            ("hardlink_out", member("./study/hard", type=tarfile.LNKTYPE, linkname="/etc/passwd"),
             "link"),
            ("absolute", member("/tmp/study_hostile_absolute"), "outside"),
            ("absolute_study", member("/study/x"), "outside"),
            ("dotdot", member("./study/../../study_hostile_dotdot"), "outside"),
            ("device", member("./study/null", type=tarfile.CHRTYPE, devmajor=1, devminor=3),
             "device"),
            ("fifo", member("./study/pipe", type=tarfile.FIFOTYPE), "device")]:
        made.append((name, archive(work / f"{name}.tar.xz", {}, extra=[adding]), words))
    for name, log, files, words in [
            ("bad_json_log", b"[{\"argv\": [", {}, "not JSON"),
            ("empty_log", [], {}, "names no invocation"),
            ("empty_argv", [dict(invocation([]), argv=[])], {}, "names no invocation"),
            ("log_not_list", {"argv": []}, {}, "not a list"),
            ("log_wrong_type", [dict(invocation(NO_RUNS), load_average_at_start="high")], {},
             "study_invocations.json"),
            ("log_finished_no_seconds", [dict(invocation(NO_RUNS), seconds=None)], {},
             "seconds"),
            ("log_newline", [invocation(NO_RUNS + ["--seed\n`rm -rf ~`"])], {}, "word"),
            ("non_utf8_log", b"[\xff\xfe]", {}, "not UTF-8"),
            ("non_utf8_csv", None, {"sweep/s1_n40_bf_r0/frames.csv": b"frame\n\xff\n"},
             "not UTF-8"),
            ("bad_json_summary", None, {"sweep/s1_n40_bf_r0/summary.json": b"{"}, "not JSON"),
            ("deep_json", None, {"deep.json": b"[" * 200000 + b"]" * 200000}, "nested too deep"),
            ("nan_load", b'[{"argv": ["study.py"], "started": "x", "load_average_at_start": NaN}]',
             {}, "NaN is no number"),
            ("summary_no_machine", None, {"sweep/s1_n40_bf_r0/summary.json": b"{}"}, "machine"),
            ("machine_not_text", None, {"sweep/s1_n40_bf_r0/summary.json": json.dumps(
                {"machine": {"cpu": 5, "gpu": "", "compiler": "", "build_type": "",
                             "git_commit": "", "hardware_threads": 2}}).encode()}, "machine")]:
        made.append((name, archive(work / f"{name}.tar.xz", files, log=log), words))
    sparse = work / "sparse_src" / "study"
    sparse.mkdir(parents=True)
    (sparse / "study_invocations.json").write_text(json.dumps([invocation(NO_RUNS)]))
    with open(sparse / "huge.csv", "wb") as f:
        f.truncate(3 * 1024 ** 3)
    subprocess.run(["tar", "-C", str(sparse.parent), "-cSJf", str(work / "sparse.tar.xz"),
                    "./study"], check=True)
    shutil.rmtree(sparse.parent)
    check((work / "sparse.tar.xz").stat().st_size < 1024 ** 2, "the sparse archive is not small")
    made.append(("huge_sparse", work / "sparse.tar.xz", "MiB"))

    def many(tar):
        for i in range(50_001):
            add(tar, f"./study/m/{i}")
    made.append(("too_many_members", archive(work / "many.tar.gz", {}, extra=[many],
                                             mode="w:gz"), "members"))
    (work / "not_tar.tar.xz").write_bytes(b"not a tar file at all")
    made.append(("not_tar", work / "not_tar.tar.xz", "cannot be read"))
    with tarfile.open(work / "nostudy.tar.xz", "w:xz") as tar:
        add(tar, "./other/file", b"x")
    made.append(("no_study", work / "nostudy.tar.xz", "no ./study"))
    return made


def case_hostile_archives_refused(args) -> None:
    work = args.out
    out = work / "out"
    earlier_unpack(out, b"old", files=2)
    before = snapshot(out)
    for name, tar, words in hostile_archives(work):
        result = study("--from-archive", tar, "--overlap", args.overlap, "--out", out)
        one_line_refusal(result, f"--from-archive {tar}", words)
        check(snapshot(out) == before, f"{name}: --out changed")
        check(not scratch_left(work), f"{name}: left {scratch_left(work)}")
        check(not pathlib.Path("/tmp/study_hostile_absolute").exists()
              and not (work.parent / "study_hostile_dotdot").exists(),
              f"{name}: a member was written outside")
    # Modes: setuid, setgid, sticky and group/other write never reach the disk, nor the
    # archive's owner (a uid of no one here: as root, tarfile alone would take it).
    if importlib.util.find_spec("matplotlib") is None:
        return
    modes = {"suid": 0o6755, "world": 0o777, "plain": 0o600, "sticky_dir/f": 0o1777}
    tar = archive(work / "modes.tar.xz", {}, extra=[
        lambda t: add(t, "./study/sticky_dir", type=tarfile.DIRTYPE, mode=0o1777, uid=4321,
                      gid=4321, uname="", gname="")] + [
        (lambda n, m: lambda t: add(t, f"./study/{n}", b"#!/bin/sh\n", mode=m, uid=4321,
                                    gid=4321, uname="", gname=""))(n, m)
        for n, m in modes.items()])
    result = study("--from-archive", tar, "--overlap", args.overlap, "--out", out)
    check(result.returncode == 0, f"the modes archive: exit {result.returncode}:\n{result.stderr}")
    for name in list(modes) + ["sticky_dir"]:
        st = (out / name).stat()
        check(not st.st_mode & (stat.S_ISUID | stat.S_ISGID | stat.S_ISVTX | 0o022),
              f"{name}: mode {oct(st.st_mode)} kept a setuid, setgid, sticky or write bit")
        check(st.st_uid == os.getuid(), f"{name}: owned by {st.st_uid}, not by this user")


def big_archive(path: pathlib.Path, which: bytes, files: int) -> pathlib.Path:
    return archive(path, {"which": which, **{f"{which.decode()}_{i}.csv": b"x,y\n" * 64
                                               for i in range(files)}})


def whole(out: pathlib.Path, counts: dict) -> str:
    """'old' or 'new' when --out is that unpack, whole (counts: its number of files);
    otherwise what is wrong."""
    which = (out / "which").read_bytes().decode() if (out / "which").is_file() else None
    if which not in counts:
        return f"no which file ({sorted(p.name for p in out.iterdir()) if out.exists() else 'no --out'})"
    found = {side: len(list(out.glob(f"{side}_*.csv"))) for side in counts}
    if found != {side: counts[side] if side == which else 0 for side in counts} or \
            not (out / MARKER).is_file():
        return f"{which} with {found} files"
    return which


def replaced(out: pathlib.Path) -> bool:
    try:
        return (out / "which").read_bytes() == b"new"
    except OSError:
        return False


def phase_seen(parent: pathlib.Path, phase: str) -> bool:
    scratch = [p for p in parent.iterdir() if ".unpack-" in p.name]
    if phase == "extracting":
        return any((p / "study").exists() for p in scratch)
    if phase == "checked":
        return any((p / "study" / MARKER).exists() for p in scratch)
    if phase == "swapped":
        return any((p / "old").exists() for p in scratch)
    return True


def case_unpack_signals_leave_whole_out(args) -> None:
    work = args.out
    files = 300
    new = big_archive(work / "new.tar.xz", b"new", files)
    old_files = files // 2
    seen = {}
    for signum in (signal.SIGINT, signal.SIGTERM):
        for phase in ("start", "extracting", "checked", "swapped", "0.3", "0.8"):
            out = work / f"out_{signum}_{phase}"
            earlier_unpack(out, b"old", files=old_files)
            process = subprocess.Popen([PYTHON, str(STUDY), "--from-archive", str(new),
                                        "--overlap", args.overlap, "--out", str(out)],
                                       stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
            give_up = time.monotonic() + 60
            if phase[0].isdigit():
                time.sleep(float(phase))
            else:
                while (process.poll() is None and not phase_seen(work, phase)
                       and not replaced(out) and time.monotonic() < give_up):
                    time.sleep(0.001)
            process.send_signal(signum)
            _, stderr = process.communicate()
            state = whole(out, {"old": old_files, "new": files})
            check(state in ("old", "new"), f"{signal.Signals(signum).name} at {phase}: --out is "
                  f"{state}:\n{stderr.decode()}")
            check(not scratch_left(work), f"{signal.Signals(signum).name} at {phase}: left "
                  f"{scratch_left(work)}")
            seen[state] = seen.get(state, 0) + 1
            shutil.rmtree(out)
    check(set(seen) == {"old", "new"}, f"the signals never met both sides of the swap: {seen}")
    # SIGKILL while unpacking leaves its scratch folder; the next unpack beside it removes it.
    out = work / "out_killed"
    earlier_unpack(out, b"old")
    process = subprocess.Popen([PYTHON, str(STUDY), "--from-archive", str(new), "--overlap",
                                args.overlap, "--out", str(out)], stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL)
    while process.poll() is None and not phase_seen(work, "extracting"):
        time.sleep(0.001)
    process.kill()
    process.wait()
    check(whole(out, {"old": 0, "new": files}) == "old", "SIGKILL while unpacking changed --out")
    check(scratch_left(work), "SIGKILL left no scratch folder: the next check proves nothing")
    small = archive(work / "small.tar.xz", {"which": b"new"})
    result = study("--from-archive", small, "--overlap", args.overlap, "--out", out)
    check(not scratch_left(work), f"the next unpack left {scratch_left(work)}:\n{result.stderr}")


def case_archive_machine_text_plain(args) -> None:
    if importlib.util.find_spec("matplotlib") is None:
        sys.exit(77)
    work = args.out
    runs = work / "runs"
    made = study("--overlap", args.overlap, "--emulation", work / "none", "--out", runs,
                 "--runs-only", *NO_RUNS)
    check(made.returncode == 0, f"the runs: exit {made.returncode}:\n{made.stderr}")
    hostile = {"cpu": "<script>alert(1)</script> **bold** [link](http://x) | cell",
               "gpu": "none\n# A heading\n<img src=x onerror=alert(1)>",
               "compiler": "`code` $math$ & co", "build_type": "Release" + "x" * 5000,
               "git_commit": "abc1234"}
    for summary in runs.rglob("summary.json"):
        data = json.loads(summary.read_text())
        data["machine"].update(hostile)
        summary.write_text(json.dumps(data))
    log = json.loads((runs / "study_invocations.json").read_text())
    log[0]["started"] = "<b>2026</b> *soon*"
    (runs / "study_invocations.json").write_text(json.dumps(log))
    tar = work / "machine.tar.xz"
    with tarfile.open(tar, "w:xz") as t:
        t.add(runs, arcname="./study")
    out = work / "here"
    result = study("--from-archive", tar, "--overlap", args.overlap, "--out", out)
    check(result.returncode == 0, f"exit {result.returncode}:\n{result.stderr}")
    report = (out / "REPORT.md").read_text()
    unescaped = re.sub(r"\\.", "", report)  # what Markdown reads as markup
    for raw in ("<script>", "**bold**", "[link](", "<img", "`code`", "$math$", " & co",
                "x" * 300, "<b>", "*soon*"):
        check(raw not in unescaped, f"the report holds {raw!r} raw")
    check("\n# A heading" not in report, "the machine's newline reached the report")
    check(any("\\<script\\>" in line and "A heading" in line for line in report.splitlines()),
          "the machine's text is not in the report, escaped, on one line")


def case_shard_count_costs_nothing(args) -> None:
    work = args.out

    def small_address_space():
        resource.setrlimit(resource.RLIMIT_AS, (1024 ** 3, 1024 ** 3))
    for shards in ("100000000", "1000000000"):
        result = subprocess.run(
            [PYTHON, str(STUDY), "--overlap", args.overlap, "--emulation", str(work / "none"),
             "--out", str(work / "out"), "--runs-only", *NO_RUNS, "--shard", f"{shards}/{shards}"],
            capture_output=True, text=True, preexec_fn=small_address_space)
        check(result.returncode == 0 and f"shard {shards}/{shards}: 0 of" in result.stderr,
              f"--shard {shards}/{shards} under 1 GiB: exit {result.returncode}:\n{result.stderr}")
    for bad in ("0/3", "4/3", "1/0", "1/x", " 1/2", "1/2/3", "1" * 5000 + "/2"):
        result = study("--overlap", args.overlap, "--out", work / "out", "--shard", bad)
        one_line_refusal(result, "--shard")


def scripts_with_parsers() -> list:
    found = []
    for path in sorted([*REPO.glob("scripts/**/*.py"), *REPO.glob("tests/**/*.py")]):
        text = path.read_text()
        if "__main__" in text and re.search(r"\bParser\(|ArgumentParser\(|arguments_or_skip\(",
                                            text) and path.name != "script_cli.py":
            found.append(path)
    return found


def required_values(help_text: str, options: set) -> list:
    """Values for the options a test script requires, so that argparse reaches the
    unknown one (a required option missing is reported first)."""
    values = {"--overlap": "/bin/true", "--driver": "/bin/true", "--input": "x",
              "--out": "/nonexistent/abbreviation-check"}
    given = [word for option, value in values.items() if option in options
             for word in (option, value)]
    cases = re.search(r"--case \{([^}]*)\}", help_text)
    return given + (["--case", cases[1].split(",")[0]] if cases else [])


def case_no_abbreviated_options(args) -> None:
    scripts = scripts_with_parsers()
    check(len(scripts) >= 10, f"found only {len(scripts)} scripts with options")
    for script in scripts:
        text = script.read_text()
        for match in re.finditer(r"ArgumentParser\(([^)]*)\)", text):
            check("allow_abbrev=False" in match[1], f"{script}: an ArgumentParser abbreviates")
        shown = subprocess.run([PYTHON, str(script), "--help"], capture_output=True, text=True)
        if shown.returncode == 77:  # skips before it reads an option (check_slurm without
            continue                # Slurm); its parser is check_quick's, checked with it
        check(shown.returncode == 0, f"{script} --help: exit {shown.returncode}:\n{shown.stderr}")
        options = set(re.findall(r"^ {2}(?:-\w, )?(--[a-z][a-z0-9-]+)", shown.stdout,
                                 re.MULTILINE)) - {"--help"}
        given = required_values(shown.stdout, options)
        for option in sorted(options | {"--help"}):
            prefix = option[:-1]
            if prefix in options or len(prefix) < 3:
                continue
            result = subprocess.run([PYTHON, str(script), *given, prefix, "/"],
                                    capture_output=True, text=True, timeout=60)
            check(result.returncode == 2 and f"unrecognized arguments: {prefix}" in result.stderr,
                  f"{script.name} {prefix}: exit {result.returncode}, taken as {option}?\n"
                  f"{result.stderr}")


def case_study_never_writes_over_a_users_folder(args) -> None:
    """A plain study (runs, --runs-only, --no-runs) refuses an --out that holds files and
    is not a study's folder, however spelled (a missing folder then `..`, a link then
    `..`), and leaves it as it was; an empty or earlier study's folder is taken
    (study_out_folder.foreign_folder_problem)."""
    work = args.out
    users = work / "docs"
    (users / "notes").mkdir(parents=True)
    (users / "REPORT.md").write_text("a report written by hand\n")
    (users / "notes" / "thesis.txt").write_text("years of work\n")
    (work / "elsewhere" / "deep").mkdir(parents=True)
    os.symlink(work / "elsewhere" / "deep", users / "notes" / "link")
    (work / "elsewhere" / "deep" / "mine.txt").write_text("mine\n")
    before = snapshot(users)
    spellings = ((users, None), (".", users), ("missing/..", users),
                 (users / "missing" / ".." / "notes" / "..", None),
                 (users / "notes" / "link" / "..", None))
    for mode in ([], ["--runs-only"], ["--no-runs"], ["--no-runs", "--report",
                                                       "--report-doc", users / "REPORT.md"]):
        for out, cwd in spellings:
            result = study("--overlap", args.overlap, *NO_RUNS, *mode, "--out", out, cwd=cwd)
            one_line_refusal(result, "--out", "not a study's folder")
            check(snapshot(users) == before, f"{mode} --out {out}: changed {users}")
    empty = work / "empty"
    empty.mkdir()
    for again in ("first", "second"):
        result = study("--overlap", args.overlap, *NO_RUNS, "--no-runs", "--out", empty)
        check(result.returncode == 0, f"{again} --no-runs into an empty folder: exit "
              f"{result.returncode}:\n{result.stderr}")
        check((empty / "REPORT.md").is_file(), f"{again}: no REPORT.md in {empty}")


def endless_thread_scaling(args) -> tuple:
    """A thread_scaling.py command whose one run lasts until it is stopped, with its
    own scratch folder as TMPDIR: (command, environment, scratch folder, work folder)."""
    work = args.out
    scratch = work / "tmp"
    scratch.mkdir()
    env = {**os.environ, "TMPDIR": str(scratch)}
    script = [PYTHON, str(REPO / "scripts" / "thread_scaling.py"), "--config",
              f"a={args.overlap}", "--common", "--objects 100 --frames 1000000 --no-tasks",
              "--out", str(work / "t.csv")]
    return script, env, scratch, work


def case_stop_signals_reach_the_runs(args) -> None:
    """SIGTERM or SIGHUP to a script (not its group) while it runs `overlap run` stops
    the run too: the script waits for it, removes its scratch folder and exits 128 + the
    signal with one line; timeout(1), which signals twice, stops it as cleanly."""
    script, env, scratch, work = endless_thread_scaling(args)
    for signum in (signal.SIGTERM, signal.SIGHUP, signal.SIGINT):
        process = subprocess.Popen(script, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                   env=env, text=True)
        children = pathlib.Path(f"/proc/{process.pid}/task/{process.pid}/children")
        give_up = time.monotonic() + 60
        runs = []
        while not runs and process.poll() is None and time.monotonic() < give_up:
            runs = children.read_text().split() if children.exists() else []
            time.sleep(0.05)
        if not runs:
            process.kill()
            check(False, f"thread_scaling.py started no run:\n{process.communicate()[1]}")
        time.sleep(1.5)  # into the run's frames
        process.send_signal(signum)
        _, stderr = process.communicate(timeout=60)
        name = signal.Signals(signum).name
        check(process.returncode == 128 + signum and stderr.count("\n") == 1 and
              f"stopped by {name}" in stderr,
              f"{name}: exit {process.returncode}:\n{stderr}")
        check(not any(pathlib.Path(f"/proc/{run}").exists() and
                      pathlib.Path(f"/proc/{run}/stat").read_text().split()[2] != "Z"
                      for run in runs), f"{name}: its overlap run {runs} still runs")
        check(not any(scratch.iterdir()), f"{name}: left {sorted(scratch.iterdir())}")
        check(not (work / "t.csv").exists(), f"{name}: wrote its CSV")
    result = subprocess.run(["timeout", "3", *script], capture_output=True, text=True,
                            env=env, timeout=60)
    check(result.returncode == 124 and "stopped by SIGTERM" in result.stderr,
          f"timeout: exit {result.returncode}:\n{result.stderr}")
    check(not any(scratch.iterdir()), f"timeout: left {sorted(scratch.iterdir())}")


def case_unpack_stop_never_lost(args) -> None:
    """SIGTERM at any moment of a large unpack (40000 members, as root too: tarfile's owner
    lookup caught KeyError around the handler's raise) always ends in exit 143, one line,
    --out whole (old or new) and no scratch folder: the stop is sticky."""
    work = args.out
    many = work / "many.tar.xz"
    with tarfile.open(many, "w:xz") as tar:
        add(tar, "./study", type=tarfile.DIRTYPE, mode=0o755)
        add(tar, "./study/study_invocations.json", json.dumps([invocation(NO_RUNS)]).encode())
        add(tar, "./study/which", b"new")
        for i in range(40_000):
            add(tar, f"./study/pad/{i}.dat", b"x", uname="nosuchuser", gname="nosuchgroup")
    out = work / "out"
    started = time.monotonic()
    timed = study("--from-archive", many, "--overlap", args.overlap, "--out", out)
    took = time.monotonic() - started
    check(timed.returncode in (0, 1), f"the large unpack: exit {timed.returncode}:\n{timed.stderr}")
    for fraction in (0.05, 0.2, 0.35, 0.5, 0.7, 0.9):
        shutil.rmtree(out, ignore_errors=True)
        earlier_unpack(out, b"old")
        process = subprocess.Popen([PYTHON, str(STUDY), "--from-archive", str(many),
                                    "--overlap", args.overlap, "--out", str(out)],
                                   stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        time.sleep(took * fraction)
        finished_first = process.poll() is not None
        process.send_signal(signal.SIGTERM)
        _, stderr = process.communicate(timeout=120)
        # Faster than the timed run (the load changed): it had finished before
        # the signal came, or had published everything, and says so.
        if process.returncode == 0 and (finished_first or "came after" in stderr):
            continue
        check(process.returncode == 128 + signal.SIGTERM and stderr.count("\n") == 1 and
              "stopped by SIGTERM" in stderr,
              f"SIGTERM at {fraction:.0%} of the unpack: exit {process.returncode}:\n{stderr}")
        check(not scratch_left(work), f"SIGTERM at {fraction:.0%}: left {scratch_left(work)}")
        which = (out / "which").read_bytes() if (out / "which").is_file() else None
        check(which in (b"old", b"new"), f"SIGTERM at {fraction:.0%}: --out is not whole")


def case_ignored_signals_stay_ignored(args) -> None:
    """A signal ignored when a script starts (nohup's SIGHUP, `trap '' INT`) stays ignored:
    the script runs on, and still stops on a signal it was not told to ignore."""
    script, env, scratch, work = endless_thread_scaling(args)

    def ignoring_int():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    for how, command, ignored, preexec in [
            ("nohup", ["nohup", *script], signal.SIGHUP, None),
            ("trap '' INT", script, signal.SIGINT, ignoring_int)]:
        process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                   env=env, text=True, preexec_fn=preexec, cwd=work)
        time.sleep(1.5)
        if process.poll() is not None:
            check(False, f"{how}: ended before the signal:\n{process.communicate()[1]}")
        process.send_signal(ignored)
        time.sleep(1.0)
        if process.poll() is not None:
            check(False, f"{how}: {signal.Signals(ignored).name}, ignored at start, stopped it "
                  f"(exit {process.returncode}):\n{process.communicate()[1]}")
        process.send_signal(signal.SIGTERM)
        _, stderr = process.communicate(timeout=60)
        check(process.returncode == 128 + signal.SIGTERM and "stopped by SIGTERM" in stderr,
              f"{how}: SIGTERM after the ignored signal: exit {process.returncode}:\n{stderr}")
        check(not any(scratch.iterdir()), f"{how}: left {sorted(scratch.iterdir())}")
    result = subprocess.run([PYTHON, "-c", "import signal, sys; sys.path.insert(0, sys.argv[1]); "
                             "import script_cli; script_cli.stop_on_signals(); "
                             "print(signal.getsignal(signal.SIGHUP) == signal.SIG_IGN, "
                             "signal.getsignal(signal.SIGTERM) == script_cli._on_stop)",
                             str(REPO / "scripts")], capture_output=True, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGHUP, signal.SIG_IGN))
    check(result.stdout.split() == ["True", "True"],
          f"stop_on_signals over an ignored SIGHUP: {result.stdout!r} {result.stderr!r}")


def real_runs(args, folder: pathlib.Path) -> pathlib.Path:
    made = study("--overlap", args.overlap, "--emulation", args.out / "none", "--out", folder,
                 "--runs-only", *NO_RUNS)
    check(made.returncode == 0, f"the runs: exit {made.returncode}:\n{made.stderr}")
    (folder / ".study.lock").unlink(missing_ok=True)
    return folder


RUN = "sweep/s1_n40_bf_r0"  # real_runs' one run, which the archive cases change


def runs_and_an_unpack(args, files: int = 0) -> tuple:
    """The archive cases' start (they need matplotlib, else skip): real runs in
    --out/runs, an earlier unpack at --out/out and its snapshot: (work, runs, out, before)."""
    if importlib.util.find_spec("matplotlib") is None:
        sys.exit(77)
    work = args.out
    runs = real_runs(args, work / "runs")
    out = work / "out"
    earlier_unpack(out, b"old", files=files)
    return work, runs, out, snapshot(out)


def archive_of(runs: pathlib.Path, path: pathlib.Path, change) -> pathlib.Path:
    copy = path.parent / (path.name + ".src")
    shutil.rmtree(copy, ignore_errors=True)
    shutil.copytree(runs, copy)
    change(copy)
    with tarfile.open(path, "w:xz") as tar:
        tar.add(copy, arcname="./study")
    shutil.rmtree(copy)
    return path


def edit_json(path: pathlib.Path, edit) -> None:
    data = json.loads(path.read_text())
    edit(data)
    path.write_text(json.dumps(data))


def case_archive_runs_lacking_what_the_report_reads_refused(args) -> None:
    """An archive whose runs' files lack what the report reads (an empty frames.csv, a
    column missing, a summary.json without parameters or with parameters not an object, a
    key of them missing), or with a number beyond a double (1e999, -1e400), NaN or an
    infinity in a frames.csv as in the JSON, a negative load average or duration in the log:
    one line naming the file (or its experiment) and the problem, exit 2, --out as it was,
    no scratch."""
    work, runs, out, before = runs_and_an_unpack(args, files=2)
    run = RUN

    def frames(text):
        return lambda f: (f / run / "frames.csv").write_text(text)

    def summary(edit):
        return lambda f: edit_json(f / run / "summary.json", edit)

    def log(edit):
        return lambda f: edit_json(f / "study_invocations.json", edit)

    def first_cell(text):  # the first frame's update_ms
        def change(f):
            lines = (f / run / "frames.csv").read_text().splitlines(keepends=True)
            column = lines[0].split(",").index("update_ms")
            cells = lines[1].split(",")
            cells[column] = text
            lines[1] = ",".join(cells)
            (f / run / "frames.csv").write_text("".join(lines))
        return change

    def raw_log(text):
        return lambda f: (f / "study_invocations.json").write_text(text)
    good_log = json.loads((runs / "study_invocations.json").read_text())
    for name, change, words in [
            ("frames_empty", frames(""), [f"study/{run}/frames.csv", "empty"]),
            ("frames_no_rows", frames("frame,update_ms,broadphase_ms,total_ms\n"),
             [f"study/{run}/frames.csv", "no frame row"]),
            ("frames_columns_missing", frames("frame,total_ms\nx,y\n"),
             [f"study/{run}/frames.csv", "update_ms"]),
            ("summary_no_parameters", summary(lambda d: d.pop("parameters")),
             [f"study/{run}/summary.json", "parameters"]),
            ("parameters_not_object", summary(lambda d: d.update(parameters=5)),
             [f"study/{run}/summary.json", "not an object"]),
            ("parameters_no_scene", summary(lambda d: d["parameters"].pop("scene")),
             ["study/sweep", "do not hold what the report reads", "scene"]),
            ("timings_not_object", summary(lambda d: d.update(timings_ms=[])),
             [f"study/{run}/summary.json", "timings_ms"]),
            ("load_1e999", raw_log(json.dumps(good_log).replace(
                '"load_average_at_start": ', '"load_average_at_start": 1e999, "x": ')),
             ["study_invocations.json", "beyond a double"]),
            ("seconds_minus_1e400", raw_log(json.dumps(good_log).replace(
                '"seconds": ', '"seconds": -1e400, "y": ')),
             ["study_invocations.json", "beyond a double"]),
            ("frames_1e999", first_cell("1e999"), [f"study/{run}/frames.csv", "update_ms",
                                                   "'1e999' is no number a study writes"]),
            ("frames_nan", first_cell("nan"), [f"study/{run}/frames.csv", "'nan' is no"]),
            # float() overflows without an exponent of three digits too.
            ("frames_long_mantissa", first_cell("1" + "0" * 301 + "e99"),
             [f"study/{run}/frames.csv", "is no number a study writes"]),
            ("frames_arabic_indic_exponent", first_cell("1e\u0664\u0660\u0660"),
             [f"study/{run}/frames.csv", "is no number a study writes"]),
            ("seconds_400_digits", raw_log(json.dumps(good_log).replace(
                '"seconds": ', '"seconds": 1' + '0' * 400 + ', "w": ')),
             ["study_invocations.json", "beyond a double"]),
            ("frames_minus_inf", first_cell("-Infinity"), [f"study/{run}/frames.csv",
                                                          "'-Infinity' is no"]),
            # float() takes PEP 515's underscores: an infinity without a hint of one.
            ("frames_underscore_exponent", first_cell("1e9_9_9"),
             [f"study/{run}/frames.csv", "'1e9_9_9' is no number a study writes"]),
            ("frames_underscore_digits", first_cell("9_" * 400 + "9"),
             [f"study/{run}/frames.csv", "is no number a study writes"]),
            ("load_negative", log(lambda d: d[0].update(load_average_at_start=-5)),
             ["study_invocations.json[0].load_average_at_start: -5 is negative"]),
            ("seconds_negative", log(lambda d: d[0].update(seconds=-1)),
             ["study_invocations.json[0].seconds: -1 is negative"]),
            ("summary_1e999", lambda f: (f / run / "summary.json").write_text(
                (f / run / "summary.json").read_text().replace('"wall_seconds": ',
                                                               '"wall_seconds": 1e999, "z": ')),
             [f"study/{run}/summary.json", "beyond a double"])]:
        tar = archive_of(runs, work / f"{name}.tar.xz", change)
        result = study("--from-archive", tar, "--overlap", args.overlap, "--out", out)
        one_line_refusal(result, f"--from-archive {tar}", *words)
        check(snapshot(out) == before, f"{name}: --out was touched:\n{result.stderr}")
        check(not scratch_left(work), f"{name}: left {scratch_left(work)}")


def case_unpack_keeps_a_study_run_into_its_folder(args) -> None:
    """A study that runs into an unpack (more --objects beside the archive's runs) makes it
    a study's folder: the next --from-archive into it is refused (one line, exit 2) and the
    runs, their log entry and the report stay; so is an unpack whose log changed since it
    was made while its marker stayed (a study of an older script ran into it)."""
    if importlib.util.find_spec("matplotlib") is None:
        sys.exit(77)
    work = args.out
    runs = real_runs(args, work / "runs")
    tar = archive_of(runs, work / "a.tar.xz", lambda f: None)
    for name in ("ran_into", "log_changed"):
        out = work / name
        result = study("--from-archive", tar, "--overlap", args.overlap, "--out", out)
        check(result.returncode == 0 and (out / MARKER).is_file(),
              f"{name}: the unpack: exit {result.returncode}:\n{result.stderr}")
        if name == "ran_into":
            more = study("--overlap", args.overlap, "--emulation", work / "none", *NO_RUNS,
                         "--objects", "40,60", "--out", out)
            check(more.returncode == 0 and (out / "sweep" / "s1_n60_bf_r0").is_dir(),
                  f"the study into the unpack: exit {more.returncode}:\n{more.stderr}")
        else:
            edit_json(out / "study_invocations.json", lambda d: d.append(d[0]))
        before = snapshot(out)
        result = study("--from-archive", tar, "--overlap", args.overlap, "--out", out)
        one_line_refusal(result, f"--out {out}")
        check(snapshot(out) == before, f"{name}: the second unpack changed --out")
        check(not scratch_left(work), f"{name}: left {scratch_left(work)}")


def case_archive_members_of_the_kind_the_study_writes_over_refused(args) -> None:
    """An archive whose commands.txt, REPORT.md, .study.lock or .study-archive is a folder,
    whose report is a file or holds a folder: one line naming the archive and the member,
    exit 2, before --out is touched (never --out replaced and then a failure, never a
    scratch path named, never exit 1)."""
    work = args.out
    out = work / "out"
    earlier_unpack(out, b"old", files=2)
    before = snapshot(out)

    def folder(name):
        return lambda tar: add(tar, f"./study/{name}", type=tarfile.DIRTYPE, mode=0o755)
    for name, extra, words in [
            ("commands_folder", [folder("commands.txt")], "study/commands.txt is a folder"),
            ("report_md_folder", [folder("REPORT.md")], "study/REPORT.md is a folder"),
            ("lock_folder", [folder(".study.lock")], "study/.study.lock is a folder"),
            ("marker_folder", [folder(MARKER)], f"study/{MARKER} is a folder"),
            ("report_file", [lambda tar: add(tar, "./study/report", b"x")],
             "study/report is a file"),
            ("report_inner_folder", [folder("report"), folder("report/sweep.csv")],
             "study/report/sweep.csv is a folder")]:
        tar = archive(work / f"{name}.tar.xz", {}, extra=extra)
        result = study("--from-archive", tar, "--overlap", args.overlap, "--out", out)
        one_line_refusal(result, f"--from-archive {tar}: {words}")
        check(snapshot(out) == before, f"{name}: --out changed")
        check(not scratch_left(work), f"{name}: left {scratch_left(work)}")


def case_unpack_stop_after_the_swap_is_no_stop(args) -> None:
    """Once --out is the new unpack nothing is left to do that a stop could cut short:
    commands.txt (naming --out's own paths) came with it, no overlap runs after the swap,
    and a stop from there on is said to come after (exit 0); a stop that is said (143)
    leaves --out the old unpack.  An --overlap that sleeps when asked its broadphases
    after the swap holds that moment open, as a slow machine would."""
    if importlib.util.find_spec("matplotlib") is None:
        sys.exit(77)
    work = args.out
    runs = real_runs(args, work / "runs")
    tar = archive_of(runs, work / "a.tar.xz", lambda f: None)
    out = work / "out"
    slowing = work / "slowing"
    slow = work / "slow_overlap"
    slow.write_text("#!/bin/sh\n"
                    f"if [ \"$1\" = --list-algos ] && [ ! -e '{out}/old.txt' ] && "
                    f"[ -e '{out}/{MARKER}' ]; then touch '{slowing}'; sleep 3; fi\n"
                    f"exec '{args.overlap}' \"$@\"\n")
    slow.chmod(0o755)
    earlier_unpack(out, b"old")
    (out / "old.txt").write_text("the old unpack\n")
    process = subprocess.Popen([PYTHON, str(STUDY), "--from-archive", str(tar), "--overlap",
                                str(slow), "--out", str(out)], stdout=subprocess.DEVNULL,
                               stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while (process.poll() is None and not slowing.exists() and not
           (not (out / "old.txt").exists() and (out / MARKER).exists())
           and time.monotonic() < deadline):
        time.sleep(0.01)
    if slowing.exists() or process.poll() is None:
        time.sleep(0.2)
        process.send_signal(signal.SIGTERM)
    _, stderr = process.communicate(timeout=60)
    new = not (out / "old.txt").exists()
    check(not slowing.exists(), f"overlap ran after --out was replaced:\n{stderr}")
    check(process.returncode == 0 or (process.returncode == 128 + signal.SIGTERM and not new),
          f"exit {process.returncode} with --out {'the new' if new else 'the old'} unpack:\n"
          f"{stderr}")
    if new:
        commands = (out / "commands.txt").read_text()
        check(f"--out {out}/sweep/" in commands and f"{runs}/" not in commands,
              f"commands.txt is not --out's own: {commands[:300]!r}")


def case_study_finishes_in_an_out_of_any_bytes(args) -> None:
    """An --out whose name holds a tab, a newline or a byte that is not UTF-8 is one a study
    finishes in: its runs, its log (this machine's own words, never refused as an
    archive's) and its report, exit 0, then a second study adds a run there, exit 0; its
    commands.txt and REPORT.md show the name escaped, one command a line."""
    if importlib.util.find_spec("matplotlib") is None:
        sys.exit(77)
    for name in (b"tab\tout", b"new\nline", b"byte\xffout"):
        out = os.fsencode(str(args.out)) + b"/" + name
        for objects, run in (("40", b"s1_n40_bf_r0"), ("40,60", b"s1_n60_bf_r0")):
            result = subprocess.run([PYTHON, str(STUDY), "--overlap", args.overlap,
                                     "--emulation", str(args.out / "none"), *NO_RUNS,
                                     "--objects", objects, "--out", out], capture_output=True,
                                    text=True, errors="replace")
            check(result.returncode == 0 and os.path.isdir(out + b"/sweep/" + run) and
                  os.path.isfile(out + b"/REPORT.md"), f"--out {name!r} --objects {objects}: "
                  f"exit {result.returncode}:\n{result.stderr}")
            check(all(line.startswith(("study", "[")) for line in result.stderr.splitlines()),
                  f"--out {name!r}: a line broken by the name:\n{result.stderr}")
            shown_lines_whole(pathlib.Path(os.fsdecode(out)), f"--out {name!r}")


def shown_lines_whole(folder: pathlib.Path, where: str) -> None:
    """FOLDER's commands.txt is one `overlap` command a line and every line of its
    REPORT.md that shows a command holds whole code spans (an even count of backticks)."""
    for line in (folder / "commands.txt").read_text(errors="replace").splitlines():
        check(line.startswith("/") and " run " in line or " latency " in line,
              f"{where}: a commands.txt line broken: {line!r}")
    for line in (folder / "REPORT.md").read_text(errors="replace").splitlines():
        check(line.startswith("```") or line.count("`") % 2 == 0,
              f"{where}: a REPORT.md code span broken: {line!r}")


def case_archive_of_an_out_of_any_bytes_reported(args) -> None:
    """The archive of a study whose --out held a tab, a newline, a byte not UTF-8 or a
    backtick (as gpu_check.sh returns one when its OUT does) is reported, exit 0: the
    study's own recorded paths are accepted, shown escaped ($'...') in REPORT.md and
    commands.txt, one line each; a recorded --overlap of those bytes is shown so too and
    never run."""
    if importlib.util.find_spec("matplotlib") is None:
        sys.exit(77)
    work = args.out
    for name in (b"tab\tout", b"new\nline", b"byte\xffout", b"back`tick"):
        out = os.fsencode(str(work)) + b"/" + name
        made = subprocess.run([PYTHON, str(STUDY), "--overlap", args.overlap, "--emulation",
                               str(work / "none"), "--runs-only", *NO_RUNS, "--out", out],
                              capture_output=True, text=True, errors="replace")
        check(made.returncode == 0, f"--out {name!r}: exit {made.returncode}:\n{made.stderr}")
        runs = pathlib.Path(os.fsdecode(out))
        (runs / ".study.lock").unlink()
        tar = archive_of(runs, work / "any.tar.xz", lambda f: None)
        unpacked = work / "unpacked"
        result = study("--from-archive", tar, "--overlap", args.overlap, "--out", unpacked)
        check(result.returncode == 0 and (unpacked / "sweep" / "s1_n40_bf_r0").is_dir(),
              f"the archive of --out {name!r}: exit {result.returncode}:\n{result.stderr}")
        shown_lines_whole(unpacked, f"--out {name!r}")
    ran = work / "tool_ran"
    tool = f"/x/a\n`touch {ran}`/overlap"
    tar = archive(work / "tool.tar.xz", {}, log=[invocation(NO_RUNS + ["--overlap", tool])])
    result = study("--from-archive", tar, "--overlap", args.overlap, "--out", work / "tool")
    check(result.returncode == 0, f"a recorded --overlap {tool!r}: exit {result.returncode}:\n"
          f"{result.stderr}")
    check(not ran.exists(), "the recorded --overlap's command ran")
    report = (work / "tool" / "REPORT.md").read_text()
    check("--overlap $'tool_ran\\x60/overlap'" in report,
          "the recorded --overlap is not shown escaped (its last two names)")
    shown_lines_whole(work / "tool", f"--overlap {tool!r}")


def case_archive_csv_not_finite_refused(args) -> None:
    """Not only frames.csv: a NaN or an infinity (nan, inf, 1e999) in the latency
    experiment's CSV or a pairs CSV, which the report reads as numbers too, refuses the
    archive: one line naming the file, line and column, exit 2, --out as it was."""
    if importlib.util.find_spec("matplotlib") is None:
        sys.exit(77)
    work = args.out
    runs = work / "runs"
    made = study("--overlap", args.overlap, "--emulation", work / "none", "--out", runs,
                 "--runs-only", "--quick", "--threads", "1", "--experiments", "latency,pairs",
                 "--latency-scenes", "4", "--latency-objects", "40", "--latency-frames", "3",
                 "--latency-algos", "bvh", "--latency-growths", "1", "--pairs-objects", "40",
                 "--pairs-frames", "3", "--pairs-algos", "bf,cpusap")
    check(made.returncode == 0, f"the runs: exit {made.returncode}:\n{made.stderr}")
    (runs / ".study.lock").unlink(missing_ok=True)
    out = work / "out"
    earlier_unpack(out, b"old")
    before = snapshot(out)

    def last_cell(name, value):
        def change(f):
            path = f / name
            lines = path.read_text().splitlines(keepends=True)
            lines[1] = lines[1].rstrip("\n").rsplit(",", 1)[0] + f",{value}\n"
            path.write_text("".join(lines))
        return change
    tar = archive_of(runs, work / "good.tar.xz", lambda f: None)
    result = study("--from-archive", tar, "--overlap", args.overlap, "--out", work / "good")
    check(result.returncode == 0, f"the archive as made: exit {result.returncode}:\n{result.stderr}")
    for name, value, column in [("latency/s4_n40_bvh.csv", "1e999", "late_ms"),
                                ("latency/s4_n40_bvh.csv", "nan", "late_ms"),
                                ("pairs/cpusap.csv", "inf", "extra")]:
        tar = archive_of(runs, work / "bad.tar.xz", last_cell(name, value))
        result = study("--from-archive", tar, "--overlap", args.overlap, "--out", out)
        one_line_refusal(result, f"--from-archive {tar}: study/{name}: line 2, {column} "
                         f"'{value}' is no number")
        check(snapshot(out) == before, f"{name} {value}: --out changed")
        check(not scratch_left(work), f"{name} {value}: left {scratch_left(work)}")


def case_archive_frames_bounded_by_the_runs_frames(args) -> None:
    """A frames.csv with more rows than its run's frames (summary.json's parameters.frames:
    a small archive of one long repeated row, whose report would take gigabytes) or with a
    row longer than overlap writes: refused in one line, exit 2, in a small address space,
    --out as it was."""
    work, runs, out, before = runs_and_an_unpack(args)
    run = RUN

    def grown(f):
        lines = (f / run / "frames.csv").read_text().splitlines(keepends=True)
        (f / run / "frames.csv").write_text("".join(lines + [lines[-1]] * 300_000))

    def long_row(f):
        lines = (f / run / "frames.csv").read_text().splitlines(keepends=True)
        cells = lines[1].split(",")
        cells[1] = "0." + "0" * 5000 + "1"
        (f / run / "frames.csv").write_text("".join(lines[:1] + [",".join(cells)] + lines[2:]))

    def limited():
        resource.setrlimit(resource.RLIMIT_AS, (1536 << 20, 1536 << 20))
    for name, change, words in [("grown", grown, "more than its run's 2 frames"),
                                ("long_row", long_row, "line 2 is longer than a row")]:
        tar = archive_of(runs, work / f"{name}.tar.xz", change)
        result = study("--from-archive", tar, "--overlap", args.overlap, "--out", out,
                       preexec_fn=limited)
        one_line_refusal(result, f"--from-archive {tar}: study/{run}/frames.csv: {words}")
        check(snapshot(out) == before, f"{name}: --out changed")
        check(not scratch_left(work), f"{name}: left {scratch_left(work)}")


def case_archive_run_frames_not_the_plans_refused(args) -> None:
    """A run whose summary.json names other frames than the archive's recorded options plan
    for it (the log's --frames 2; its summary forged to 1000000 beside a frames.csv of
    300000 rows, which its own word would allow) is refused in one line naming the archive,
    the run and both numbers, exit 2, in a small address space, --out as it was; one forged
    to 1 is refused too, and the archive as made is reported."""
    work, runs, out, before = runs_and_an_unpack(args)
    run = RUN

    def forged(frames: int, rows: int):
        def change(f):
            edit_json(f / run / "summary.json",
                      lambda d: d["parameters"].update(frames=frames))
            lines = (f / run / "frames.csv").read_text().splitlines(keepends=True)
            (f / run / "frames.csv").write_text("".join(lines + [lines[-1]] * rows))
        return change

    def limited():
        resource.setrlimit(resource.RLIMIT_AS, (1536 << 20, 1536 << 20))
    for frames, rows in ((1_000_000, 300_000), (1, 0)):
        tar = archive_of(runs, work / f"forged{frames}.tar.xz", forged(frames, rows))
        result = study("--from-archive", tar, "--overlap", args.overlap, "--out", out,
                       preexec_fn=limited)
        one_line_refusal(result, f"--from-archive {tar}: study/{run}/summary.json",
                         f"{frames} are not the 2")
        check(snapshot(out) == before, f"frames {frames}: --out changed")
        check(not scratch_left(work), f"frames {frames}: left {scratch_left(work)}")
    tar = archive_of(runs, work / "good.tar.xz", lambda f: None)
    result = study("--from-archive", tar, "--overlap", args.overlap, "--out", work / "good")
    check(result.returncode == 0, f"the archive as made: exit {result.returncode}:\n{result.stderr}")


def case_long_invocation_log_costs_linear_time(args) -> None:
    """An archive whose invocation log repeats one entry 20000 times (every job meeting
    every other) makes its report in seconds, not the minutes a pairwise count took."""
    if importlib.util.find_spec("matplotlib") is None:
        sys.exit(77)
    work = args.out
    runs = real_runs(args, work / "runs")
    tar = archive_of(runs, work / "long.tar.xz",
                     lambda f: edit_json(f / "study_invocations.json", lambda d: d.extend(
                         [d[0]] * 19_999)))
    started = time.monotonic()
    result = study("--from-archive", tar, "--overlap", args.overlap, "--out", work / "out",
                   timeout=120)
    took = time.monotonic() - started
    check(result.returncode == 0, f"exit {result.returncode}:\n{result.stderr}")
    check(took < 60, f"20000 invocations took {took:.0f} s")
    check("20000 invocation(s)" in (work / "out" / "REPORT.md").read_text(),
          "the report does not count the log's 20000 invocations")


def case_study_log_of_wrong_shape_refused(args) -> None:
    """--out with a study_invocations.json that is not the log a study writes (bad JSON, an
    object, a list of numbers, a number beyond a double, a negative duration, time or load
    average, a job that ends before it starts): one line naming it (and the field), exit 2,
    before any job runs (with --no-runs too), the folder as it was."""
    work = args.out
    def negative(**fields):
        return json.dumps([{**invocation(NO_RUNS), **fields}])
    for name, text in [("bad_json", "[{"), ("object", '{"a": 1}'), ("numbers", "[1]"),
                       ("inf", json.dumps([invocation(NO_RUNS)]).replace('0.1', '1e999')),
                       ("negative_seconds", negative(seconds=-1)),
                       ("negative_load", negative(load_average_at_start=-5)),
                       ("negative_start", negative(jobs=[{"group": "g", "experiment": "sweep",
                                                          "key": "k", "start": -3, "end": 1}])),
                       ("end_before_start", negative(jobs=[{
                           "group": "g", "experiment": "sweep", "key": "k", "start": 10,
                           "end": 9}]))]:
        folder = work / name
        folder.mkdir()
        (folder / "study_invocations.json").write_text(text + "\n")
        before = snapshot(folder)
        for mode in ([], ["--no-runs"], ["--runs-only"]):
            result = study("--overlap", args.overlap, "--emulation", work / "none", *NO_RUNS,
                           *mode, "--out", folder)
            one_line_refusal(result, f"{folder}/study_invocations.json", *{
                "negative_seconds": [".seconds: -1 is negative"],
                "negative_load": [".load_average_at_start: -5 is negative"],
                "negative_start": [".jobs[0].start: -3 is negative"],
                "end_before_start": [".jobs[0]: its end 9 is before its start 10"]}.get(
                    name, []))
            check(snapshot(folder) == before, f"{name} {mode}: the folder changed")


def case_scripts_with_shebang_executable(args) -> None:
    """Every file under scripts/ that opens with #! is executable, on disk and in git, and
    every scripts/ command the docs give names an executable file."""
    scripts = [p for p in sorted((REPO / "scripts").rglob("*")) if p.is_file()
               and p.read_bytes()[:2] == b"#!"]
    check(len(scripts) >= 10, f"found only {len(scripts)} scripts")
    for path in scripts:
        check(os.access(path, os.X_OK), f"{path.relative_to(REPO)}: opens with #! but is not "
              "executable (chmod +x, git update-index --chmod=+x)")
    listed = subprocess.run(["git", "-C", str(REPO), "ls-files", "-s", "scripts"],
                            capture_output=True, text=True)
    if listed.returncode == 0:  # a checkout (not a tarball): git's mode is what a clone gets
        modes = {line.split("\t")[1]: line.split()[0] for line in listed.stdout.splitlines()}
        for path in scripts:
            name = path.relative_to(REPO).as_posix()
            check(modes.get(name, "100755") == "100755",
                  f"{name}: committed as {modes.get(name)}, not 100755 (git update-index "
                  "--chmod=+x)")
    commands = set()
    for doc in [REPO / "README.md", *sorted((REPO / "docs").rglob("*.md"))]:
        for match in re.finditer(r"^\s*(?:\$ )?(scripts/[\w./-]+\.(?:py|sh))\b", doc.read_text(),
                                 re.MULTILINE):
            commands.add((doc.relative_to(REPO).as_posix(), match[1]))
    check(any(c == "scripts/study_slurm.sh" for _, c in commands),
          "no doc runs scripts/study_slurm.sh: the doc scan finds nothing")
    for doc, command in sorted(commands):
        path = REPO / command
        check(path.is_file() and os.access(path, os.X_OK),
              f"{doc} runs {command}, which is not an executable file")


def fake_sbatch(work: pathlib.Path, body: str) -> dict:
    """An environment whose PATH finds first an `sbatch` that runs the sh `body`."""
    fake = work / "bin"
    fake.mkdir()
    (fake / "sbatch").write_text(f"#!/bin/sh\n{body}\n")
    (fake / "sbatch").chmod(0o755)
    return {**os.environ, "PATH": f"{fake}:{os.environ['PATH']}"}


def case_slurm_checks_before_submitting(args) -> None:
    """scripts/study_slurm.sh checks the study's options (study.py --check-only) and refuses
    a second --out, --shard or --from-archive after --, before it makes or submits anything:
    exit 2, one line, no sbatch call, no --out folder (sbatch faked on PATH)."""
    work = args.out
    calls = work / "sbatch_calls"
    env = fake_sbatch(work, f"echo \"$@\" >> {calls}\necho 12345")
    slurm = REPO / "scripts" / "study_slurm.sh"
    own = ["--overlap", args.overlap]
    for words, named in [
            (["--profile", "nosuch"], "--profile"),
            (["--profile", "quick", "--", *own, "--algos", "nosuch"], "--algos"),
            (["--profile", "quick", "--", *own, "--objects", "0"], "--objects"),
            (["--profile", "quick", "--", *own, "--repetitions", "99999999999999"],
             "--repetitions"),
            (["--profile", "quick", "--", *own, "--out", "/etc"], "--out"),
            (["--profile", "quick", "--", *own, "--out=/etc"], "--out"),
            (["--profile", "quick", "--", *own, "--shard", "1/2"], "--shard"),
            (["--profile", "full", "--", *own, "--profile", "quick"], "--profile"),
            (["--", *own, "--profile=quick"], "--profile"),
            (["--profile", "quick", "--", *own, "--full"], "--full"),
            (["--", *own, "--quick"], "--quick"),
            (["--profile", "quick", "--", *own, "--help"], "--help"),
            (["--profile", "quick", "--", *own, "-h"], "-h"),
            (["--shards", "99999999999999999999999"], "--shards")]:
        out = work / "sl"
        result = subprocess.run([str(slurm), "--out", str(out), "--shards", "4", *words],
                                capture_output=True, text=True, env=env, timeout=120)
        check(result.returncode == 2 and result.stderr.count("\n") == 1 and
              named in result.stderr and "Traceback" not in result.stderr,
              f"study_slurm.sh {' '.join(words)}: exit {result.returncode}:\n{result.stderr}")
        check(not calls.exists(), f"study_slurm.sh {' '.join(words)}: submitted "
              f"{calls.read_text() if calls.exists() else ''}")
        check(not out.exists(), f"study_slurm.sh {' '.join(words)}: made {out}")
    # sbatch reads % and \\ in its log names as patterns; and the jobs start in the
    # checkout, so a path relative to the caller's folder is checked from there.
    elsewhere = os.path.relpath(args.overlap, work)
    for out, words, named in [
            (work / "p%jq", own, "sbatch reads %"),
            (work / "b\\sl", own, "sbatch reads %"),
            (work / "rel", ["--overlap", elsewhere], "--overlap")]:
        result = subprocess.run([str(slurm), "--out", str(out), "--shards", "2", "--profile",
                                 "quick", "--", *words, *NO_RUNS[1:]], capture_output=True,
                                text=True, env=env, timeout=120, cwd=work)
        check(result.returncode == 2 and result.stderr.count("\n") == 1 and
              named in result.stderr, f"study_slurm.sh --out {out}: exit "
              f"{result.returncode}:\n{result.stderr}")
        check(not calls.exists() and not out.exists(), f"study_slurm.sh --out {out}: went on")
    out = work / "good"
    result = subprocess.run([str(slurm), "--out", str(out), "--shards", "4", "--profile", "quick",
                             "--", *own, *NO_RUNS[1:]], capture_output=True, text=True, env=env,
                            timeout=120)
    check(result.returncode == 0 and len(calls.read_text().splitlines()) == 2,
          f"good options: exit {result.returncode}:\n{result.stderr}")


def case_slurm_stop_says_what_was_submitted(args) -> None:
    """A stop signal to study_slurm.sh says what it had done: during the study's check,
    nothing made and nothing submitted (exit 143, one line of its own); while sbatch
    submits the shards, the job it submitted, once it has ended (bash runs the trap then),
    to cancel (sbatch faked, slow; no scancel here: named as not cancelled, with the
    scancel to run)."""
    work = args.out
    started = work / "sbatch_started"
    env = fake_sbatch(work, f"touch {started}\nsleep 3\necho 4242")
    slurm = REPO / "scripts" / "study_slurm.sh"
    out = work / "st"
    command = [str(slurm), "--out", str(out), "--shards", "2", "--profile", "quick", "--",
               "--overlap", args.overlap, *NO_RUNS[1:]]
    # While sbatch submits.
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                               text=True, env=env)
    deadline = time.monotonic() + 60
    while not started.exists() and time.monotonic() < deadline:
        time.sleep(0.05)
    process.send_signal(signal.SIGTERM)
    _, stderr = process.communicate(timeout=60)
    lines = [line for line in stderr.splitlines() if line.startswith("study_slurm:")]
    check(process.returncode == 128 + signal.SIGTERM and len(lines) == 1 and
          "the shards' job 4242" in lines[0] and "scancel 4242" in lines[0] and
          "squeue" not in lines[0],
          f"SIGTERM during sbatch: exit {process.returncode}:\n{stderr}")
    # Before anything is made: the fresh --out is gone.
    shutil.rmtree(out, ignore_errors=True)
    started.unlink()
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                               text=True, env=env)
    time.sleep(0.05)
    process.send_signal(signal.SIGTERM)
    _, stderr = process.communicate(timeout=60)
    if not started.exists():  # the stop came before the submission, as meant
        check(not out.exists(), f"SIGTERM before sbatch: --out left:\n{stderr}")
        # (bash's first milliseconds, before the trap is set, end by the signal itself)
        check(process.returncode == -signal.SIGTERM or (
            process.returncode == 128 + signal.SIGTERM and
            "stopped by SIGTERM; nothing submitted" in stderr),
              f"SIGTERM before sbatch: exit {process.returncode}:\n{stderr}")


def case_slurm_jobs_run_the_checked_words(args) -> None:
    """The commands study_slurm.sh submits (sbatch --wrap, which the job's /bin/sh runs) are
    word for word the ones its check ran (study.py --check-only): for the array's task and
    the report job, with the full profile's --full as with --profile quick, and for an
    --out with a space, a tab, a quote and a byte not ASCII under LANG=C (sbatch and python3
    faked on PATH: each records what it was given)."""
    work = args.out
    fake = work / "bin"
    fake.mkdir()
    calls, ran = work / "sbatch_calls", work / "python_argvs"
    (fake / "sbatch").write_text(
        "#!/bin/sh\n"
        f"n=$(ls '{calls}' | wc -l)\n"
        "for a; do case \"$a\" in --wrap=*) printf '%s' \"${a#--wrap=}\" > "
        f"'{calls}'/wrap$n ;; esac; done\n"
        "echo 1000$n\n")
    (fake / "sbatch").chmod(0o755)
    recorder = fake / "python3"
    recorder.write_text(
        f"#!{PYTHON}\nimport json, os, sys\n"
        f"with open({str(ran)!r}, 'a') as f:\n"
        "    f.write(json.dumps([os.fsencode(w).hex() for w in sys.argv]) + '\\n')\n"
        "if not os.environ.get('RECORD_ONLY'):\n"
        f"    os.execv({PYTHON!r}, [{PYTHON!r}] + sys.argv[1:])\n")
    recorder.chmod(0o755)
    env = {k: v for k, v in os.environ.items() if not k.startswith("LC_")}
    env.update(PATH=f"{fake}:{os.environ['PATH']}", PYTHON=str(recorder), LANG="C",
               LC_ALL="C")
    slurm = REPO / "scripts" / "study_slurm.sh"
    odd = os.fsencode(str(work)) + b"/stud \t'q\xe9 x"
    for profile, out in [("quick", odd), ("full", os.fsencode(str(work / "full")))]:
        calls.mkdir()
        ran.unlink(missing_ok=True)
        result = subprocess.run([str(slurm), "--out", out, "--shards", "2", "--profile",
                                 profile, "--", "--overlap", args.overlap, *NO_RUNS[1:]],
                                capture_output=True, env=env, timeout=120)
        check(result.returncode == 0, f"{profile}: exit {result.returncode}:\n"
              f"{result.stderr.decode(errors='replace')}")
        checked = [[bytes.fromhex(w) for w in json.loads(line)]
                   for line in ran.read_text().splitlines()]
        checked = [argv for argv in checked if b"--check-only" in argv]
        wraps = [(calls / f"wrap{n}").read_bytes() for n in range(2)]
        ran.unlink()
        for wrap in wraps:
            done = subprocess.run(["/bin/sh", "-c", wrap], env={
                **env, "SLURM_ARRAY_TASK_ID": "1", "RECORD_ONLY": "1"}, capture_output=True)
            check(done.returncode == 0, f"{profile}: sh -c {wrap!r}: {done.stderr!r}")
        submitted = [[bytes.fromhex(w) for w in json.loads(line)]
                     for line in ran.read_text().splitlines()]
        for what, job_argv in zip(("task 1", "report"), submitted):
            given = job_argv[job_argv.index(b"--out") + 1] if b"--out" in job_argv else None
            check(given == out, f"{profile}: the {what}'s --out is {given!r}, not {out!r}")
        check(len(checked) == 2, f"{profile}: {len(checked)} checks ran, expected the task's "
              "and the report job's")
        for what, check_argv, job_argv in zip(("task 1", "report"), checked, submitted):
            check(check_argv == job_argv + [b"--check-only"],
                  f"{profile}: the {what} runs {job_argv}, the check ran {check_argv}")
        check((b"--full" in submitted[0]) == (profile == "full"),
              f"{profile}: the task's --full: {submitted[0]}")
        check(os.path.isfile(out + b"/.study.lock"), f"{profile}: {out!r} not made")
        shutil.rmtree(calls)


def case_oversized_plan_refused_quickly(args) -> None:
    """A list option of 20000 values with --repetitions 1000 (--objects), or lists within
    their bound whose product with the repetitions is past the plan's bound (2 million
    jobs): one line naming the bound, exit 2, in seconds and in a small address space,
    --check-only and a plain study alike, nothing written; the full profile is within it."""
    work = args.out

    def limited():
        resource.setrlimit(resource.RLIMIT_AS, (400 << 20, 400 << 20))
    for values, named in [(20000, "--objects: 20000 values; at most 1000"),
                          (1000, "plan 2000000 jobs")]:
        for mode in (["--check-only"], ["--runs-only"], []):
            out = work / "o"
            started = time.monotonic()
            result = study("--overlap", args.overlap, "--emulation", work / "none", "--quick",
                           "--experiments", "sweep", "--scenes", "1", "--algos", "bf,cpusap",
                           "--objects", ",".join(map(str, range(1, values + 1))),
                           "--frames", "5", "--repetitions", "1000", *mode, "--out", out,
                           preexec_fn=limited, timeout=60)
            took = time.monotonic() - started
            one_line_refusal(result, named)
            check(took < 20, f"{values} values {mode}: refused after {took:.0f} s")
            check(not out.exists(), f"{values} values {mode}: made {out}")
    result = study("--overlap", args.overlap, "--profile", "full", "--check-only", "--out",
                   work / "full")
    check(result.returncode == 0 and "1148 jobs" in result.stderr,
          f"the full profile: exit {result.returncode}:\n{result.stderr}")


def case_stop_after_the_end_changes_nothing(args) -> None:
    """A stop signal that comes once a script's main() has ended (everything published),
    while the interpreter tears down (which gives the signals back their default action, as
    done here by hand, then lingers): the script ends with main()'s status, not killed by
    the signal (SIGTERM, SIGINT and SIGHUP, each as the first signal)."""
    script = args.out / "publishes_then_tears_down.py"
    script.write_text(
        "import signal, sys, time\n"
        f"sys.path.insert(0, {str(REPO / 'scripts')!r})\n"
        "import script_cli\n"
        "def main():\n"
        "    print('published', flush=True)\n"
        "    return 3\n"
        "status = script_cli.run(main, 'teardown')\n"
        "for signum in script_cli.STOPS:  # what the interpreter's teardown does\n"
        "    signal.signal(signum, signal.SIG_DFL)\n"
        "print('tearing down', flush=True)\n"
        "time.sleep(2)\n"
        "sys.exit(status)\n")
    for signum in script_cli_stops():
        child = subprocess.Popen([PYTHON, str(script)], stdout=subprocess.PIPE,
                                 stderr=subprocess.PIPE, text=True)
        lines = [child.stdout.readline(), child.stdout.readline()]
        check(lines == ["published\n", "tearing down\n"], f"the script said {lines}")
        child.send_signal(signum)
        _, stderr = child.communicate(timeout=30)
        check(child.returncode == 3, f"{signal.Signals(signum).name} in the teardown: exit "
              f"{child.returncode}, expected main()'s 3:\n{stderr}")
        check("Traceback" not in stderr, f"{signal.Signals(signum).name}: {stderr}")


def script_cli_stops() -> tuple:
    return (signal.SIGTERM, signal.SIGINT, signal.SIGHUP)


def case_memory_limit_not_bad_input(args) -> None:
    """study.py under a small `ulimit -v`: a MemoryError while it starts, or an overlap that
    cannot start (its loader, exit 127) or is killed, is one line and exit 1 (the machine's
    limit), never a traceback and never exit 2 (bad input); nothing left in --out."""
    work = args.out
    seen = set()
    for kib in (17_000, 20_000, 23_000, 26_000, 40_000, 100_000, 150_000, 200_000):
        def limited(kib=kib):
            resource.setrlimit(resource.RLIMIT_AS, (kib * 1024, kib * 1024))
        out = work / f"out_{kib}"
        result = subprocess.run([PYTHON, str(STUDY), "--overlap", args.overlap, "--emulation",
                                 str(work / "none"), "--out", str(out), "--runs-only", *NO_RUNS],
                                capture_output=True, text=True, preexec_fn=limited, timeout=120)
        lines = result.stderr.splitlines()
        if result.returncode == 0:
            continue
        check(result.returncode == 1 and "Traceback" not in result.stderr,
              f"ulimit -v {kib}: exit {result.returncode}:\n{result.stderr}")
        check(len([l for l in lines if l.startswith("study")]) >= 1 and
              not any("Traceback" in l for l in lines), f"ulimit -v {kib}: {result.stderr}")
        seen.add(kib)
    check(seen, "no limit made study.py fail: the check proves nothing")


def case_bad_arguments_one_line(args) -> None:
    work = args.out
    missing = work / "missing"
    a_file = work / "a_file"
    a_file.write_text("x\n")
    unreadable = work / "unreadable.tar.xz"
    unreadable.write_text("x")
    unreadable.chmod(0)
    not_text = work / "not_text.md"
    not_text.write_bytes(b"# a report\n\xff\xfe\n")
    scripts = REPO / "scripts"
    cases = [
        (["study_document.py", "check", not_text], "not_text.md: not UTF-8"),
        (["study_document.py", "words", not_text], "not_text.md: not UTF-8"),
        (["study.py", "--overlap", missing], "--overlap"),
        (["study.py", "--overlap", args.overlap, "--threads", "x"], "--threads"),
        (["study.py", "--overlap", args.overlap, "--experiments", "nope"], "--experiments"),
        (["study.py", "--overlap", args.overlap, "--experiments", "", "--no-runs", "--out",
          work / "o"], "--experiments '': expected one or more"),
        (["study.py", "--overlap", args.overlap, "--experiments", "sweep\nx", "--no-runs",
          "--out", work / "o"], "--experiments 'sweep\\nx': expected"),
        (["study.py", "--overlap", args.overlap, "--profile", "nope"], "--profile"),
        (["study.py", "--overlap", args.overlap, "--from-archive", missing, "--out", work / "o"],
         "no such file"),
        (["study.py", "--overlap", args.overlap, "--from-archive", "/dev/null", "--out",
          work / "o"], "/dev/null: not a regular file"),
        (["study.py", "--overlap", args.overlap, "--from-archive", a_file, "--out", work / "o"],
         "cannot be read"),
        (["study.py", "--overlap", args.overlap, "--from-archive", unreadable, "--out",
          work / "o"], "unreadable"),
        (["study.py", "--overlap", args.overlap, "--out", a_file / "sub", "--runs-only",
          *NO_RUNS], "a_file"),
        # An --out no study could make is said before any job, --check-only too.
        (["study.py", "--overlap", args.overlap, "--out", "/proc/1/nope", "--check-only",
          *NO_RUNS], "--out /proc/1/nope: cannot be written in /proc/1"),
        *[(["study.py", "--overlap", args.overlap, "--out", work / "o", "--runs-only",
            *NO_RUNS, option, value], option)
          for option, value in [("--objects", "x"), ("--objects", "-5"), ("--scenes", "9"),
                                ("--algos", "nope"), ("--frames", "0"), ("--threads", "-1"),
                                ("--physics-ccd", "x"), ("--overlap-loads", "1,,2"),
                                ("--physics-substeps", "auto,0"), ("--shard", "2/1"),
                                ("--algos", "bf,bf"), ("--scenes", "1,1"),
                                ("--objects", "40,40"), ("--overlap-loads", "1,1.0"),
                                ("--algos", ""), ("--repetitions", "99999999999999"),
                                ("--overlap-repetitions", "999999999999"),
                                ("--objects", "999999999"), ("--objects", "05"),
                                ("--frames", "1_000"), ("--frames", " 5"), ("--frames", "05"),
                                ("--frames", "1000001"), ("--seed", "18446744073709551616"),
                                ("--seed", "-1"), ("--threads", "1025"),
                                ("--ideal-threads", "2000"), ("--overlap-loads", "101"),
                                ("--physics-substeps", "1001"),
                                ("--capture-objects", "10000001"),
                                ("--physics-seeds", ",".join(map(str, range(1001))))]],
        (["study.py", "--overlap", args.overlap, "--out", work / "o", "--check-only",
          *NO_RUNS, "--objects", "0"], "--objects"),
        (["study.py", "--overlap", args.overlap, "--out", work / "o", "--check-only",
          "--from-archive", a_file], "--check-only"),
        (["study.py", "--overlap", args.overlap, "--out", work / "o", "--no-runs", "--report",
          "--report-doc", missing], "--report-doc"),
        (["gpu_results.py", "--raw", missing], "--raw"),
        (["gpu_results.py", "--raw", work], "raw folder"),
        (["gpu_cost_model.py", "--raw", missing], "--raw"),
        (["gpusap_chain_model.py", "--raw", a_file], "--raw"),
        (["cpusap_table.py", "--bench", missing], "--bench"),
        (["cpusap_table.py", "--repeats", "0"], "--repeats"),
        (["plot_run.py", missing], "missing"),
        (["peers/peers_table.py", missing], "missing"),
        (["peers/check_broadmark_pairs.py", "--driver", missing, "--overlap", args.overlap,
          "--input", missing], "--input"),
        (["peers/check_broadmark_pairs.py", "--driver", missing, "--overlap", args.overlap,
          "--input", a_file], "--driver"),
        *[(["thread_scaling.py", "--config", config, *extra, "--out", out], named)
          for config, extra, out, named in [
              (f"a={work}", [], work / "t.csv", "not an executable file"),
              (f"a={args.overlap}", ["--skip", "-1"], work / "t.csv", "--skip -1"),
              (f"a={args.overlap}", ["--config", f"a={args.overlap}"], work / "t.csv",
               "each LABEL once"),
              (f"a={args.overlap}", [], "/dev/null", "not a regular file"),
              (f"a={args.overlap}", [], a_file / "t.csv", "--out"),
              (f"a={args.overlap}:--seed '1", [], work / "t.csv", "No closing quotation"),
              (f"a={args.overlap}", ["--common", "--seed '1"], work / "new" / "t.csv",
               "--common"),
              (f"a\nb={args.overlap}", [], work / "t.csv", "control character")]]]
    for words, named in cases:
        before = sorted(p.name for p in work.iterdir())
        result = subprocess.run([PYTHON, str(scripts / words[0]), *map(str, words[1:])],
                                capture_output=True, text=True, timeout=120)
        check(result.returncode == 2 and result.stderr.count("\n") == 1 and
              "Traceback" not in result.stderr and named in result.stderr,
              f"{' '.join(map(str, words))}: exit {result.returncode}:\n{result.stderr}")
        check(sorted(p.name for p in work.iterdir()) == before,
              f"{' '.join(map(str, words))}: wrote into {work}")


def run_case(cases: dict, add_options=lambda parser: None) -> int:
    """Runs the case_NAME of `cases` (a check script's globals()) that --case names, on
    --overlap, in a fresh --out; `add_options` adds a script's own options."""
    parser = argparse.ArgumentParser(allow_abbrev=False)
    parser.add_argument("--overlap", required=True)
    parser.add_argument("--out", type=pathlib.Path, required=True)
    add_options(parser)
    parser.add_argument("--case", required=True,
                        choices=[n[len("case_"):] for n in cases if n.startswith("case_")])
    args = parser.parse_args()
    args.overlap = str(pathlib.Path(args.overlap).resolve())
    shutil.rmtree(args.out, ignore_errors=True)
    args.out.mkdir(parents=True)
    args.out = args.out.resolve()
    cases["case_" + args.case](args)
    print(f"study.{args.case}: all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(run_case(globals()))
