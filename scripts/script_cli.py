"""How every script of scripts/ reads its command line and answers bad input.

Rules, each with its reason:
  * No option is ever abbreviated (allow_abbrev=False): a prefix of an option is an
    unknown option, refused, never another option taken silently (`--repo` is not
    `--report`, and a recorded command line means what it says on every version).
  * Bad input (an option's value, a missing or unreadable file, a file that does
    not hold what the script reads) is one line naming the input and the problem,
    exit 2, and nothing written: argparse's errors are that line too, and main()
    raises BadInput, which run() turns into it.  A traceback is a defect of the
    script, never an answer to its input.
  * SIGINT, SIGTERM and SIGHUP stop a script as they stop `overlap` (docs/CLI.md,
    "Signals"): the first raises Stopped where the script is, so every `finally` and
    `with` removes what the script had half-made; a child it runs (run_child) gets the
    signal too and is waited for, so it removes its own temporaries; then one line and
    exit 128 + the signal.  A repeat within a second of the first is the same request
    (timeout(1) signals the process and then its group) and is dropped; a later one
    ends the script at once, by that signal.
  * A stop is sticky: the handler records it before it raises, and check_stopped()
    raises it again at the script's own safe points (after an unpack, before a
    publication) and run() once main() returns, so a library whose broad `except`
    swallows the raise (tarfile's owner lookup catches KeyError around pwd/grp) never
    loses it: a stopped script never ends as if it had finished.
  * A signal ignored when the script starts (SIG_IGN: under nohup, `trap '' INT`, a
    background job of a non-interactive shell) stays ignored, here and in every child
    (ignored dispositions survive exec): the convention nohup and shells rely on.
  * Running out of memory (MemoryError) is one line, exit 1: the machine's limit, not
    bad input (exit 2) and not a traceback.
  * Once main() has ended (everything published, or the failure known), run() holds the
    stop signals until the process ends: a signal then changes nothing (run() says so when
    it came before it returned), never a death by the first signal in the interpreter's
    teardown, which gives the signals back their default action while modules are still
    being torn down.
"""
import argparse
import errno
import os
import pathlib
import signal
import subprocess
import sys
import time

# An OSError with one of these is about the input named (a path that is not there, or
# not readable); any other (a full disk, an I/O error) is the machine's: exit 1.
INPUT_ERRORS = (errno.ENOENT, errno.EACCES, errno.EPERM, errno.EISDIR, errno.ENOTDIR,
                errno.ELOOP, errno.ENAMETOOLONG)


class BadInput(Exception):
    """An input the script cannot use; the message names it and says why."""


class Failed(Exception):
    """Not the input's fault: the machine's (out of memory, a child that could not start
    or was killed); the message names what failed.  run(): one line, exit 1."""


def signal_name(signum: int) -> str:
    try:
        return signal.Signals(signum).name
    except ValueError:
        return f"signal {signum}"


class Stopped(KeyboardInterrupt):
    """SIGINT, SIGTERM or SIGHUP came (a KeyboardInterrupt, so code that stops on ^C
    stops on each)."""

    def __init__(self, signum: int, note: str = ""):
        super().__init__(signum)
        self.signum, self.note = signum, note  # note: what the stop left, said after it


STOPS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
REPEAT_SECONDS = 1.0  # a signal this soon after the first is the first delivered twice
CHILD_STOP_SECONDS = 30  # how long a signalled child may take to stop before it is killed
_first_stop = []  # (when, signal) of the first stop signal


def _on_stop(signum, frame):
    now = time.monotonic()
    if not _first_stop:
        _first_stop.append((now, signum))
        raise Stopped(signum)
    if now - _first_stop[0][0] < REPEAT_SECONDS:
        return
    signal.signal(signum, signal.SIG_DFL)
    os.kill(os.getpid(), signum)


def stop_on_signals() -> None:
    """Installs the stop rule (above) for SIGINT, SIGTERM and SIGHUP, except for a signal
    that was ignored when the script started: that one stays ignored."""
    for signum in STOPS:
        if signal.getsignal(signum) != signal.SIG_IGN:
            signal.signal(signum, _on_stop)


def stopped_by():
    """The stop signal that came (recorded by the handler, even where a library swallowed
    its Stopped), or None."""
    return _first_stop[0][1] if _first_stop else None


def check_stopped() -> None:
    """Raises Stopped again when a stop signal came: at a script's safe points (before it
    publishes anything), so no library's broad `except` can lose a stop."""
    if _first_stop:
        raise Stopped(_first_stop[0][1])


