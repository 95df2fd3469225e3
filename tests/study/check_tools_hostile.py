"""The study's tool scripts against hostile input (probe48s): study_slurm.sh (a faked
Slurm), gpu_check.sh --dry-run (a scratch checkout whose build-emulation/ is this
build), thread_scaling.py and plot_run.py.  One behaviour per --case (each a ctest test
study.CASE, tests/study/CMakeLists.txt):

  slurm_stop_keeps_a_folder_filled_meanwhile   a stop of study_slurm.sh during its check
                                  removes no --out that another submission or a study
                                  made or filled meanwhile (it made none itself)
  slurm_wait_gives_the_report_jobs_status   --wait: the report job's own exit status, a
                                  failed job named as one that ran, not as refused
  slurm_stop_while_waiting_cancels_nothing   a stop while --wait waits: at once, 143,
                                  both jobs named as going on, nothing cancelled
  slurm_missing_option_value_one_line   a missing or empty option value: one line of
                                  the script's own, exit 2, nothing made
  slurm_group_stop_says_what_goes_on   a stop while --wait waits or the report job is
                                  submitted, to the script or its group (sbatch ended
                                  too): 128 + N and its one line, never errexit's 1
  slurm_shards_job_id_checked     the shards' sbatch printing no job id (nothing, a
                                  sentence, two lines): exit 1, one line, no report job,
                                  the --out made removed
  slurm_sbatch_failure_one_line   an sbatch refusing or killed: one line of the script's
                                  own (exit 1), no bash notice, the --out made removed
  slurm_stop_while_shards_submit_cancels_them   a stop to the script while the shards'
                                  sbatch runs: its job (known once sbatch ended) cancelled
  slurm_failed_submission_keeps_anothers_out   a failing submission removes no --out
                                  another submission into it went through with
  slurm_temporary_made_before_submitting   no temporary: one line, nothing submitted
  slurm_cancel_failure_said       scancel refusing or missing: the job named NOT cancelled
  slurm_second_stop_waits_for_the_first   a second stop during the trap: its line all
                                  the same
  slurm_group_stop_while_out_is_made   a group stop while --out is made: none left
  slurm_report_id_unread_is_not_refused   the report's sbatch exiting 0 with no id read:
                                  not named refused, squeue named to look for it
  slurm_shards_id_then_failure_is_submitted   an id printed, then a failure: submitted
  slurm_job_id_is_the_whole_output   a NUL, a second line, 21 digits: no job id
  slurm_unwritten_job_record_goes_on   slurm/ removed while the shards' sbatch runs, or
                                  another login node's submission with the same PID: the
                                  shards' job named, its report job submitted, exit 0
  slurm_stop_while_job_is_recorded   a stop while slurm/job-ID is written: its line, the
                                  job cancelled, its record and the claim removed
  slurm_cancel_bounded_without_timeout   a scancel that hangs, timeout(1) on PATH or not:
                                  'did not answer in 10 s' within the bound
  slurm_stop_once_out_is_said_undoes_it   a group stop after the folder check printed
                                  what it made, before bash read it: none left
  slurm_stale_claims_named        claims of submissions from this host that do not run:
                                  removed where the PID is no process, else named
  slurm_temporary_folder_like_an_option   TMPDIR=-dash (a relative folder): it works
  slurm_odd_files_in_slurm_not_read   a FIFO and a link to /dev/zero among the claims:
                                  the submission goes through, neither read
  gpu_resume_archive_checked_before_unpacking   gpu_check.sh --study: a resume archive
                                  with a link, an absolute or '..' name is refused (exit
                                  2, one line) before an earlier run is touched, nothing
                                  written outside OUT; a good one is unpacked
  gpu_check_environment_numbers_checked_first   DEADLINE_S, STUDY_SHARDS, CTEST_JOBS
                                  not plain digits: exit 2, one line, the earlier run kept
  thread_scaling_provenance_stays_comments   a binary whose name holds a newline: the
                                  CSV read back has its own header and every '#' line
  plot_run_refuses_numbers_no_run_writes   inf, nan, 1e999, a negative in frames.csv:
                                  exit 2, one line naming file, line and column, no PNG
  plot_run_refuses_a_frame_time_no_run_has   summary.json's frame_time NaN, infinite,
                                  negative, zero or a string: exit 2, one line, no PNG
  plot_run_names_an_unreadable_file   a summary.json not JSON (or not an object, not
                                  UTF-8), a frames.csv not UTF-8: exit 2, one line
                                  naming the file, no PNG

--scripts FOLDER runs the cases against another copy of scripts/ (an old version, to see
a case fail).  Exit 77 (ctest's skip) when a case needs what this machine lacks.
"""
import importlib.util
import io
import json
import os
import pathlib
import shutil
import signal
import subprocess
import sys
import tarfile
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from check_hostile import (NO_RUNS, PYTHON, REPO, add, archive, check, fake_sbatch,  # noqa: E402
                           run_case)

SCRIPTS = REPO / "scripts"


def skip(reason: str) -> None:
    print(f"skipped: {reason}")
    sys.exit(77)


def one_line_exit(result, code: int, *words, prefix: str = "") -> None:
    """Exit `code` and one line (of those starting with `prefix`: the study's own check
    says what it checked) holding each of `words`."""
    stderr = result.stderr if isinstance(result.stderr, str) else result.stderr.decode()
    check(result.returncode == code, f"exit {result.returncode}, expected {code}:\n{stderr}")
    said = [line for line in stderr.splitlines() if line.startswith(prefix)]
    check(len(said) == 1 and "Traceback" not in stderr, f"not one line:\n{stderr}")
    for word in words:
        check(word in stderr, f"{word!r} not in {stderr!r}")


# --- study_slurm.sh against a faked Slurm ---------------------------------------------

def fake_slurm(work: pathlib.Path) -> tuple:
    """sbatch records its argv (calls/callN, or in FAKE_CALLS where that is set), prints
    job 4242+N; with --wait it sleeps FAKE_WAIT_S (1) and exits FAKE_WAIT_RC (0), the
    job's status as sbatch(1) says.  The shards' call (call0) prints FAKE_SHARDS_PRINTS
    instead of its id where that is set (FAKE_SHARDS_FORMAT: a printf format, for a NUL),
    then exits FAKE_SHARDS_RC (0; an error line first where it is not 0); the report's
    (call1) prints FAKE_REPORT_PRINTS where that is set; call N ends by SIGKILL before it
    prints anything where FAKE_KILLED is N, after its id where FAKE_KILLED_AFTER_ID is N;
    it sleeps FAKE_SLOW_S (3) before its id where FAKE_SLOW is N; once call N has printed,
    WORK/doneN exists.  scancel appends its argv to scancel.log, sleeps FAKE_SCANCEL_SLOW
    seconds where that is set, then exits FAKE_SCANCEL_RC (0; an error line first where it
    is not 0)."""
    calls = work / "calls"
    calls.mkdir()
    env = fake_sbatch(work, f"c=\"${{FAKE_CALLS:-{calls}}}\"; n=$(ls \"$c\" | wc -l)\n"
                      "printf '%s\\n' \"$@\" > \"$c\"/call$n\n"
                      "[ \"${FAKE_KILLED-}\" = $n ] && kill -9 $$\n"
                      "[ \"${FAKE_SLOW-}\" = $n ] && sleep \"${FAKE_SLOW_S:-3}\"\n"
                      "if [ $n = 0 ] && [ -n \"${FAKE_SHARDS_FORMAT+set}\" ]; then\n"
                      "  printf \"$FAKE_SHARDS_FORMAT\"\n"
                      "elif [ $n = 0 ] && [ -n \"${FAKE_SHARDS_PRINTS+set}\" ]; then\n"
                      "  printf '%s' \"$FAKE_SHARDS_PRINTS\"\n"
                      "elif [ $n = 1 ] && [ -n \"${FAKE_REPORT_PRINTS+set}\" ]; then\n"
                      "  printf '%s' \"$FAKE_REPORT_PRINTS\"; else echo $((4242 + n)); fi\n"
                      f": > '{work}/done'$n\n"
                      "[ \"${FAKE_KILLED_AFTER_ID-}\" = $n ] && kill -9 $$\n"
                      "if [ $n = 0 ] && [ \"${FAKE_SHARDS_RC:-0}\" != 0 ]; then\n"
                      "  echo 'sbatch: error: Batch job submission failed' >&2\n"
                      "  exit \"$FAKE_SHARDS_RC\"; fi\n"
                      "for a; do [ \"$a\" = --wait ] && { "
                      "trap 'kill $! 2> /dev/null; exit 143' TERM; "
                      "sleep \"${FAKE_WAIT_S:-1}\" & wait $!; "
                      "exit \"${FAKE_WAIT_RC:-0}\"; }; done\nexit 0")
    scancel = work / "bin" / "scancel"
    scancel.write_text(f"#!/bin/sh\necho \"$@\" >> '{work}/scancel.log'\n"
                       "[ -z \"${FAKE_SCANCEL_SLOW-}\" ] || sleep \"$FAKE_SCANCEL_SLOW\"\n"
                       "[ \"${FAKE_SCANCEL_RC:-0}\" = 0 ] || { echo \"scancel: error: Kill job "
                       "error on job id $1: Access/permission denied\" >&2; "
                       "exit \"$FAKE_SCANCEL_RC\"; }\n")
    scancel.chmod(0o755)
    return env, calls


