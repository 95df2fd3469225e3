"""A study archive unpacked as a --out folder (`study.py --from-archive TAR --out D`).

An archive is a tar file (.tar.xz as scripts/gpu_check.sh --study returns it)
holding a study's --out folder as ./study.  It comes from another machine, so
nothing in it is trusted: not its names, its modes, its sizes, nor its text.

Rules, each with its reason:
  * D is replaced only when it is an earlier unpack (a folder holding MARKER,
    which every unpack writes), an empty folder, or absent.  Any other D is
    refused, and so is the current folder or one above it, through any link:
    an unpack never removes what an unpack did not make.  MARKER records the
    digest of the log the unpack wrote; a D whose log is another (a study ran
    into it) is refused, and a study that logs into an unpack removes MARKER
    first (study_out_folder.claim_an_unpack), under D's lock, which the swap
    holds too.
  * Everything is checked before D is touched.  The members: only files and
    folders under ./study, none absolute, none through '..', no link, no
    device, at most MAX_MEMBERS members and MAX_BYTES bytes unpacked (a sparse
    member counts its full size).  Then the unpacked text: every .json, .csv,
    .md and .txt file is UTF-8, every .json file parses (no NaN, no Infinity, no
    number beyond a double: 1e999 would read as a measurement), the invocation log,
    the runs' summary.json and frames.csv have the shapes the report reads (and
    no CSV outside report/ a NaN or an infinity either; the log no negative duration,
    time or load average); each run the report reads has the frames the recorded options
    plan for it (its summary.json's are refused when they differ, its frames.csv holds no
    more rows: the report's memory is bounded by the log, not by a run's own word); then
    (study.py's `prepare`) the report is made in the scratch folder, so a run file
    lacking anything else it reads refuses the archive too.  A member that is
    not under ./study is never written, yet an absolute or '..' name, a link or a
    device anywhere refuses the archive.  A bad archive is
    one line naming it and the problem, exit 2, and D as it was.
  * Members are written as tarfile's `data` filter writes them (as_data(), and the
    filter itself where the Python has it): no setuid, setgid or sticky bit, no
    write for group or others, no owner taken from the archive nor looked up
    (OwnerlessTar: tarfile's lookup swallowed a stop signal).
  * A stop is never lost: script_cli.check_stopped() after the unpack, after the
    report and before the swap raises a stop some library's `except` swallowed.
  * The new folder is unpacked beside D (PARENT/.D.unpack-XXXXXXXX), D is renamed
    into that scratch folder and the new one renamed to D with SIGINT, SIGTERM
    and SIGHUP held off, and only then is the old one removed: a signal at any
    moment leaves D whole, old or new; once D is the new one the signals stay
    held (nothing is left to stop: commands.txt and the report were made in the
    scratch folder).  A signal before that (script_cli.Stopped) removes the
    scratch folder, then goes on: the script stops as script_cli says.  A scratch folder whose unpack was
    killed (no process holds its lock) is removed by the next unpack beside it.
"""
import codecs
import contextlib
import copy
import csv
import fcntl
import glob
import hashlib
import json
import lzma
import math
import os
import pathlib
import re
import shutil
import signal
import tarfile
import tempfile
import zlib

from script_cli import STOPS, Stopped, check_stopped, one_line

MARKER = ".study-archive"  # in D: D is an unpack, which the next unpack may replace
LOG_NAME = "study_invocations.json"  # study_out_folder's: the log every study writes first
SCRATCH_MARKER = ".study-unpack"  # in a scratch folder: made by an unpack
MAX_BYTES = 2 * 1024 ** 3
MAX_MEMBERS = 50_000  # a full study (1112 jobs) unpacks to about 6000
TEXT_SUFFIXES = (".json", ".csv", ".md", ".txt")
MACHINE_TEXT = ("cpu", "gpu", "compiler", "build_type", "git_commit")


class BadArchive(Exception):
    """The archive cannot be unpacked as a study; the message says why."""


class BadOut(Exception):
    """--out cannot be replaced by an unpack; the message says why."""


@contextlib.contextmanager
def signals_held():
    """SIGINT, SIGTERM and SIGHUP wait until the block is done."""
    before = signal.pthread_sigmask(signal.SIG_BLOCK, STOPS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, before)