def run_child(command: list, check: bool = False, capture_output: bool = False,
              **popen) -> subprocess.CompletedProcess:
    """subprocess.run(command, ...) for a child that stops on a signal as overlap does: a
    stop (Stopped) while it runs is sent on to it (unless it came first, to its whole
    process group), then the child is waited for, at most CHILD_STOP_SECONDS, before the
    stop goes on (subprocess.run would kill it at once, leaving its temporaries)."""
    if capture_output:
        popen.update(stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    with subprocess.Popen(command, **popen) as child:
        try:
            stdout, stderr = child.communicate()
        except Stopped as stop:
            if child.poll() is None:
                child.send_signal(stop.signum)  # a repeat, if it had it: dropped there
                try:
                    child.communicate(timeout=CHILD_STOP_SECONDS)
                except subprocess.TimeoutExpired:
                    child.kill()
            raise
    result = subprocess.CompletedProcess(command, child.returncode, stdout, stderr)
    if check:
        result.check_returncode()
    return result


class Parser(argparse.ArgumentParser):
    """argparse without abbreviations, whose errors are one line: `PROG: PROBLEM`."""

    def __init__(self, *args, **kwargs):
        kwargs["allow_abbrev"] = False
        super().__init__(*args, **kwargs)

    def error(self, message: str):
        # one_line: a value quoted in the message may hold a newline of its own.
        self.exit(2, f"{self.prog}: {one_line(message)} (--help lists the options)\n")


def one_line(text: str) -> str:
    """`text` printable on one line: newlines and other control characters escaped."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in str(text))


def shell_word(word: str) -> str:
    """`word` as a shown command line holds it (commands.txt, the report's commands): as it
    is when every character is printable and none a backtick; else in bash's $'...'
    quoting, a tab, a newline, a backtick, a quote or a byte that is not UTF-8 (a surrogate
    here) escaped, so the line stays one line, a Markdown code span holds the word whole,
    and bash reads it back byte for byte (a path a study was given may hold any byte)."""
    word = str(word)
    if all(c.isprintable() and c != "`" for c in word):
        return word
    shown = []
    for c in word:
        if c in "\\'`":
            shown.append("\\" + c if c != "`" else "\\x60")
        elif c in "\t\n\r":
            shown.append({"\t": "\\t", "\n": "\\n", "\r": "\\r"}[c])
        elif c.isprintable():
            shown.append(c)
        else:  # a control character, a surrogate of a byte not UTF-8, U+2028...: its bytes
            shown.extend(f"\\x{b:02x}" for b in c.encode("utf-8", "surrogateescape"))
    return "$'" + "".join(shown) + "'"


def existing_file(text: str) -> pathlib.Path:
    """argparse type: a regular file that can be read."""
    path = pathlib.Path(text)
    if not path.is_file():
        problem = "not a regular file" if path.exists() else "no such file"
        raise argparse.ArgumentTypeError(f"{one_line(text)}: {problem}")
    try:
        with open(path, "rb"):
            pass
    except OSError as error:
        raise argparse.ArgumentTypeError(f"{one_line(text)}: {error.strerror}")
    return path


def existing_folder(text: str) -> pathlib.Path:
    """argparse type: a folder that exists."""
    path = pathlib.Path(text)
    if not path.is_dir():
        raise argparse.ArgumentTypeError(f"{one_line(text)}: not a folder")
    return path


def write_atomically(path: pathlib.Path, text: str) -> None:
    """`text` as the whole of `path`, or `path` as it was: written beside it, then
    renamed over it, so that a signal or a full disk never leaves it half-written."""
    path = pathlib.Path(path)
    temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        # UTF-8 text; a path's byte that is not UTF-8 (a surrogate here) written escaped.
        temporary.write_text(text, encoding="utf-8", errors="backslashreplace")
        os.replace(temporary, path)
    finally:
        temporary.unlink(missing_ok=True)


def _hold_stops() -> None:
    """From here to the process's end, the stop signals wait (and are dropped at exit)."""
    signal.pthread_sigmask(signal.SIG_BLOCK, STOPS)


def _stops_after_the_end() -> list:
    """The stop signals that came once main() had ended, held (those ignored from the
    start, pending as well since a held signal is never ignored, left out)."""
    pending = signal.sigpending()
    return [signum for signum in STOPS if signum in pending and
            signal.getsignal(signum) not in (signal.SIG_IGN, None)]


def run(main, prog: str = None) -> int:
    """main()'s exit status; BadInput, a file that is not UTF-8 text and an OSError on an
    input path are one line naming the input and the problem, exit 2 (another OSError:
    exit 1); a stop signal is one line too, exit 128 + the signal (see the rules).  Once
    main() ends the stop signals are held to the process's end (see the rules)."""
    prog = prog or pathlib.Path(sys.argv[0]).name
    stop_on_signals()
    status = _outcome(main, prog)
    _hold_stops()  # again: a stop raised inside _outcome's own `finally` skipped it there
    late = _stops_after_the_end()
    if late:
        print(f"{prog}: {', '.join(signal_name(s) for s in late)} came after the script had "
              f"ended (exit {status}); it changed nothing", file=sys.stderr)
    return status


def _outcome(main, prog: str) -> int:
    try:
        try:
            status = main() or 0
        finally:
            _hold_stops()  # what main() published stays; no signal interrupts the end
        check_stopped()  # a stop some library swallowed: the script did not finish
        return status
    except MemoryError:
        print(f"{prog}: out of memory (a memory limit, ulimit -v?)", file=sys.stderr)
        return 1
    except Failed as failure:
        print(f"{prog}: {one_line(failure)}", file=sys.stderr)
        return 1
    except BadInput as problem:
        print(f"{prog}: {one_line(problem)}", file=sys.stderr)
        return 2
    except UnicodeDecodeError as error:
        print(f"{prog}: an input is not UTF-8 text (byte {error.start}: "
              f"{one_line(error.reason)})", file=sys.stderr)
        return 2
    except KeyboardInterrupt as stop:
        signum = getattr(stop, "signum", signal.SIGINT)
        note = getattr(stop, "note", "")
        print(f"{prog}: stopped by {signal.Signals(signum).name}"
              + (f"; {one_line(note)}" if note else ""), file=sys.stderr)
        return 128 + signum
    except OSError as error:
        where = error.filename if error.filename is not None else "?"
        print(f"{prog}: {one_line(where)}: {one_line(error.strerror or error)}",
              file=sys.stderr)
        return 2 if error.errno in INPUT_ERRORS else 1