def slurm_command(args, out, *more) -> list:
    return [str(args.scripts / "study_slurm.sh"), "--out", str(out), "--shards", "2",
            "--profile", "quick", *more, "--", "--overlap", args.overlap, *NO_RUNS[1:]]


def case_slurm_stop_keeps_a_folder_filled_meanwhile(args) -> None:
    """--out absent at study_slurm.sh's start; while its check runs (a slow PYTHON),
    another submission and its shards make and fill it; a SIGTERM then: exit 143, and
    every file of theirs is still there."""
    work = args.out
    env, calls = fake_slurm(work)
    started = work / "python_started"
    slow = work / "slowpy"
    slow.write_text(f"#!/bin/sh\ntouch '{started}'\nsleep 3\nexec {PYTHON} \"$@\"\n")
    slow.chmod(0o755)
    out = work / "shared"
    process = subprocess.Popen(slurm_command(args, out), stdout=subprocess.DEVNULL,
                               stderr=subprocess.PIPE, text=True, env={**env, "PYTHON": str(slow)})
    deadline = time.monotonic() + 60
    while not started.exists() and time.monotonic() < deadline:
        time.sleep(0.05)
    # What another submission and its first shard leave there meanwhile.
    (out / "slurm").mkdir(parents=True)
    (out / ".study.lock").touch()
    (out / "slurm" / "shard-1.log").write_text("another submission's shard\n")
    (out / "study_invocations.json").write_text("[]\n")
    (out / "sweep" / "s1_n40_bf_r0").mkdir(parents=True)
    (out / "sweep" / "s1_n40_bf_r0" / "summary.json").write_text("{}\n")
    before = sorted(p.relative_to(out).as_posix() for p in out.rglob("*"))
    process.send_signal(signal.SIGTERM)
    _, stderr = process.communicate(timeout=60)
    check(process.returncode == 128 + signal.SIGTERM and "nothing submitted" in stderr,
          f"exit {process.returncode}:\n{stderr}")
    after = sorted(p.relative_to(out).as_posix() for p in out.rglob("*")) if out.exists() else []
    check(after == before, f"--out filled meanwhile lost {sorted(set(before) - set(after))}")
    check(not any(calls.iterdir()), "submitted after the stop")
    # The same, --out made meanwhile but left empty by the other: it is not this script's.
    shutil.rmtree(out)
    started.unlink()
    process = subprocess.Popen(slurm_command(args, out), stdout=subprocess.DEVNULL,
                               stderr=subprocess.PIPE, text=True, env={**env, "PYTHON": str(slow)})
    while not started.exists() and time.monotonic() < deadline + 60:
        time.sleep(0.05)
    out.mkdir()
    process.send_signal(signal.SIGTERM)
    _, stderr = process.communicate(timeout=60)
    check(process.returncode == 128 + signal.SIGTERM and out.is_dir(),
          f"an --out made by another removed: exit {process.returncode}:\n{stderr}")


def case_slurm_wait_gives_the_report_jobs_status(args) -> None:
    """study_slurm.sh --wait returns the report job's exit status: 0 when it ended well;
    a job that ran and failed (sbatch --wait exits with its status, 2 here) is named as
    the report job that ended with that status, not as a refused submission."""
    work = args.out
    env, calls = fake_slurm(work)
    out = work / "st"
    result = subprocess.run(slurm_command(args, out, "--wait"), capture_output=True, text=True,
                            env={**env, "FAKE_WAIT_RC": "2"}, timeout=120)
    one_line_exit(result, 2, "report job 4243", "exit status 2", prefix="study_slurm:")
    check("refused" not in result.stderr, f"a job that ran, named refused: {result.stderr}")
    check("4243" in result.stdout, f"the report job's id not said: {result.stdout}")
    check(not (work / "scancel.log").exists(), "cancelled a job")
    shutil.rmtree(calls)
    calls.mkdir()
    result = subprocess.run(slurm_command(args, out, "--wait"), capture_output=True, text=True,
                            env=env, timeout=120)
    check(result.returncode == 0 and "study_slurm" not in result.stderr and
          "4243" in result.stdout,
          f"a report that ended well: exit {result.returncode}:\n{result.stderr}")
    # A refusal by sbatch (no job id) is still named as one, exit 1.
    (work / "bin" / "sbatch").write_text(
        f"#!/bin/sh\nn=$(ls '{calls}' | wc -l)\ntouch '{calls}'/call$n\n"
        "[ $n = 0 ] && { echo 4242; exit 0; }\necho 'sbatch: error: refused' >&2; exit 1\n")
    shutil.rmtree(calls)
    calls.mkdir()
    result = subprocess.run(slurm_command(args, out, "--wait"), capture_output=True, text=True,
                            env=env, timeout=120)
    check(result.returncode == 1 and "sbatch refused the report job" in result.stderr,
          f"a refused report job: exit {result.returncode}:\n{result.stderr}")


def case_slurm_stop_while_waiting_cancels_nothing(args) -> None:
    """A SIGTERM to study_slurm.sh (not its group) while --wait waits for the report job:
    handled at once (not when the job ends), exit 143, one line naming both jobs as
    submitted and going on; scancel never runs."""
    work = args.out
    env, calls = fake_slurm(work)
    said = work / "stderr"
    with open(said, "w") as stderr_file:  # a file: a fake's orphaned sleep holds no pipe
        process = subprocess.Popen(slurm_command(args, work / "st", "--wait"),
                                   stdout=subprocess.DEVNULL, stderr=stderr_file,
                                   env={**env, "FAKE_WAIT_S": "30"})
    deadline = time.monotonic() + 90
    while not (calls / "call1").exists() and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(1)
    sent = time.monotonic()
    process.send_signal(signal.SIGTERM)
    process.wait(timeout=60)
    took = time.monotonic() - sent
    stderr = said.read_text()
    lines = [line for line in stderr.splitlines() if line.startswith("study_slurm:")]
    check(process.returncode == 128 + signal.SIGTERM and len(lines) == 1 and
          "4242" in lines[0] and "4243" in lines[0] and "go on" in lines[0],
          f"exit {process.returncode}:\n{stderr}")
    check(took < 10, f"the stop was handled {took:.0f} s after the signal")
    check(not (work / "scancel.log").exists(),
          f"cancelled: {(work / 'scancel.log').read_text() if (work / 'scancel.log').exists() else ''}")