@contextlib.contextmanager
def folder_locked(folder: pathlib.Path, blocking: bool = True):
    """An exclusive flock on the folder itself (no file made); None when not blocking
    and another process holds it."""
    fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | (0 if blocking else fcntl.LOCK_NB))
        except BlockingIOError:
            yield None
            return
        yield fd
    finally:
        os.close(fd)


@contextlib.contextmanager
def study_locked(target: pathlib.Path):
    """TARGET's study lock (study_out_folder's .study.lock) held where it has one: a study
    logging into it meanwhile (and so claiming it: no longer an unpack) waits, or has."""
    lock = target / ".study.lock"
    if lock.is_symlink() or not lock.is_file():
        yield
        return
    fd = os.open(lock, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)


def replaceable(target: pathlib.Path, out: pathlib.Path) -> None:
    """Raises BadOut unless `target` (--out `out`, resolved) may be replaced."""
    here = pathlib.Path.cwd().resolve()
    if target == here or target in here.parents:
        raise BadOut(f"{out}: is the current folder or one above it, which an unpack "
                     "never replaces; give a folder of its own")
    if not os.path.lexists(target):
        return
    if target.is_symlink() or not target.is_dir():
        raise BadOut(f"{out}: exists and is not a folder")
    marker = target / MARKER
    if marker.is_symlink() or not marker.is_file():
        if any(target.iterdir()):
            raise BadOut(f"{out}: exists and is not an earlier unpack of a study archive "
                         f"(it has no {MARKER}); give a new folder, or empty it yourself")
        return
    if not log_as_unpacked(target, marker):
        raise BadOut(f"{out}: a study has run or logged into this unpack since it was made "
                     f"(its {LOG_NAME} is not the archive's), so it holds runs no unpack made; "
                     "give a new folder, or empty it yourself")


def log_digest(folder: pathlib.Path) -> str:
    """The sha256 of FOLDER's invocation log, or "none" when it has none."""
    try:
        with open(folder / LOG_NAME, "rb") as f:
            return hashlib.file_digest(f, "sha256").hexdigest() if hasattr(
                hashlib, "file_digest") else hashlib.sha256(f.read()).hexdigest()
    except FileNotFoundError:
        return "none"


def log_as_unpacked(target: pathlib.Path, marker: pathlib.Path) -> bool:
    """Whether TARGET's invocation log is the one its unpack wrote (the digest its MARKER
    records; a marker of an older unpack, recording none, is taken at its word)."""
    try:
        recorded = re.search(r"^log sha256: ([0-9a-f]{64}|none)$",
                             marker.read_text(encoding="utf-8", errors="replace"), re.M)
    except OSError:
        return False
    return recorded is None or recorded[1] == log_digest(target)


def clear_stale(parent: pathlib.Path, name: str) -> None:
    """Removes the scratch folders of unpacks into PARENT/NAME that were killed."""
    for folder in parent.glob(f".{glob.escape(name)}.unpack-*"):
        if folder.is_symlink() or not folder.is_dir() or folder.stat().st_uid != os.getuid():
            continue
        if not ((folder / SCRATCH_MARKER).is_file() or not any(folder.iterdir())):
            continue
        with folder_locked(folder, blocking=False) as free:
            if free is not None:
                shutil.rmtree(folder, ignore_errors=True)


def study_members(tar: tarfile.TarFile) -> list:
    """The members under ./study, checked one by one as they are read (bounded)."""
    members, count, total = [], 0, 0
    for member in tar:
        count += 1
        if count > MAX_MEMBERS:
            raise BadArchive(f"holds over {MAX_MEMBERS} members: more than a study unpacks to")
        path = pathlib.PurePosixPath(member.name)
        if path.is_absolute() or ".." in path.parts:
            raise BadArchive(f"member {member.name!r} names a path outside the archive")
        if not (member.isfile() or member.isdir()):
            raise BadArchive(f"member {member.name!r} is a link or a device, not a file "
                             "or a folder")
        if path.parts[:1] != ("study",):  # "./study/x" reads as study/x
            continue
        total += member.size
        if total > MAX_BYTES:
            raise BadArchive(f"unpacks to over {MAX_BYTES // 1024 ** 2} MiB: more than a "
                             f"study holds (member {member.name!r} passes the bound)")
        members.append(member)
    if not members:
        raise BadArchive("holds no ./study folder (a study's --out)")
    return members


