"""The study's --out folder, shared by every shard that runs at once (`--shard i/k`).

Rules, each with its reason:
  * A job writes only its own paths (its run folder, its CSV): shards split
    the job list, so no two of them write one job's result.
  * A file several shards may write (commands.txt, bf_pairs.csv) is written
    to a temporary of this process's own, then renamed over the name: a
    reader sees the old file or the whole new one, and two writers never
    share a temporary (one's rename would find the other's gone).
  * What every shard reads, changes and writes back (the invocation log) and
    what is written from all the results (the tables, figures and report) is
    done under one lock on OUT/.study.lock: no update is lost, and the shard
    that writes the report last has read every result the others finished.
  * Nothing a process needs only for itself (the GPU probe's run) is written
    into --out: another shard's `overlap` could replace it, or remove it.
  * --out is a study's folder or becomes one: absent, empty, or holding the lock
    or the invocation log that every study writes before anything else
    (foreign_folder_problem); a study never writes its report, commands and
    figures over a folder of the user's (`--out docs` holds docs/REPORT.md).
  * OUT/study_invocations.json is read (read_log) only as the log a study writes: JSON
    with no NaN or number beyond a double, a list of invocations of the shape the report
    reads; any other is bad input naming it, refused before any job runs (and again
    under the lock before each write, since another shard may have written it).
"""
import contextlib
import fcntl
import json
import os
import pathlib
import sys
import tempfile

from script_cli import BadInput, one_line

LOCK_NAME = ".study.lock"
LOG_NAME = "study_invocations.json"


def reached_path(path: pathlib.Path) -> pathlib.Path:
    """Where the kernel puts `path` once the folders missing on its way are made: each
    existing part resolved (links followed from where they stand), a missing one kept as
    written (it will be a folder), `..` the parent of what was reached.  So `nx/..`, nx
    missing, is the current folder, and `link/..` the parent of the link's target; a text
    normalisation (os.path.abspath) gets both wrong."""
    here = pathlib.Path(os.getcwd()) if not path.is_absolute() else pathlib.Path(path.anchor)
    for part in path.parts[1:] if path.is_absolute() else path.parts:
        if part == ".":
            continue
        if part == "..":
            here = here.parent
            continue
        here = here / part
        if os.path.lexists(here):
            here = here.resolve()
    return here


def foreign_folder_problem(out: pathlib.Path) -> str:
    """Why --out `out` is not a study's folder to write into, or "" when it is one.  The
    folder is looked at where the kernel will put it (reached_path), however spelled."""
    out = reached_path(out)
    if not os.path.lexists(out):
        return ""
    if not out.is_dir():
        return "exists and is not a folder"
    try:
        if not any(out.iterdir()):
            return ""
    except OSError as error:
        return f"cannot be read ({error.strerror})"
    if any((out / name).is_file() and not (out / name).is_symlink()
           for name in (LOCK_NAME, LOG_NAME)):
        return ""
    return (f"holds files and is not a study's folder (it has no {LOCK_NAME} or {LOG_NAME}): "
            "a study writes REPORT.md, commands.txt and report/ there; give a new or empty "
            "folder, or an earlier study's")


def unmakable_problem(out: pathlib.Path) -> str:
    """Why a study could not write into --out `out` (make it, or write inside it), or "":
    tried with a scratch folder made and removed in `out` or its nearest existing folder
    (permission bits do not tell root's case, nor /proc's)."""
    here = reached_path(out)
    while not os.path.lexists(here):
        here = here.parent
    if not here.is_dir():
        return f"{one_line(here)} is not a folder"
    try:
        os.rmdir(tempfile.mkdtemp(dir=here, prefix=".study-check-"))
    except OSError as error:
        return f"cannot be written in {one_line(here)} ({error.strerror})"
    return ""


def write_atomically(path: pathlib.Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, partial = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.",
                                       suffix=".partial")
    try:
        # UTF-8 text whatever the locale; a path's byte that is not UTF-8 (an --out of any
        # bytes reads as surrogates here) written escaped, so the file stays text.
        with os.fdopen(handle, "w", encoding="utf-8", errors="backslashreplace") as f:
            f.write(text)
        os.replace(partial, path)
    except BaseException:
        pathlib.Path(partial).unlink(missing_ok=True)
        raise


@contextlib.contextmanager
def locked(out: pathlib.Path):
    """Holds the --out folder's lock (blocking until every other shard has let it go)."""
    out.mkdir(parents=True, exist_ok=True)
    with open(out / LOCK_NAME, "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def read_log(out: pathlib.Path) -> list:
    """OUT/study_invocations.json, checked (see the rules); [] when there is none."""
    import study_archive  # here: study_archive's checks are the archive's and the log's
    path = out / LOG_NAME
    if not path.exists():
        return []
    try:
        log = study_archive.parse_json(path.read_text(encoding="utf-8"))
        study_archive.check_log(log, str(path), foreign=False)
    except RecursionError:
        raise BadInput(f"{one_line(path)}: JSON nested too deep for a study's log")
    except study_archive.BadArchive as problem:
        raise BadInput(one_line(problem))
    except ValueError as error:  # json's errors, UnicodeDecodeError among them
        raise BadInput(f"{one_line(path)}: not the study's log: not JSON ({one_line(error)})")
    return log


def claim_an_unpack(out: pathlib.Path) -> None:
    """A study that logs (and so runs) into an unpack of a study archive makes it a study's
    folder: the unpack's marker goes (under the lock, before the log names a run), so the
    next --from-archive refuses the folder rather than removing runs no unpack made."""
    import study_archive
    marker = out / study_archive.MARKER
    if marker.is_file() and not marker.is_symlink():
        marker.unlink()
        print(f"study: {one_line(out)} was an unpack of a study archive; it is now this "
              "study's folder, which --from-archive no longer replaces", file=sys.stderr)


class InvocationLog:
    """This invocation's entry in OUT/study_invocations.json, beside every other shard's:
    each write re-reads the log under the lock and adds or replaces only this entry (the
    log is only ever appended to, so its place stays its own)."""

    def __init__(self, out: pathlib.Path, entry: dict):
        self.out, self.entry, self.index = out, entry, None

    def write(self) -> None:
        path = self.out / LOG_NAME
        with locked(self.out):
            log = read_log(self.out)
            claim_an_unpack(self.out)
            if self.index is None:
                self.index = len(log)
                log.append(self.entry)
            else:
                log[self.index] = self.entry
            write_atomically(path, json.dumps(log, indent=1) + "\n")