def case_slurm_missing_option_value_one_line(args) -> None:
    """An option of study_slurm.sh with its value missing or empty: one line of the
    script's own naming the option (not bash's 'line N: ...'), exit 2, nothing made or
    submitted."""
    work = args.out
    env, calls = fake_slurm(work)
    slurm = str(args.scripts / "study_slurm.sh")
    out = str(work / "sl")
    for words, named in [(["--out", "", "--shards", "2"], "--out needs a folder"),
                         (["--shards", "2", "--out"], "--out needs a folder"),
                         (["--out", out, "--shards", ""], "--shards needs a count"),
                         (["--out", out, "--shards"], "--shards needs a count"),
                         (["--out", out, "--shards", "2", "--profile", ""], "--profile needs"),
                         (["--out", out, "--shards", "2", "--profile"], "--profile needs"),
                         (["--out", out, "--shards", "2", "--sbatch"], "--sbatch needs")]:
        result = subprocess.run([slurm, *words], capture_output=True, text=True, env=env,
                                timeout=60)
        check(result.stderr.startswith("study_slurm: "), f"{words}: {result.stderr!r}")
        one_line_exit(result, 2, named)
        check(not any(calls.iterdir()) and not os.path.lexists(out), f"{words}: went on")


def case_slurm_group_stop_says_what_goes_on(args) -> None:
    """SIGTERM, SIGHUP and SIGINT while --wait waits for the report job, to
    study_slurm.sh alone and to its whole process group (which ends the fake sbatch
    --wait too, before the trap's own kill): exit 128 + N, one line naming both jobs as
    going on, nothing cancelled; never the trap ended early by errexit (exit 1, no word).
    The same stops while the report job's sbatch submits: to the script alone, it waits
    for the id, then the same line; a TERM or HUP to the group, which ends sbatch before
    its id, cancels the shards' job and says so."""
    work = args.out
    env, calls = fake_slurm(work)
    said, shown = work / "stderr", work / "stdout"
    for waiting, fake in [(True, {"FAKE_WAIT_S": "30"}), (False, {"FAKE_SLOW": "1"})]:
        for sig, group in [(sig, group) for group in (False, True)
                           for sig in (signal.SIGTERM, signal.SIGHUP, signal.SIGINT)]:
            # (an INT to the group reaches no sbatch: bash starts its & jobs with INT ignored)
            goes_on = waiting or not group or sig == signal.SIGINT
            words = ["4242", "4243", "go on"] if goes_on else ["4242", "is cancelled"]
            shutil.rmtree(calls)
            calls.mkdir()
            (work / "scancel.log").unlink(missing_ok=True)
            # Files, not pipes: a fake's orphaned sleep holds none; a session of its own,
            # so that the group's signal reaches this test not.
            with open(said, "w") as stderr_file, open(shown, "w") as stdout_file:
                process = subprocess.Popen(slurm_command(args, work / "st", "--wait"),
                                           stdout=stdout_file, stderr=stderr_file,
                                           env={**env, **fake}, start_new_session=True)
            try:
                deadline = time.monotonic() + 90
                while (("waiting for it to end" not in shown.read_text() if waiting else
                        not (calls / "call1").exists()) and
                       process.poll() is None and time.monotonic() < deadline):
                    time.sleep(0.05)
                time.sleep(0.3)  # into the wait for sbatch (--wait, or its submission)
                if group:
                    os.killpg(process.pid, sig)
                else:
                    process.send_signal(sig)
                process.wait(timeout=60)
            finally:
                try:
                    os.killpg(process.pid, signal.SIGKILL)  # what the fake left running
                except ProcessLookupError:
                    pass
            stderr = said.read_text()
            lines = [line for line in stderr.splitlines() if line.startswith("study_slurm:")]
            to = (f"{sig.name} to the {'group' if group else 'script alone'} while "
                  f"{'waiting' if waiting else 'the report job is submitted'}")
            check(process.returncode == 128 + sig and len(lines) == 1 and
                  all(word in lines[0] for word in words),
                  f"{to}: exit {process.returncode}:\n{stderr}")
            log = work / "scancel.log"
            cancelled = log.read_text() if log.exists() else ""
            check(cancelled == ("" if goes_on else "4242\n"), f"{to}: cancelled {cancelled!r}")


def case_slurm_shards_job_id_checked(args) -> None:
    """The shards' sbatch exits 0 but prints no job id, a line that is not one or two
    lines: exit 1, one line saying so with what it printed, no report job submitted (no
    --dependency=afterok: on no id), the --out this call made removed."""
    work = args.out
    env, calls = fake_slurm(work)
    out = work / "st"
    for printed in ["", "Submitted batch job 4243\n", "4242\n4243\n", "4242x\n"]:
        shutil.rmtree(calls)
        calls.mkdir()
        result = subprocess.run(slurm_command(args, out), capture_output=True, text=True,
                                env={**env, "FAKE_SHARDS_PRINTS": printed}, timeout=120)
        one_line_exit(result, 1, "sbatch printed no job id for the shards",
                      "squeue --name overlap-study", prefix="study_slurm:")
        words = printed.rstrip("\n").replace("\n", "\\n")
        check(words in result.stderr, f"{printed!r}: what sbatch printed not said: "
              f"{result.stderr!r}")
        check(sorted(path.name for path in calls.iterdir()) == ["call0"],
              f"{printed!r}: the report job submitted: "
              f"{[path.read_text() for path in sorted(calls.iterdir())][1:]}")
        check(not os.path.lexists(out), f"{printed!r}: --out left: "
              f"{sorted(p.name for p in out.rglob('*'))}")


def case_slurm_sbatch_failure_one_line(args) -> None:
    """The shards' sbatch refusing (exit 1) or ended by SIGKILL: exit 1, one line of the
    script's own (no set -e end on sbatch's line alone, no 137), the --out this call made
    removed, no report job; the report job's sbatch ended by SIGKILL, before or after
    its id: exit 1, one line naming the shards' job, and no bash notice ('line N: ...
    Killed') beside it."""
    work = args.out
    env, calls = fake_slurm(work)
    out = work / "st"

    def own_lines_only(result) -> bool:  # the study's check's lines, then the script's
        return all(line.startswith(("study:", "study_slurm:"))
                   for line in result.stderr.splitlines())

    def submit(more, *words, **fake):
        shutil.rmtree(calls)
        calls.mkdir()
        result = subprocess.run(slurm_command(args, out, *more), capture_output=True,
                                text=True, env={**env, **fake}, timeout=120)
        one_line_exit(result, 1, *words, prefix="study_slurm:")
        return result

    result = submit([], "sbatch refused the shards (exit 1); nothing submitted",
                    FAKE_SHARDS_PRINTS="", FAKE_SHARDS_RC="1")
    check("sbatch: error:" in result.stderr, f"sbatch's own line lost: {result.stderr!r}")
    check(sorted(path.name for path in calls.iterdir()) == ["call0"], "submitted on")
    check(not os.path.lexists(out), "a refused submission left its --out")
    result = submit([], "SIGKILL", "shards", "squeue --name overlap-study", FAKE_KILLED="0")
    check(own_lines_only(result),
          f"not the script's own line alone: {result.stderr!r}")
    check(sorted(path.name for path in calls.iterdir()) == ["call0"], "submitted on")
    check(not os.path.lexists(out), "a killed sbatch's --out left")
    for more in ([], ["--wait"]):
        result = submit(more, "SIGKILL", "report job", "4242", FAKE_KILLED="1")
        check(own_lines_only(result),
              f"{more}: not the script's own line alone: {result.stderr!r}")
        check((out / "slurm").is_dir(), f"{more}: the shards' logs folder removed")
    result = submit([], "report job 4243", FAKE_KILLED_AFTER_ID="1")
    check(own_lines_only(result),
          f"killed after its id: not the script's own line alone: {result.stderr!r}")
    # --wait: 128 + N is the job's status or sbatch's end by a signal; the line says both.
    shutil.rmtree(calls)
    calls.mkdir()
    result = subprocess.run(slurm_command(args, out, "--wait"), capture_output=True, text=True,
                            env={**env, "FAKE_KILLED_AFTER_ID": "1"}, timeout=120)
    one_line_exit(result, 137, "report job 4243", "SIGKILL", prefix="study_slurm:")
    check(own_lines_only(result),
          f"--wait, killed after its id: not the script's own line alone: {result.stderr!r}")