def as_data(member: tarfile.TarInfo) -> tarfile.TarInfo:
    """The member as tarfile's `data` filter writes it, on every Python (Debian's 3.11.2
    has no filters): no setuid, setgid or sticky bit, no write for group or others, read
    and write for the owner, execute only where the owner has it, and this process's
    owner, not the archive's."""
    safe = copy.copy(member)
    mode = member.mode & 0o755
    if member.isdir():
        mode |= 0o700
    else:
        mode = (mode if mode & 0o100 else mode & ~0o111) | 0o600
    safe.mode, safe.uid, safe.gid, safe.uname, safe.gname = \
        mode, os.getuid(), os.getgid(), "", ""
    return safe


class OwnerlessTar(tarfile.TarFile):
    """A TarFile that never sets or looks up a member's owner: every member belongs to this
    process (as_data), and tarfile's own chown, run as root, looks each owner's name up
    in pwd/grp inside an `except KeyError: pass` that would swallow a stop signal's
    Stopped raised meanwhile (and costs a passwd lookup a member)."""

    def chown(self, tarinfo, targetpath, numeric_owner):
        pass


def extract(archive: pathlib.Path, scratch: pathlib.Path) -> pathlib.Path:
    filtered = {"filter": "data"} if hasattr(tarfile, "data_filter") else {}
    try:
        with OwnerlessTar.open(archive) as tar:
            tar.extractall(scratch, [as_data(m) for m in study_members(tar)], **filtered)
    except (tarfile.TarError, EOFError, lzma.LZMAError, zlib.error) as error:
        first = str(error).splitlines()[0].rstrip(":") if str(error) else type(error).__name__
        raise BadArchive(f"cannot be read as a tar file ({first})")
    except OSError as error:
        raise BadArchive(f"cannot be unpacked ({error.strerror or error})")
    study = scratch / "study"
    if study.is_symlink() or not study.is_dir():
        raise BadArchive("its ./study is not a folder")
    return study


def check_shape(value, shape, where: str) -> None:
    """`value` against `shape`: a type, a tuple of types, [shape] or {key: shape} (a key
    ending in '?' may be absent)."""
    if isinstance(shape, list):
        if not isinstance(value, list):
            raise BadArchive(f"{where}: not a list")
        for index, item in enumerate(value):
            check_shape(item, shape[0], f"{where}[{index}]")
        return
    if isinstance(shape, dict):
        if not isinstance(value, dict):
            raise BadArchive(f"{where}: not an object")
        for key, inner in shape.items():
            name = key.rstrip("?")
            if name in value:
                check_shape(value[name], inner, f"{where}.{name}")
            elif not key.endswith("?"):
                raise BadArchive(f"{where}: has no {name!r}")
        return
    types = shape if isinstance(shape, tuple) else (shape,)
    if not isinstance(value, types) or (isinstance(value, bool) and bool not in types):
        raise BadArchive(f"{where}: {json.dumps(value)[:60]} is not of the type the "
                         "report reads")


NUMBER = (int, float)
INVOCATION = {"argv": [str], "started": str, "load_average_at_start": NUMBER,
              "finished?": bool, "seconds?": (int, float, type(None)),
              "jobs?": [{"group": str, "experiment": str, "key": str, "start": NUMBER,
                         "end": NUMBER}]}
# What every run's summary.json holds that the report reads of every run (the tables read
# more of some; the report itself, made in the scratch folder before the swap, refuses an
# archive whose runs lack that: study.py).
SUMMARY = {"machine": {**{key: str for key in MACHINE_TEXT}, "hardware_threads": int},
           "parameters": {"algorithm": str}, "timings_ms": dict, "counts": dict}
MAX_JSON_BYTES = 64 * 1024 ** 2


def check_utf8(path: pathlib.Path, name: str) -> None:
    decoder = codecs.getincrementaldecoder("utf-8")("strict")
    done = 0
    try:
        with open(path, "rb") as f:
            while chunk := f.read(1 << 20):
                decoder.decode(chunk)
                done += len(chunk)
            decoder.decode(b"", final=True)
    except UnicodeDecodeError as error:
        raise BadArchive(f"{name}: not UTF-8 text (at byte {done + error.start})")


def refuse_constant(name: str):
    """json's NaN, Infinity and -Infinity, which no file of a study holds (a load
    average of NaN would read as a measurement)."""
    raise ValueError(f"{name} is no number a study writes")


def finite_float(text: str) -> float:
    """A JSON number with a fraction or an exponent; one beyond a double (1e999, -1e400,
    which float() reads as an infinity without a word) is refused as NaN is."""
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"{text[:40]} is beyond a double: no number a study writes")
    return value


def finite_int(text: str) -> int:
    """A JSON whole number; one beyond a double (a 400-digit integer, which the report's
    arithmetic turns into an OverflowError) is refused as 1e999 is."""
    if len(text.lstrip("-")) > 308:
        raise ValueError(f"{text[:40]}... is beyond a double: no number a study writes")
    return int(text)


def parse_json(text: str):
    """A study file's JSON: no NaN, no Infinity, no number beyond a double (ValueError,
    RecursionError as json.loads raises them)."""
    return json.loads(text, parse_constant=refuse_constant, parse_float=finite_float,
                      parse_int=finite_int)


# The options whose value a study records as it was given, a path of the machine that ran
# it (any bytes: a tab, a newline, a byte not UTF-8): study.py's --out, --overlap,
# --emulation and --report-doc.  The archive's are never taken (study.py NOT_THE_RUNS: the
# unpack's --out is its own) and are shown escaped (script_cli.shell_word).
PATH_OPTIONS = ("--out", "--overlap", "--emulation", "--report-doc")


def recorded_words(argv: list) -> list:
    """(word, whether it is a path option's value) for each word of a recorded argv."""
    words, after_path = [], False
    for word in argv:
        words.append((word, after_path or word.partition("=")[0] in PATH_OPTIONS
                      and "=" in word))
        after_path = not after_path and word in PATH_OPTIONS
    return words


def check_log(log, name: str, foreign: bool = True) -> None:
    """The invocation log `name` has the shape the report and the next shard read: a
    list of invocations (raises BadArchive).  A foreign log (an archive's) has no word a
    command line of a study would not hold either (a backtick, a control character, a
    byte not UTF-8), but for the paths it was given (PATH_OPTIONS' values), which hold
    what the study was given and are shown escaped; a local --out's log holds this
    machine's own words, not checked."""
    check_shape(log, [INVOCATION], name)
    for index, run in enumerate(log):
        if run.get("finished", True) and not isinstance(run.get("seconds"), (int, float)):
            raise BadArchive(f"{name}[{index}]: finished, yet no seconds of its jobs")
        # Durations, times and load averages are never negative, nor a job's end before
        # its start: such a number would read as a measurement ("took -1 s").
        fields = [("load_average_at_start", run["load_average_at_start"]),
                  ("seconds", run.get("seconds"))]
        for at, job in enumerate(run.get("jobs", [])):
            fields += [(f"jobs[{at}].start", job["start"]), (f"jobs[{at}].end", job["end"])]
            if job["end"] < job["start"]:
                raise BadArchive(f"{name}[{index}].jobs[{at}]: its end {job['end']} is before "
                                 f"its start {job['start']}: no job a study logs")
        for field, value in fields:
            if isinstance(value, (int, float)) and value < 0:
                raise BadArchive(f"{name}[{index}].{field}: {json.dumps(value)[:40]} is "
                                 "negative: no number a study writes")
        for word, a_path in recorded_words(run["argv"]) + [(run["started"], False)] \
                if foreign else ():
            if len(word) > 4096 or not a_path and ("`" in word or not word.isprintable()):
                raise BadArchive(f"{name}[{index}]: the word {word[:60]!r} is not one "
                                 "a command line of the study holds")