def slurm_stopped(args, out, fake, env, until, sig, group=False, again=None, more=()):
    """study_slurm.sh run in a session of its own (stdout, stderr to files), `sig` sent to
    it (or its group) once `until()` holds, `again` 1 s later where given: (exit, stderr,
    scancel.log's text)."""
    work = args.out
    said, shown = work / "stderr", work / "stdout"
    (work / "scancel.log").unlink(missing_ok=True)
    with open(said, "w") as stderr_file, open(shown, "w") as stdout_file:
        process = subprocess.Popen(slurm_command(args, out, *more), stdout=stdout_file,
                                   stderr=stderr_file, env={**env, **fake},
                                   start_new_session=True)
    try:
        deadline = time.monotonic() + 90
        while not until() and process.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
        time.sleep(0.3)
        for each in (sig, again):
            if each is None:
                continue
            try:
                os.killpg(process.pid, each) if group else process.send_signal(each)
            except ProcessLookupError:
                pass
            time.sleep(1)
        process.wait(timeout=60)
    finally:
        try:
            os.killpg(process.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    log = work / "scancel.log"
    return process.returncode, said.read_text(), log.read_text() if log.exists() else ""


def own_line(stderr: str) -> list:
    return [line for line in stderr.splitlines() if line.startswith("study_slurm:")]


def case_slurm_stop_while_shards_submit_cancels_them(args) -> None:
    """A stop (INT, TERM, HUP) to study_slurm.sh alone while the shards' sbatch submits:
    bash runs the trap once sbatch has ended, with its id: the shards' job is cancelled
    and named, exit 128 + N, no 'squeue --name overlap-study' to scancel from.  Sent
    to the group (sbatch ended before its id): nothing submitted, the --out made removed."""
    work = args.out
    env, calls = fake_slurm(work)
    out = work / "st"
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        for group in (False, True):
            shutil.rmtree(calls)
            calls.mkdir()
            shutil.rmtree(out, ignore_errors=True)
            code, stderr, cancelled = slurm_stopped(
                args, out, {"FAKE_SLOW": "0", "FAKE_SLOW_S": "2"}, env,
                lambda: (calls / "call0").exists(), sig, group)
            to = f"{sig.name} to the {'group' if group else 'script'}"
            lines = own_line(stderr)
            check(code == 128 + sig and len(lines) == 1 and "squeue" not in lines[0],
                  f"{to}: exit {code}:\n{stderr}")
            if group:
                check("nothing submitted" in lines[0] and not cancelled and
                      not os.path.lexists(out), f"{to}: {stderr} {cancelled!r}")
            else:
                check("4242" in lines[0] and "is cancelled" in lines[0] and
                      cancelled == "4242\n", f"{to}: {stderr} cancelled {cancelled!r}")
            check(sorted(path.name for path in calls.iterdir()) == ["call0"],
                  f"{to}: the report job submitted")


def case_slurm_failed_submission_keeps_anothers_out(args) -> None:
    """Submission A makes --out, its shards' sbatch is slow and then refuses (or prints
    no id); meanwhile submission B into the same --out goes through: A exits 1, and
    B's --out (the lock, slurm/ with B's job kept there) is still there."""
    work = args.out
    env, calls = fake_slurm(work)
    out = work / "shared"
    calls_b = work / "calls_b"
    for fake in ({"FAKE_SHARDS_RC": "1", "FAKE_SHARDS_PRINTS": ""}, {"FAKE_SHARDS_PRINTS": ""}):
        shutil.rmtree(calls)
        calls.mkdir()
        shutil.rmtree(calls_b, ignore_errors=True)
        calls_b.mkdir()
        shutil.rmtree(out, ignore_errors=True)
        a = subprocess.Popen(slurm_command(args, out), stdout=subprocess.DEVNULL,
                             stderr=subprocess.PIPE, text=True,
                             env={**env, **fake, "FAKE_SLOW": "0", "FAKE_SLOW_S": "4"})
        deadline = time.monotonic() + 60
        while not (calls / "call0").exists() and time.monotonic() < deadline:
            time.sleep(0.02)
        b = subprocess.run(slurm_command(args, out), capture_output=True, text=True,
                           env={**env, "FAKE_CALLS": str(calls_b)}, timeout=60)
        _, a_said = a.communicate(timeout=60)
        check(b.returncode == 0 and a.returncode == 1, f"{fake}: A exit {a.returncode}, "
              f"B exit {b.returncode}:\n{a_said}\n{b.stderr}")
        check((out / ".study.lock").is_file() and (out / "slurm" / "job-4242").is_file(),
              f"{fake}: B's --out removed by A's failure: "
              f"{sorted(p.name for p in out.rglob('*')) if out.exists() else 'gone'}")


def case_slurm_temporary_made_before_submitting(args) -> None:
    """TMPDIR missing (no temporary for what sbatch prints): one line saying so, exit 1,
    nothing submitted, no --out made."""
    work = args.out
    env, calls = fake_slurm(work)
    out = work / "st"
    result = subprocess.run(slurm_command(args, out), capture_output=True, text=True,
                            env={**env, "TMPDIR": str(work / "no_such_folder")}, timeout=120)
    one_line_exit(result, 1, "temporary", "nothing submitted", prefix="study_slurm:")
    check(not any(calls.iterdir()), "submitted without a temporary")
    check(not os.path.lexists(out), "--out left")


def case_slurm_cancel_failure_said(args) -> None:
    """A stop to the group while the report job's sbatch submits (its id never printed):
    scancel refusing, or missing from PATH: the shards' job named as NOT cancelled, with
    scancel's error and the scancel to run; a working scancel: 'is cancelled'."""
    work = args.out
    env, calls = fake_slurm(work)
    out = work / "st"
    fake = {"FAKE_SLOW": "1", "FAKE_SLOW_S": "5"}

    def stop(more):
        shutil.rmtree(calls)
        calls.mkdir()
        return slurm_stopped(args, out, {**fake, **more}, env,
                             lambda: (calls / "call1").exists(), signal.SIGTERM, group=True)

    code, stderr, cancelled = stop({"FAKE_SCANCEL_RC": "1"})
    lines = own_line(stderr)
    check(code == 143 and len(lines) == 1 and "NOT cancelled" in lines[0] and
          "Access/permission denied" in lines[0] and "scancel 4242" in lines[0] and
          cancelled == "4242\n", f"scancel refusing: exit {code}:\n{stderr}")
    scancel = work / "bin" / "scancel"
    scancel.rename(work / "scancel.away")
    try:
        if shutil.which("scancel", path=env["PATH"]) is None:
            code, stderr, cancelled = stop({})
            lines = own_line(stderr)
            check(code == 143 and len(lines) == 1 and "NOT cancelled" in lines[0] and
                  "scancel 4242" in lines[0], f"no scancel: exit {code}:\n{stderr}")
    finally:
        (work / "scancel.away").rename(scancel)
    code, stderr, cancelled = stop({})
    check(code == 143 and "is cancelled" in stderr and cancelled == "4242\n",
          f"scancel working: exit {code}:\n{stderr}")


def case_slurm_second_stop_waits_for_the_first(args) -> None:
    """A SIGTERM (or SIGHUP) to study_slurm.sh while the report job's sbatch submits, a
    second one 1 s later while the trap waits for its id: the trap's line all the same
    (both jobs named as going on), exit 128 + N of the first."""
    work = args.out
    env, calls = fake_slurm(work)
    for sig in (signal.SIGTERM, signal.SIGHUP):
        shutil.rmtree(calls)
        calls.mkdir()
        code, stderr, cancelled = slurm_stopped(
            args, work / "st", {"FAKE_SLOW": "1", "FAKE_SLOW_S": "4"}, env,
            lambda: (calls / "call1").exists(), sig, again=sig)
        lines = own_line(stderr)
        check(code == 128 + sig and len(lines) == 1 and "4243" in lines[0] and
              "go on" in lines[0] and not cancelled, f"{sig.name} twice: exit {code}:\n{stderr}")


def case_slurm_group_stop_while_out_is_made(args) -> None:
    """A stop to the group while the folder check makes --out (slow storage: a sleep after
    its lock is made, before it has said what it made): exit 128 + N, 'nothing
    submitted', and no folder of it left."""
    work = args.out
    env, calls = fake_slurm(work)
    site, made = work / "site", work / "made"
    site.mkdir()
    (site / "sitecustomize.py").write_text(
        "import os, pathlib, time\n"
        "_touch = pathlib.Path.touch\n"
        "def touch(self, *args, **kwargs):\n"
        "    _touch(self, *args, **kwargs)\n"
        f"    open({str(made)!r}, 'w').close()\n"
        "    time.sleep(3)\n"
        "pathlib.Path.touch = touch\n")
    slow = work / "slowpy"
    slow.write_text(f"#!/bin/sh\nPYTHONPATH=\"${{PYTHONPATH:+$PYTHONPATH:}}{site}\" "
                    f"exec {PYTHON} \"$@\"\n")
    slow.chmod(0o755)
    out = work / "new" / "deep"
    for sig in (signal.SIGTERM, signal.SIGHUP, signal.SIGINT):
        made.unlink(missing_ok=True)
        code, stderr, _ = slurm_stopped(args, out, {"PYTHON": str(slow)}, env, made.exists,
                                        sig, group=True)
        lines = own_line(stderr)
        check(code == 128 + sig and len(lines) == 1 and "nothing submitted" in lines[0] and
              "Traceback" not in stderr, f"{sig.name}: exit {code}:\n{stderr}")
        check(not os.path.lexists(work / "new"), f"{sig.name}: left "
              f"{sorted(str(p.relative_to(work)) for p in (work / 'new').rglob('*'))}")
        check(not any(calls.iterdir()), f"{sig.name}: submitted")


def case_slurm_report_id_unread_is_not_refused(args) -> None:
    """The report's sbatch exits 0 but prints no id it reads ('4243\\r\\n', nothing): exit
    1, one line naming squeue --name overlap-study-report to look for it, never
    'refused'; an sbatch refusing (exit 1) is still 'refused', its advice in sh quoting."""
    work = args.out
    env, calls = fake_slurm(work)
    out = work / "st"
    for printed in ["4243\r\n", ""]:
        shutil.rmtree(calls)
        calls.mkdir()
        result = subprocess.run(slurm_command(args, out), capture_output=True, text=True,
                                env={**env, "FAKE_REPORT_PRINTS": printed}, timeout=120)
        one_line_exit(result, 1, "squeue --name overlap-study-report", "4242",
                      prefix="study_slurm:")
        check(not any("refused" in line for line in own_line(result.stderr)),
              f"{printed!r}: named refused: {result.stderr}")


def case_slurm_shards_id_then_failure_is_submitted(args) -> None:
    """The shards' sbatch prints its id, then exits 1 or is killed: the job is taken as
    submitted, its report job submitted after it (afterok on it), a line with sbatch's
    status, slurm/ kept."""
    work = args.out
    env, calls = fake_slurm(work)
    out = work / "st"
    for fake, said in [({"FAKE_SHARDS_PRINTS": "4242\n", "FAKE_SHARDS_RC": "1"}, "exited 1"),
                       ({"FAKE_KILLED_AFTER_ID": "0"}, "SIGKILL")]:
        shutil.rmtree(calls)
        calls.mkdir()
        shutil.rmtree(out, ignore_errors=True)
        result = subprocess.run(slurm_command(args, out), capture_output=True, text=True,
                                env={**env, **fake}, timeout=120)
        check((calls / "call1").exists() and
              "--dependency=afterok:4242" in (calls / "call1").read_text(),
              f"{fake}: no report job after the shards' 4242:\n{result.stderr}")
        check(any("4242" in line and said in line for line in own_line(result.stderr)) and
              "nothing submitted" not in result.stderr, f"{fake}: {result.stderr}")
        check((out / "slurm").is_dir(), f"{fake}: the shards' logs folder removed")


def case_slurm_job_id_is_the_whole_output(args) -> None:
    """The shards' id only where all sbatch printed is one line of up to 20 digits (and
    ';cluster'): '12 NUL 3', '4242;c' then a line, 21 digits: 'printed no job id', no
    report job, no bash warning ('line N:')."""
    work = args.out
    env, calls = fake_slurm(work)
    out = work / "st"
    for printed in ["12\\0003\\n", "4242;c\\n9999\\n", "1" * 21 + "\\n"]:
        shutil.rmtree(calls)
        calls.mkdir()
        result = subprocess.run(slurm_command(args, out), capture_output=True, text=True,
                                env={**env, "FAKE_SHARDS_FORMAT": printed}, timeout=120)
        one_line_exit(result, 1, "sbatch printed no job id for the shards",
                      prefix="study_slurm:")
        check("line " not in result.stderr and "warning" not in result.stderr,
              f"{printed!r}: {result.stderr}")
        check(sorted(path.name for path in calls.iterdir()) == ["call0"],
              f"{printed!r}: the report job submitted")


def fake_command(work: pathlib.Path, folder: str, name: str, body: str) -> pathlib.Path:
    """WORK/FOLDER/NAME, an sh script running `body`: a folder to put first on PATH."""
    where = work / folder
    where.mkdir(exist_ok=True)
    (where / name).write_text(f"#!/bin/sh\n{body}\n")
    (where / name).chmod(0o755)
    return where


def case_slurm_unwritten_job_record_goes_on(args) -> None:
    """The shards' job submitted, its record slurm/job-ID not written: slurm/ removed while
    the shards' sbatch runs, or (two login nodes, one PID: each submission in a PID
    namespace of its own, each with its own host name) the other submission's failure
    removing what it took for its own claim: exit 0, a line naming the job and the record
    not written (or the record kept), the report job submitted after it."""
    work = args.out
    env, calls = fake_slurm(work)
    out = work / "st"
    a = subprocess.Popen(slurm_command(args, out), stdout=subprocess.DEVNULL,
                         stderr=subprocess.PIPE, text=True,
                         env={**env, "FAKE_SLOW": "0", "FAKE_SLOW_S": "2"})
    deadline = time.monotonic() + 60
    while not (calls / "call0").exists() and time.monotonic() < deadline:
        time.sleep(0.02)
    shutil.rmtree(out / "slurm")
    _, said = a.communicate(timeout=60)
    check(a.returncode == 0 and any("4242" in line and "could not be written" in line
                                    for line in own_line(said)),
          f"slurm/ removed: exit {a.returncode}:\n{said}")
    check((calls / "call1").exists() and
          "--dependency=afterok:4242" in (calls / "call1").read_text(),
          f"slurm/ removed: no report job after the shards' 4242:\n{said}")
    unshare = next((words for words in (["unshare", "-pf"], ["unshare", "-rpf"])
                    if shutil.which("unshare") and
                    subprocess.run([*words, "true"], capture_output=True).returncode == 0), None)
    if unshare is None:
        print("(no PID namespace here: two submissions with one PID not run)")
        return
    shutil.rmtree(out)
    started = []
    for node, fake in (("a", {"FAKE_SHARDS_RC": "1", "FAKE_SHARDS_PRINTS": "",
                              "FAKE_SLOW": "0", "FAKE_SLOW_S": "1.5"}),
                       ("b", {"FAKE_SLOW": "0", "FAKE_SLOW_S": "3"})):
        node_calls = work / f"calls_{node}"
        node_calls.mkdir()
        named = fake_command(work, f"host_{node}", "hostname", f"echo login-{node}")
        started.append(subprocess.Popen(
            [*unshare, "bash", "-c", ':; "$@"; exit $?', "-", *slurm_command(args, out)],
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
            env={**env, **fake, "FAKE_CALLS": str(node_calls), "PATH": f"{named}:{env['PATH']}"}))
        deadline = time.monotonic() + 60
        while not (node_calls / "call0").exists() and time.monotonic() < deadline:
            time.sleep(0.02)
    (a, b), said = started, [each.communicate(timeout=60)[1] for each in started]
    check(a.returncode == 1 and b.returncode == 0 and (out / "slurm" / "job-4242").is_file() and
          (out / ".study.lock").is_file(), f"one PID on two nodes: A exit {a.returncode}, B exit "
          f"{b.returncode}, left {sorted(p.name for p in out.rglob('*')) if out.exists() else 'none'}:"
          f"\n{said[0]}\n{said[1]}")


def case_slurm_stop_while_job_is_recorded(args) -> None:
    """A SIGTERM to study_slurm.sh (or its group) while it writes the shards' job record (a
    slow date(1) once the shards' sbatch has printed): exit 143, one line naming the job
    cancelled, on the script's stderr; the job's record and the claim removed."""
    work = args.out
    env, calls = fake_slurm(work)
    out, started = work / "st", work / "date_started"
    slow = fake_command(work, "slowdate", "date",
                        f"[ -e '{work}/done0' ] && {{ : > '{started}'; sleep 2; }}\n"
                        f"exec {shutil.which('date')} \"$@\"")
    env = {**env, "PATH": f"{env['PATH'].split(':', 1)[0]}:{slow}:{env['PATH'].split(':', 1)[1]}"}
    for group in (False, True):
        shutil.rmtree(calls)
        calls.mkdir()
        shutil.rmtree(out, ignore_errors=True)
        for each in (work / "done0", started):
            each.unlink(missing_ok=True)
        code, stderr, cancelled = slurm_stopped(args, out, {}, env, started.exists,
                                                signal.SIGTERM, group)
        to = f"to the {'group' if group else 'script'}"
        lines = own_line(stderr)
        check(code == 143 and len(lines) == 1 and "4242" in lines[0] and
              "is cancelled" in lines[0] and cancelled == "4242\n",
              f"{to}: exit {code}, scancel {cancelled!r}:\n{stderr}")
        left = sorted(p.name for p in (out / "slurm").iterdir()) if (out / "slurm").is_dir() else []
        check(not left, f"{to}: left in slurm/: {left}")


def case_slurm_cancel_bounded_without_timeout(args) -> None:
    """A stop to the group while the report job's sbatch submits, scancel hanging for 40 s,
    with timeout(1) on PATH and without: within about 10 s of scancel, exit 143, one line
    naming the shards' job NOT cancelled, 'scancel did not answer in 10 s'."""
    work = args.out
    env, calls = fake_slurm(work)
    bare = work / "notimeout"  # every command on PATH but timeout
    bare.mkdir()
    for folder in env["PATH"].split(":"):
        if not os.path.isdir(folder):
            continue
        for name in os.listdir(folder):
            if name != "timeout" and not os.path.lexists(bare / name):
                (bare / name).symlink_to(pathlib.Path(folder) / name)
    fake = {"FAKE_SLOW": "1", "FAKE_SLOW_S": "5", "FAKE_SCANCEL_SLOW": "40"}
    for path in (env["PATH"], f"{work / 'bin'}:{bare}"):
        shutil.rmtree(calls)
        calls.mkdir()
        began = time.monotonic()
        code, stderr, cancelled = slurm_stopped(args, work / "st", {**fake, "PATH": path}, env,
                                                lambda: (calls / "call1").exists(),
                                                signal.SIGTERM, group=True)
        took = time.monotonic() - began
        lines = own_line(stderr)
        to = "no timeout" if path != env["PATH"] else "timeout on PATH"
        check(code == 143 and took < 25 and len(lines) == 1 and "NOT cancelled" in lines[0] and
              "scancel did not answer in 10 s" in lines[0] and "scancel 4242" in lines[0],
              f"{to}: exit {code} after {took:.1f} s:\n{stderr}")


def case_slurm_stop_once_out_is_said_undoes_it(args) -> None:
    """A stop to the group after the folder check's Python has made --out and printed what
    it made, before bash has read it (a PYTHON whose output is held back: slow storage,
    then the stop): exit 128 + N, 'nothing submitted' with what was made removed, and no
    folder of it left."""
    work = args.out
    env, calls = fake_slurm(work)
    said, held = work / "said", work / "held"
    slow = fake_command(work, "slowpy", "python",
                        "case \"$*\" in *foreign_folder_problem*)\n"
                        f"  {PYTHON} \"$@\" > '{held}'; status=$?\n"
                        f"  : > '{said}'; sleep 3; cat '{held}'; exit $status ;;\n"
                        f"esac\nexec {PYTHON} \"$@\"")
    out = work / "new" / "deep"
    for sig in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP):
        said.unlink(missing_ok=True)
        code, stderr, _ = slurm_stopped(args, out, {"PYTHON": str(slow / "python")}, env,
                                        said.exists, sig, group=True)
        lines = own_line(stderr)
        check(code == 128 + sig and len(lines) == 1 and "nothing submitted" in lines[0] and
              "is removed" in lines[0], f"{sig.name}: exit {code}:\n{stderr}")
        check(not os.path.lexists(work / "new"), f"{sig.name}: left "
              f"{sorted(str(p.relative_to(work)) for p in (work / 'new').rglob('*'))}")
        check(not any(calls.iterdir()), f"{sig.name}: submitted")


def case_slurm_stale_claims_named(args) -> None:
    """Claims in slurm/ of submissions from this host that do not run: the one whose PID is
    no process is removed, the one whose PID is another program kept; each named in a line
    of its own; another host's claim kept and not named.  The submission goes through."""
    work = args.out
    env, calls = fake_slurm(work)
    named = fake_command(work, "host", "hostname", "echo login-here")
    env = {**env, "PATH": f"{named}:{env['PATH']}"}
    out = work / "st"
    first = subprocess.run(slurm_command(args, out), capture_output=True, text=True, env=env,
                           timeout=120)
    check(first.returncode == 0, f"a first submission: exit {first.returncode}:\n{first.stderr}")
    ended = subprocess.Popen(["true"])
    ended.wait()
    other = subprocess.Popen(["sleep", "60"])
    try:
        claims = {}
        for name, pid, host in (("gone", ended.pid, "login-here"), ("other", other.pid, "login-here"),
                                ("elsewhere", ended.pid, "login-there")):
            claims[name] = out / "slurm" / f"submission-{host}-{pid}"
            claims[name].write_text(
                f"a submission of study_slurm.sh (pid {pid} on {host}, 2024-01-02 03:04:05) is "
                "submitting its shards' job into this folder; remove this file if no such "
                "submission runs\nmade 0 1 1\n")
        shutil.rmtree(calls)
        calls.mkdir()
        result = subprocess.run(slurm_command(args, out), capture_output=True, text=True,
                                env=env, timeout=120)
    finally:
        other.kill()
        other.wait()
    lines = own_line(result.stderr)
    check(result.returncode == 0, f"exit {result.returncode}:\n{result.stderr}")
    gone = [line for line in lines if claims["gone"].name in line]
    kept = [line for line in lines if claims["other"].name in line]
    check(len(gone) == 1 and "removed" in gone[0] and not claims["gone"].exists(),
          f"a claim whose PID is no process: {result.stderr}")
    check(len(kept) == 1 and "remove" in kept[0] and claims["other"].exists(),
          f"a claim whose PID is another program: {result.stderr}")
    check(claims["elsewhere"].exists() and claims["elsewhere"].name not in result.stderr,
          f"another host's claim: {result.stderr}")