def read_text(study: pathlib.Path) -> dict:
    """Checks every text file's UTF-8; returns every .json file parsed, keyed by its
    path in the archive."""
    parsed = {}
    for path in sorted(study.rglob("*")):
        if path.suffix not in TEXT_SUFFIXES or path.is_symlink() or not path.is_file():
            continue
        name = "study/" + path.relative_to(study).as_posix()
        check_utf8(path, name)
        if path.suffix == ".json":
            if path.stat().st_size > MAX_JSON_BYTES:
                raise BadArchive(f"{name}: over {MAX_JSON_BYTES // 1024 ** 2} MiB of JSON")
            try:
                parsed[name] = parse_json(path.read_text(encoding="utf-8"))
            except RecursionError:
                raise BadArchive(f"{name}: JSON nested too deep for a study's files")
            except ValueError as error:
                raise BadArchive(f"{name}: not JSON ({error})")
    return parsed


# What the study writes in its --out over what an archive holds (the report, commands.txt,
# the lock, the unpack's marker): each of the kind the study writes there (the report's
# tables and figures are files of report/), checked before anything is written over them.
WRITTEN_FILES = ("commands.txt", "REPORT.md", ".study.lock", MARKER)
WRITTEN_FOLDERS = ("report",)


def check_written_kinds(study: pathlib.Path) -> None:
    for name in WRITTEN_FILES:
        if os.path.lexists(study / name) and not (study / name).is_file():
            raise BadArchive(f"study/{name} is a folder where the study writes a file")
    for name in WRITTEN_FOLDERS:
        if os.path.lexists(study / name) and not (study / name).is_dir():
            raise BadArchive(f"study/{name} is a file where the report writes a folder")
        if (study / name).is_dir():
            inner = next((p for p in sorted((study / name).iterdir()) if not p.is_file()), None)
            if inner is not None:
                raise BadArchive(f"study/{name}/{one_line(inner.name)[:80]} is a folder where "
                                 "the report writes its tables and figures (files)")


def check_study(study: pathlib.Path, planned=None) -> list:
    """The unpacked ./study checked as the report reads it; returns its invocation log.
    `planned` (see check_runs): the frames the report's plan gives each run it reads."""
    log = check_text(study)
    check_runs(study, planned)
    return log


def check_text(study: pathlib.Path) -> list:
    """Everything but the runs' CSV files (check_runs): the kinds of what the study writes
    over, every text file's UTF-8 and JSON, the log's and the summaries' shapes; returns
    the invocation log."""
    if not (study / "study_invocations.json").is_file():
        raise BadArchive("its ./study has no study_invocations.json: no study ran into it")
    check_written_kinds(study)
    parsed = read_text(study)
    log = parsed["study/study_invocations.json"]
    check_log(log, "study/study_invocations.json")
    if not log or not log[0]["argv"]:
        raise BadArchive("study/study_invocations.json: names no invocation")
    for name, data in parsed.items():
        if name.endswith("/summary.json"):
            check_shape(data, SUMMARY, name)
    return log


def check_runs(study: pathlib.Path, planned=None) -> None:
    """Every CSV outside report/ (check_csv_cells), a run's frames.csv as check_frames
    reads it.  `planned` ({run folder under study: frames}) is the plan the report is made
    from, its frames the recorded options' (the archive's log, not its runs): a run of it
    whose summary.json names other frames is refused, and its frames.csv may hold no more
    rows than the plan's frames, so what the report holds of the runs is bounded by the
    options, which the archive cannot forge one file at a time.  A frames.csv of no run of
    the plan is not read by the report: only streamed here.  Without a plan (gpu_check.sh's
    resume, whose study plans the runs itself) a run's own summary.json bounds its rows."""
    for folder, frames in (planned or {}).items():
        summary = study / folder / "summary.json"
        if summary.is_symlink() or not summary.is_file():
            continue  # not done: the report does not read the run
        try:
            recorded = parse_json(summary.read_text(encoding="utf-8"))["parameters"]["frames"]
        except (ValueError, LookupError, TypeError, RecursionError):
            recorded = None
        if type(recorded) is not int or recorded != frames:
            raise BadArchive(f"study/{folder}/summary.json: its run's frames "
                             f"(parameters.frames) {json.dumps(recorded)[:40]} are not the "
                             f"{frames} the archive's recorded options plan for it")
    for path in sorted(study.rglob("*.csv")):
        if path.is_symlink() or not path.is_file() or path.relative_to(study).parts[0] == \
                "report":  # report/: the other machine's report, made again here
            continue
        name = "study/" + path.relative_to(study).as_posix()
        if path.name != "frames.csv":  # latency/*.csv, pairs/*.csv...: the report reads them
            check_csv_cells(path, name)
        elif planned is None:
            check_frames(path, name, run_frames(path), "its summary.json's parameters.frames")
        else:
            check_frames(path, name, planned.get(path.parent.relative_to(study).as_posix()),
                         "the archive's recorded options' plan")