def case_slurm_odd_files_in_slurm_not_read(args) -> None:
    """A FIFO and a link to /dev/zero in slurm/, named as claims: the stale-claim check reads
    only a claim's regular file, so the submission neither hangs nor reads memory full."""
    work = args.out
    env, calls = fake_slurm(work)
    out = work / "st"
    first = subprocess.run(slurm_command(args, out), capture_output=True, text=True, env=env,
                           timeout=120)
    check(first.returncode == 0, f"a first submission: exit {first.returncode}:\n{first.stderr}")
    os.mkfifo(out / "slurm" / "submission-fifo")
    (out / "slurm" / "submission-zero").symlink_to("/dev/zero")
    shutil.rmtree(calls)
    calls.mkdir()
    try:
        result = subprocess.run(slurm_command(args, out), capture_output=True, text=True,
                                env=env, timeout=60)
    except subprocess.TimeoutExpired:
        check(False, "a FIFO among the claims held the submission for a minute")
    check(result.returncode == 0 and (calls / "call1").exists(),
          f"exit {result.returncode}:\n{result.stderr}")
    check("Traceback" not in result.stderr, f"a traceback:\n{result.stderr}")


def case_slurm_temporary_folder_like_an_option(args) -> None:
    """TMPDIR=-dash, a relative folder whose name starts with a dash: exit 0, both jobs
    submitted (mktemp not reading it as its options)."""
    work = args.out
    env, calls = fake_slurm(work)
    (work / "-dash").mkdir()
    result = subprocess.run(slurm_command(args, work / "st"), capture_output=True, text=True,
                            env={**env, "TMPDIR": "-dash"}, cwd=work, timeout=120)
    check(result.returncode == 0 and (calls / "call1").exists(),
          f"exit {result.returncode}:\n{result.stderr}")


# --- gpu_check.sh --dry-run in a scratch checkout ---------------------------------------

def scratch_checkout(args) -> pathlib.Path:
    """WORK/root: a copy of the scripts, build-emulation/ this build's folder."""
    root = args.out / "root"
    shutil.copytree(args.scripts, root / "scripts", symlinks=True)
    (root / "build-emulation").symlink_to(pathlib.Path(args.overlap).parent)
    listed = subprocess.run([args.overlap, "--list-algos", "--json"], capture_output=True)
    if listed.returncode != 0:
        skip(f"{args.overlap} --list-algos --json fails: gpu_check.sh --dry-run cannot run")
    (root / ".gpu-carry").mkdir()
    return root


def gpu_check(root: pathlib.Path, *words, **env) -> subprocess.CompletedProcess:
    return subprocess.run(["bash", str(root / "scripts" / "gpu_check.sh"), *words],
                          capture_output=True, text=True, cwd=root, timeout=200,
                          env={**os.environ, **env})


def case_gpu_resume_archive_checked_before_unpacking(args) -> None:
    """gpu_check.sh --study --dry-run with a .gpu-carry/resume.tar.xz whose ./study holds
    a link out (to a folder of a user's), an absolute or a '..' name: exit 2, one line
    naming the resume archive, the folder outside OUT as it was, the earlier run in OUT
    kept, no scratch left; a good resume archive's ./study is unpacked as the study's."""
    root = scratch_checkout(args)
    victim = args.out / "victim"
    victim.mkdir()
    (victim / "mine.txt").write_text("a user's file\n")
    resume = root / ".gpu-carry" / "resume.tar.xz"
    out = args.out / "gc"

    def link_out(tar):
        add(tar, "./study/sweep", type=tarfile.SYMTYPE, linkname=str(victim))

    def absolute(tar):
        add(tar, str(victim / "planted.txt"), b"planted\n")

    def dotdot(tar):
        add(tar, "./study/../../victim/planted.txt", b"planted\n")

    for name, adding in [("a link out", link_out), ("an absolute name", absolute),
                         ("a '..' name", dotdot)]:
        shutil.rmtree(out, ignore_errors=True)
        (out / "gpu-study").mkdir(parents=True)
        (out / "gpu-study" / "earlier.txt").write_text("an earlier run's\n")
        (out / "gpu_study_summary.txt").write_text("an earlier run's summary\n")
        archive(resume, {}, extra=[adding])
        result = gpu_check(root, "--study", "--dry-run", "--only", "study", OUT=str(out),
                           STUDY_SHARDS="1")
        one_line_exit(result, 2, ".gpu-carry/resume.tar.xz")
        check(sorted(p.name for p in victim.iterdir()) == ["mine.txt"],
              f"{name}: wrote outside OUT: {sorted(p.name for p in victim.iterdir())}")
        check((out / "gpu-study" / "earlier.txt").is_file() and
              (out / "gpu_study_summary.txt").is_file(), f"{name}: the earlier run touched")
        check(sorted(p.name for p in out.iterdir()) == ["gpu-study", "gpu_study_summary.txt"],
              f"{name}: left {sorted(p.name for p in out.iterdir())}")
    archive(resume, {"resumed.txt": b"an earlier loan's\n"})
    result = gpu_check(root, "--study", "--dry-run", "--only", "info", OUT=str(out))
    check(result.returncode == 0, f"a good resume archive: exit {result.returncode}:\n"
          f"{result.stderr}")
    check((out / "gpu-study" / "study" / "resumed.txt").is_file(),
          "a good resume archive's ./study is not the study's")
    check(not list(out.glob(".gpu-resume-*")), "a scratch folder left in OUT")