FRAMES_COLUMNS = ("frame", "update_ms", "broadphase_ms", "total_ms")  # the report's own


# What a cell that float() reads as NaN or an infinity must hold: a letter of nan or inf,
# a three-digit exponent, 100 digits in a row (a long mantissa overflows too: with a
# two-digit exponent, a shorter one stays below 1e199), an '_' (float() takes PEP 515's
# 1e9_9_9 and 9_9...9: no number a study writes has one), or a character beyond ASCII
# (float() reads any script's decimal digits: 1e\u0664\u0660\u0660).  Only a row with one
# is read cell by cell, so a long CSV costs one scan.
NOT_FINITE_HINT = re.compile(r"[nNiI_]|[eE][+-]?[0-9]{3}|[0-9]{100}|[^\x00-\x7f]")
# The most bytes of a row of a run's frames.csv, a cell: overlap writes numbers of at
# most a few tens of digits (the bound keeps what the report holds of a run to its frames).
MAX_CELL_BYTES = 64


def check_csv_cells(path: pathlib.Path, name: str, max_rows: int = None, source: str = "",
                    rows_of_numbers: bool = False) -> list:
    """Every cell of the CSV file `path` that reads as a number is finite: no NaN or
    infinity (nan, inf, 1e999: no number overlap writes, and one would read as a
    measurement, as in the JSON); at most `max_rows` rows under the header (`source` says
    whose frames those are), and with `rows_of_numbers` (a frames.csv) each of at most
    MAX_CELL_BYTES a cell of the header.  Read a row at a time (its memory is a row's,
    whatever the file's size); returns (the header, the first row)."""
    try:
        return csv_cells(path, name, max_rows, source, rows_of_numbers)
    except csv.Error as error:
        raise BadArchive(f"{name}: not CSV ({one_line(error)[:80]})")


def csv_cells(path: pathlib.Path, name: str, max_rows: int, source: str,
              rows_of_numbers: bool) -> list:
    with open(path, newline="", encoding="utf-8") as f:
        rows = csv.reader(f)
        header = next(rows, None) or []
        first = None
        for count, row in enumerate(rows, start=1):
            first = row if first is None else first
            if max_rows is not None and count > max_rows:
                raise BadArchive(f"{name}: more than its run's {max_rows} frames ({source}) "
                                 "in rows")
            if rows_of_numbers and sum(map(len, row)) > MAX_CELL_BYTES * len(header):
                raise BadArchive(f"{name}: line {rows.line_num} is longer than a row of "
                                 "numbers overlap writes")
            if not NOT_FINITE_HINT.search("".join(row)):
                continue
            for column, cell in zip(header, row):
                try:
                    value = float(cell)
                except ValueError:
                    continue
                if not math.isfinite(value):
                    raise BadArchive(f"{name}: line {rows.line_num}, {one_line(column)[:40]} "
                                     f"{one_line(cell)[:40]!r} is no number a study writes")
    return header, first


def run_frames(path: pathlib.Path) -> int:
    """The frames the run beside `path` (a frames.csv) ran: its summary.json's, or None."""
    try:
        frames = json.loads((path.parent / "summary.json").read_text(encoding="utf-8"),
                            parse_constant=refuse_constant)["parameters"]["frames"]
    except (OSError, ValueError, KeyError, TypeError, RecursionError):
        return None
    return frames if type(frames) is int and 0 <= frames <= 10_000_000 else None


def check_frames(path: pathlib.Path, name: str, max_rows, source: str) -> None:
    """A run's frames.csv holds what the report reads: a header with the columns it reads
    (FRAMES_COLUMNS), then at least one row of as many cells and at most `max_rows` (the
    frames the run ran, by `source`; None: not bounded, a run the report does not read),
    and no cell that reads as NaN or an infinity (check_csv_cells)."""
    header, first = check_csv_cells(path, name, max_rows, source, rows_of_numbers=True)
    if not header:
        raise BadArchive(f"{name}: empty, no header of the frames' columns")
    missing = [column for column in FRAMES_COLUMNS if column not in header]
    if missing:
        raise BadArchive(f"{name}: its header has no {', '.join(missing)} column")
    if first is None or len(first) != len(header):
        raise BadArchive(f"{name}: no frame row under its header")


def unpack(archive: pathlib.Path, out: pathlib.Path, options_of, prepare=None,
           planned_of=None):
    """Unpacks the archive's ./study as `out` (see the rules above) and returns
    (options_of(its invocation log), prepare(options, the unpacked study folder)), both
    called before `out` is touched; planned_of(options, the unpacked study folder) gives
    the frames of each run the report reads (check_runs) before its CSV files are read.
    Each raises BadArchive to refuse the archive
    (prepare makes the report in the scratch folder, so an archive whose runs do not
    hold what it reads is refused with `out` as it was).  Raises BadOut when `out` may
    not be replaced."""
    target = out.resolve()
    replaceable(target, out)
    if not archive.is_file():
        raise BadArchive("not a regular file" if archive.exists() else "no such file")
    if archive.resolve().is_relative_to(target):
        raise BadOut(f"{out}: holds the archive, which replacing it would remove")
    target.parent.mkdir(parents=True, exist_ok=True)
    with contextlib.ExitStack() as held:
        scratch = None
        try:
            # Made and locked at once, signals held: no other unpack takes it for a stale
            # one; a signal held meanwhile arrives as the block ends, inside the `try`
            # whose `finally` removes it.
            with signals_held(), folder_locked(target.parent):
                clear_stale(target.parent, target.name)
                scratch = pathlib.Path(tempfile.mkdtemp(prefix=f".{target.name}.unpack-",
                                                        dir=target.parent))
                held.enter_context(folder_locked(scratch))
            (scratch / SCRATCH_MARKER).touch()
            study = extract(archive, scratch)
            check_stopped()  # a stop some library's `except` swallowed while unpacking
            options = options_of(check_text(study))
            check_runs(study, planned_of(options, study) if planned_of is not None else None)
            prepared = prepare(options, study) if prepare is not None else None
            check_stopped()
            (study / MARKER).write_text(
                f"An unpack of the study archive {one_line(archive.name)} (scripts/study.py "
                "--from-archive): the next unpack into this folder replaces it, while its "
                "log is this one (a study that runs into it makes it a study's folder).\n"
                f"log sha256: {log_digest(study)}\n")
            with folder_locked(target.parent), study_locked(target):
                replaceable(target, out)
                check_stopped()  # the last point before D is replaced
                swap(study, target, scratch / "old")
            return options, prepared
        finally:
            if scratch is not None:
                remove_whole(scratch)


def remove_whole(folder: pathlib.Path) -> None:
    """`folder` removed, signals held; a signal that came just before (its handler runs
    at Python's next step, blocked or not) waits until the folder is gone."""
    stopped = None
    while True:
        try:
            with signals_held():
                shutil.rmtree(folder, ignore_errors=True)
            break
        except Stopped as stop:
            stopped = stop
    if stopped is not None:
        raise stopped


def swap(new: pathlib.Path, target: pathlib.Path, aside: pathlib.Path) -> None:
    """`new` renamed to `target`, a non-empty `target` renamed to `aside` first; no
    signal between the two renames, and `target` back as it was if the second fails.
    Once `target` is the new unpack it is published: the stop signals stay held from
    there on (script_cli.run says that one came after; a caller that goes on to work it
    may stop lets them go itself), so no stop is ever said after D was replaced."""
    before = signal.pthread_sigmask(signal.SIG_BLOCK, STOPS)
    try:
        moved = target.is_dir() and any(target.iterdir())
        if moved:
            os.rename(target, aside)
        try:
            os.rename(new, target)  # over an empty folder, atomically
        except OSError:
            if moved:
                os.rename(aside, target)
            raise
    except BaseException:
        signal.pthread_sigmask(signal.SIG_SETMASK, before)
        raise