def case_gpu_check_environment_numbers_checked_first(args) -> None:
    """gpu_check.sh --dry-run with DEADLINE_S, STUDY_SHARDS or CTEST_JOBS not plain digits
    (a unit, a word, a sign, a leading 0 bash reads as octal): exit 2, one line naming
    the variable, before the earlier run's files are touched."""
    root = scratch_checkout(args)
    out = args.out / "gc"
    result = gpu_check(root, "--dry-run", "--only", "info", OUT=str(out))
    check(result.returncode == 0, f"the earlier run: exit {result.returncode}:\n{result.stderr}")
    earlier = sorted(p.relative_to(out).as_posix() for p in out.rglob("*"))
    for name, value in [("DEADLINE_S", "10m"), ("DEADLINE_S", "abc"), ("DEADLINE_S", "-5"),
                        ("DEADLINE_S", "010"), ("DEADLINE_S", "1 + 1"),
                        ("STUDY_SHARDS", "x"), ("STUDY_SHARDS", "0"),
                        ("CTEST_JOBS", "2x"), ("CTEST_JOBS", "0x10")]:
        for part in ([], ["--study"]):
            result = gpu_check(root, "--dry-run", *part, "--only", "info", OUT=str(out),
                               **{name: value})
            one_line_exit(result, 2, f"{name}=")
            now = sorted(p.relative_to(out).as_posix() for p in out.rglob("*"))
            check(now == earlier, f"{name}={value}: the earlier run's files changed: "
                  f"{sorted(set(earlier) ^ set(now))}")


# --- thread_scaling.py and plot_run.py --------------------------------------------------

def case_thread_scaling_provenance_stays_comments(args) -> None:
    """thread_scaling.py with a --config binary whose name holds a newline (and a CSV
    header after it): the CSV read back has its own header and rows, and every line
    before the header is a '#' line (the medians among them)."""
    sys.path.insert(0, str(args.scripts))
    from results_files import provenance, read_csv
    header_line = "round,config,physics_ms,substeps,per_substep_ms,state_hash"
    odd = args.out / f"ov\n{header_line}"
    odd.symlink_to(args.overlap)
    csv_path = args.out / "ts.csv"
    result = subprocess.run(
        [PYTHON, str(args.scripts / "thread_scaling.py"), "--out", str(csv_path), "--rounds",
         "1", "--skip", "0", "--common",
         "--scene 1 --objects 40 --frames 3 --no-tasks --algo bf --threads 1",
         "--config", f"t1={odd}"], capture_output=True, text=True, timeout=120)
    check(result.returncode == 0, f"exit {result.returncode}:\n{result.stderr}")
    rows = read_csv(csv_path)
    check([row["config"] for row in rows] == ["t1"], f"the rows read back: {rows}")
    lines = csv_path.read_text().splitlines()
    header = lines.index(header_line)
    check(all(line.startswith("#") for line in lines[:header]), f"not '#': {lines[:header]}")
    check("medians" in provenance(csv_path) and "configs" in provenance(csv_path),
          f"provenance lost: {provenance(csv_path)}")


def a_run(args) -> pathlib.Path:
    if importlib.util.find_spec("matplotlib") is None:
        skip(f"{PYTHON} has no matplotlib (plot_run.py draws with it)")
    run = args.out / "run"
    subprocess.run([args.overlap, "run", "--scene", "1", "--objects", "40", "--frames", "3",
                    "--algo", "bf", "--threads", "1", "--capture-every", "0", "--no-wav",
                    "--out", str(run)], check=True, capture_output=True, timeout=120)
    return run


def plot(args, folder: pathlib.Path) -> subprocess.CompletedProcess:
    return subprocess.run([PYTHON, str(args.scripts / "plot_run.py"), str(folder)],
                          capture_output=True, text=True, timeout=120)


def case_plot_run_refuses_numbers_no_run_writes(args) -> None:
    """plot_run.py on a run whose frames.csv holds inf, nan, 1e999, a negative, or a number
    not in ASCII decimal (Arabic-Indic digits, 1_0, a space: float() reads them, no run
    writes them) in a column it draws (total_ms, physics_ms, a stage): exit 2, one line
    naming frames.csv, the line and the column, no run.png and no temporary."""
    run = a_run(args)
    header = (run / "frames.csv").read_text().splitlines()[0].split(",")
    for column in ("total_ms", "physics_ms", "update_ms"):
        for value in ("inf", "nan", "1e999", "-inf", "-1", "\u0661\u0660", "1_0", " 1"):
            folder = args.out / "bad"
            shutil.rmtree(folder, ignore_errors=True)
            shutil.copytree(run, folder)
            lines = (folder / "frames.csv").read_text().splitlines()
            cells = lines[1].split(",")
            cells[header.index(column)] = value
            lines[1] = ",".join(cells)
            (folder / "frames.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")
            result = plot(args, folder)
            one_line_exit(result, 2, "frames.csv", "line 2", column)
            check(sorted(p.name for p in folder.iterdir()) == sorted(p.name for p in run.iterdir()),
                  f"{column}={value}: wrote {sorted(p.name for p in folder.iterdir())}")
    result = plot(args, run)
    check(result.returncode == 0 and (run / "run.png").is_file(),
          f"a good run: exit {result.returncode}:\n{result.stderr}")


def case_plot_run_refuses_a_frame_time_no_run_has(args) -> None:
    """plot_run.py on a run whose summary.json's frame_time is NaN, an infinity (1e999),
    negative, zero or a string: exit 2, one line naming summary.json and frame_time, no
    run.png; a summary.json without one draws with the default 1/30 s."""
    run = a_run(args)
    for value in ("NaN", "Infinity", "1e999", "-5", "0", '"0.03"'):
        folder = args.out / "bad"
        shutil.rmtree(folder, ignore_errors=True)
        shutil.copytree(run, folder)
        summary = json.loads((folder / "summary.json").read_text())
        summary["parameters"]["frame_time"] = "@VALUE@"
        (folder / "summary.json").write_text(json.dumps(summary).replace('"@VALUE@"', value))
        result = plot(args, folder)
        one_line_exit(result, 2, "summary.json", "frame_time")
        check(not (folder / "run.png").exists(), f"frame_time {value}: drawn")
    summary = json.loads((folder / "summary.json").read_text(), parse_constant=str)
    del summary["parameters"]["frame_time"]
    (folder / "summary.json").write_text(json.dumps(summary))
    result = plot(args, folder)
    check(result.returncode == 0 and (folder / "run.png").is_file(),
          f"no frame_time: exit {result.returncode}:\n{result.stderr}")


def case_plot_run_names_an_unreadable_file(args) -> None:
    """plot_run.py on a run whose summary.json is not JSON ('{'), not UTF-8 or not an
    object ('[1]', parameters not one), or whose frames.csv is not UTF-8: exit 2, one line
    naming that file, no run.png (never the default frame time drawn without a word)."""
    run = a_run(args)
    for name, data in (("summary.json", b"{"), ("summary.json", b"\xff"),
                       ("summary.json", b"[1]"), ("summary.json", b'{"parameters": 3}'),
                       ("frames.csv", (run / "frames.csv").read_bytes() + b"\xff\n")):
        folder = args.out / "bad"
        shutil.rmtree(folder, ignore_errors=True)
        shutil.copytree(run, folder)
        (folder / name).write_bytes(data)
        result = plot(args, folder)
        one_line_exit(result, 2, f"{folder / name}:")
        check(not (folder / "run.png").exists(), f"{name} {data[:20]!r}: drawn")


def main() -> int:
    return run_case(globals(), lambda parser: parser.add_argument(
        "--scripts", type=lambda text: pathlib.Path(text).resolve(), default=SCRIPTS,
        help="the scripts folder to test (default: this checkout's)"))


if __name__ == "__main__":
    sys.exit(main())
