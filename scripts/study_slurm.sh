#!/usr/bin/env bash
# The study on a Slurm cluster (docs/STUDY.md): one array job, one shard a task
# (scripts/study.py --runs-only --shard i/K), every task into one --out on storage
# all nodes share; then one job, started when every shard has ended well
# (--dependency=afterok), that collects the runs and writes the report there.
#
#   scripts/study_slurm.sh --out /shared/study --shards 64 [--profile full]
#                          [--sbatch "--partition=cpu --time=12:00:00"] [--wait]
#                          [-- more scripts/study.py options]
#
# The checkout (with its build/overlap) must be at the same path on every node,
# and the nodes' python3 needs only its standard library for the shards;
# the report job needs matplotlib (PYTHON, default /usr/bin/python3).  --wait
# returns when the report job has ended, with its exit status (a stop while
# waiting stops the waiting only: the jobs go on).  A shard that stopped (a
# node lost, a time limit) is rerun by submitting the same command again:
# finished runs are kept, only the missing ones run.
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
python="${PYTHON:-/usr/bin/python3}"
usage() { sed -n '2,18p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }
die() { echo "study_slurm: $*" >&2; exit 2; }

# An option's value: present (and, but for --sbatch, not empty), else one line and exit 2.
needs() { [[ $# -ge 3 && ( -n "$3" || "$1" == --sbatch ) ]] || die "$1 needs $2"; }
out="" shards="" profile="full" extra_sbatch="" wait=()
while [[ $# -gt 0 ]]; do
  case "$1" in
    --out) needs "$1" "a folder" "${@:2:1}"; out="$2"; shift 2 ;;
    --shards) needs "$1" "a count" "${@:2:1}"; shards="$2"; shift 2 ;;
    --profile) needs "$1" "a name" "${@:2:1}"; profile="$2"; shift 2 ;;
    --sbatch) needs "$1" "options (\"\" for none)" "${@:2:1}"; extra_sbatch="$2"; shift 2 ;;
    --wait) wait=(--wait); shift ;;
    --) shift; break ;;
    -h|--help) usage ;;
    *) die "unknown option $1 (see --help)" ;;
  esac
done
[[ -n "$out" && -n "$shards" ]] || usage
[[ "$shards" =~ ^[1-9][0-9]{0,5}$ ]] || die "--shards $shards: expected a count, 1 to 999999"
# The pass-through options are the study's own, but not those this script sets: a second
# --out would override the folder checked here, --shard each task's share, a --profile (or
# --quick, --full) the profile the tasks are confirmed for; and no --help, which the check
# would answer with the help (exit 0) and every task likewise.
for word in "$@"; do
  case "$word" in
    --out|--out=*|--shard|--shard=*|--from-archive|--from-archive=*|--runs-only|--no-runs|--check-only)
      die "${word%%=*} after --: study_slurm.sh sets it itself (give --out before --)" ;;
    --profile|--profile=*|--quick|--full)
      die "${word%%=*} after --: study_slurm.sh sets the profile (give --profile before --)" ;;
    --help|-h|-h*)
      die "$word after --: the study's help runs nothing (scripts/study.py --help shows it)" ;;
  esac
done
command -v sbatch > /dev/null || die "sbatch is not on PATH (no Slurm client here)"
# Every job's command, built once: the tasks run `shard` with --shard i/K, the report job
# `report`; the check below runs these very words (with --check-only), so what passes here
# is what runs there.  --out absolute: the jobs start in the checkout (--chdir).
[[ "$out" == /* ]] || out="$PWD/$out"
shown_out="${out//$'\n'/\\n}"  # the name on one line, in this script's own lines
# sbatch reads its --output names as patterns: a % in --out would be replaced (%j: the
# job's number) and a backslash turns the patterns off (every shard into one log).
[[ "$out" == *%* || "$out" == *\\* ]] &&
  die "--out $shown_out: sbatch reads % and \\ in its log names as patterns; give a folder without them"
# The full profile runs only when confirmed: a batch job cannot answer, so it says --full.
confirm=()
[[ "$profile" == full ]] && confirm=(--full)
study=("$python" "$repo/scripts/study.py" --profile "$profile" --out "$out" "$@")
shard=("${study[@]}" "${confirm[@]}" --runs-only)
report=("${study[@]}" --no-runs)
# Words for the jobs' /bin/sh (sbatch --wrap: "a simple sh shell script"): each in single
# quotes, a ' as '\'' -- every byte as it is, in any locale (bash's printf %q writes $'...',
# which sh reads as a $ and a quoted word).
sh_quoted() {
  local word words=()
  for word in "$@"; do words+=("'${word//\'/\'\\\'\'}'"); done
  printf '%s' "${words[*]}"
}
signal_name() {  # the signal of an exit status past 128 (a command ended by it)
  local name
  name="$(kill -l "$(($1 - 128))" 2> /dev/null)" || name="$(($1 - 128))"
  echo "SIG$name"
}
# A stop from here on says what was made and submitted (phase): before the shards are
# submitted, what this script made (the folders, slurm/ and the lock) is removed if it
# is still as made, never a folder another submission or a study has written into
# meanwhile; shards submitted without their report job are cancelled; once the report
# job is submitted, a stop stops the waiting only.
# Each submission claims --out in slurm/submission-HOST-PID-RANDOM (a line saying whose, then the
# line of what it made) before its shards' sbatch, and once the shards' job is submitted
# keeps slurm/job-ID (the same for the user): a submission that fails or is stopped removes
# its own claim only, and the folders only where no other submission's claim or job is in
# slurm/.  The host in the name too: two login nodes may give two submissions one PID.
phase="" made="" array="" report_job="" sbatch_pid="" ids="" said="" notices=""
shards_started="" id_read=""
host="$(hostname 2> /dev/null)" || host=""
host="${host:-?}"
# (and a random word: two PID namespaces of one host may give two submissions one PID)
claim="submission-${host//[^A-Za-z0-9._-]/_}-$$-${SRANDOM:-$RANDOM}"
claim_text="a submission of study_slurm.sh (pid $$ on $host, $(date '+%F %T')) is submitting its shards' job into this folder; remove this file if no such submission runs
"
# What this submission made for --out ("LEVELS SLURM LOCK" as the folder's check printed
# it: the folders made from --out up, whether slurm/ and the lock were made), undone: its
# claim; the lock and slurm/ only while nothing else is in them (another submission's
# claim or job, a shard's log, a study's file); each folder only while empty.
undo_py='def undo(out, levels, slurm, lock, claim):
    logs = out / "slurm"
    try:
        (logs / claim).unlink()
    except OSError:
        pass
    try:
        if slurm:
            logs.rmdir()
        if lock and set(os.listdir(out)) <= ({LOCK_NAME} if slurm else {LOCK_NAME, "slurm"}) \
                and (out / LOCK_NAME).stat().st_size == 0 \
                and not (logs.is_dir() and not logs.is_symlink() and os.listdir(logs)):
            (out / LOCK_NAME).unlink()
    except OSError:
        pass
    for _ in range(levels):  # each folder made, from --out up: only while empty
        try:
            out.rmdir()
        except OSError:
            break
        out = out.parent
'
# A stop after the folder check's Python has said what it made, before bash has assigned
# it to made: the same line, from this submission's own claim (its text, then "made ...").
made_from_claim() {
  local text
  [[ -z "$made" ]] || return 0
  # This user's own regular file only (never a FIFO's wait, nor another user's edit), read
  # as far as a claim goes.
  [[ -f "$out/slurm/$claim" && ! -L "$out/slurm/$claim" && -O "$out/slurm/$claim" ]] || return 0
  text="$(head -c 4096 -- "$out/slurm/$claim" 2> /dev/null)" || return 0
  [[ $text == "${claim_text}made "* ]] || return 0
  text="${text#"${claim_text}made "}"
  [[ $text =~ ^[0-9]+\ [01]\ [01]$ ]] && made="$text"
}
undo_made() {
  [[ -n "$made" ]] || return 0
  PYTHONPATH="$repo/scripts" "$python" -c 'import os, pathlib, sys
from study_out_folder import LOCK_NAME
'"$undo_py"'
undo(pathlib.Path(sys.argv[1]), *map(int, sys.argv[2].split()), sys.argv[3])' \
    "$out" "$made" "$claim" 2> /dev/null || true
}
# A job id as sbatch --parsable prints it: the whole of what it printed is one line "N" or
# "N;cluster", N at most 20 digits, no NUL byte (read from its file, not through $(...),
# which drops a NUL); FILE [running]: while its sbatch runs, only a line it has ended.
id_pattern='^[0-9]{1,20}(;[^[:space:]]*)?$'
read_id() {
  local text=""
  ! IFS= read -r -d '' text < "$1" || return 1  # read to its end, or a NUL byte: no id
  [[ ${2-} != running || $text == *$'\n' ]] || return 1
  text="${text%$'\n'}"
  [[ $text =~ $id_pattern ]] || return 1
  id_read="${text%%;*}"
}
printed() {  # FILE: what sbatch printed, on one line of at most 200 characters
  local text
  text="$(tr '\000' '\001' < "$1" 2> /dev/null)"
  text="${text//$'\001'/\\0}"; text="${text//$'\n'/\\n}"; text="${text//$'\r'/\\r}"
  [[ ${#text} -le 200 ]] || text="${text:0:200}..."
  printf '%s' "${text:+it printed: }${text:-it printed nothing}"
}
report_id() {  # the report job's id, once its sbatch has printed it ([ended]: sbatch has)
  [[ -z "$report_job" && -n "$ids" ]] && read_id "$ids" "${1:-running}" && report_job="$id_read"
  [[ -n "$report_job" ]]
}
# The shards' job $array, kept in slurm/ for the user and other submissions, and the claim
# removed; else (slurm/ gone, the storage full) unrecorded says why, and the claim stays.
# Only the write's own error is redirected (to $(...)): a stop meanwhile says its line on
# the script's stderr.
unrecorded=""
record_job() {
  local when why
  unrecorded=""
  [[ -n $made ]] || return 0
  when="$(date '+%F %T' 2> /dev/null)" || when="?"
  if why="$(printf 'the shards job %s (%s tasks) of study_slurm.sh, submitted %s from %s (pid %s)\n' \
      "$array" "$shards" "$when" "$host" "$$" 2>&1 > "$out/slurm/job-$array")"; then
    rm -f -- "$out/slurm/$claim" 2> /dev/null
    return 0
  fi
  why="${why//$'\n'/ }"; why="${why##*: }"
  unrecorded="its record $shown_out/slurm/job-$array could not be written (${why:-no reason given})"
  return 1
}
# JOB: scancel it, and say what came of it.  At most 10 s, timeout(1) or not: scancel in
# the background (its words in $said, read by now), killed if it has not ended by then.
cancelled() {
  local said_back status i pid
  if ! command -v scancel > /dev/null; then
    echo "is NOT cancelled (scancel is not on PATH): cancel it with scancel $1"; return
  fi
  scancel "$1" > "$said" 2>&1 &
  pid=$!
  for ((i = 0; i < 100; i++)); do kill -0 "$pid" 2> /dev/null || break; sleep 0.1; done
  if kill -0 "$pid" 2> /dev/null; then
    kill -KILL "$pid" 2> /dev/null; wait "$pid" 2> /dev/null
    echo "is NOT cancelled (scancel did not answer in 10 s): cancel it with scancel $1"; return
  fi
  status=0; wait "$pid" 2> /dev/null || status=$?
  if [[ $status -eq 0 ]]; then echo "is cancelled"; return; fi
  said_back="$(cat -- "$said" 2> /dev/null)"; said_back="${said_back//$'\n'/ }"
  echo "is NOT cancelled (scancel exited $status${said_back:+: $said_back}): cancel it with scancel $1"
}
stopped() {
  # No errexit in here: a command that fails (a kill of an sbatch the same stop has
  # ended already, a scancel refused) must not end the stop before its line and its
  # exit status; every way out of here is the exit of its own.  A second stop is ignored
  # (this one is bounded: at most about 20 s, 10 for the report's sbatch to print its id,
  # 10 for scancel), so that its line and its cleanup complete.
  set +e
  trap '' INT TERM HUP
  [[ -z $notices ]] || exec 2>&3  # the lines below to stderr, not where bash's notices go
  local i nothing="" result
  if [[ $phase == shards ]]; then  # bash runs this once the shards' sbatch has ended
    if [[ -n $shards_started ]] && read_id "$said"; then
      array="$id_read"; record_job; phase=shards_only
    else
      phase=""; [[ -z $shards_started ]] || nothing=" (sbatch printed no job id for the shards)"
    fi
  fi
  if [[ $phase == report ]]; then  # its sbatch is submitting: wait a little for its word
    for ((i = 0; i < 100; i++)); do
      report_id && break; kill -0 "$sbatch_pid" 2> /dev/null || { report_id ended; break; }; sleep 0.1
    done
    if report_id ended; then phase=waiting
    elif kill -0 "$sbatch_pid" 2> /dev/null; then
      kill "$sbatch_pid" 2> /dev/null
      echo "study_slurm: stopped by SIG$1 while sbatch was submitting the report job; the shards' job $array is submitted: see squeue --name overlap-study-report, and scancel $array if it lists no report job" >&2
      exit $((128 + $2))
    else phase=shards_only
    fi
  fi
  case $phase in
    shards_only)  # cancelled, its record goes: no later failure keeps --out for it
      result="$(cancelled "$array")"
      [[ $result != "is cancelled" ]] || rm -f -- "$out/slurm/job-$array" 2> /dev/null
      echo "study_slurm: stopped by SIG$1; the shards' job $array, submitted without its report job, $result${unrecorded:+ ($unrecorded)}" >&2 ;;
    waiting)
      kill "$sbatch_pid" 2> /dev/null
      echo "study_slurm: stopped by SIG$1${wait:+ while waiting for the report job}; both jobs are submitted and go on (the shards' job $array, the report job $report_job: scancel $array $report_job stops them)" >&2 ;;
    *)
      made_from_claim
      undo_made
      echo "study_slurm: stopped by SIG$1; nothing submitted$nothing${made:+ (of what this script made for --out, what nothing else has written into is removed)}" >&2 ;;
  esac
  exit $((128 + $2))
}
trap 'stopped INT 2' INT
trap 'stopped TERM 15' TERM
trap 'stopped HUP 1' HUP
# The study's own checks of every option, --out and its log (study.py --check-only, as a
# shard and the report job would start), before anything is made or submitted: a bad value
# is one line and exit 2 here, not a failure of every task on the cluster.
# From the checkout, where the jobs start: a relative path among the options must mean there
# what it will mean in the jobs.
(cd "$repo" && "${shard[@]}" --shard "1/$shards" --check-only) || exit $?
(cd "$repo" && "${report[@]}" --check-only) || exit $?
# The temporaries (what each sbatch prints), made and written to once before anything is
# made or submitted: a TMPDIR missing, full or read-only is one line here, not a shards'
# job submitted without its report job.
temporary() {
  local made_here
  made_here="$(mktemp -- "${TMPDIR:-/tmp}/study_slurm.XXXXXX" 2>&1)" && [[ -f $made_here ]] &&
    { echo id > "$made_here" && : > "$made_here"; } 2> /dev/null && { echo "$made_here"; return 0; }
  if [[ -f $made_here ]]; then rm -f -- "$made_here"; made_here="cannot be written to"; fi
  echo "study_slurm: no temporary file for what sbatch prints in ${TMPDIR:-/tmp} (${made_here//$'\n'/ }); nothing submitted (set TMPDIR to a writable folder)" >&2
  return 1
}
trap 'rm -f -- ${ids:+"$ids"} ${said:+"$said"}' EXIT
said="$(temporary)" || { undo_made; exit 1; }
ids="$(temporary)" || { undo_made; exit 1; }
# --out is a study's folder, as study.py takes it (study_out_folder.py): refused
# if it holds a user's files; else its logs folder, the lock that marks it and this
# submission's claim.  A stop while it makes them (the same stop to this script's group):
# it removes what it made before it has printed what it made; the line it prints is in the
# claim as well, for a stop that comes before bash has read it.  Claims of submissions
# from this host that no longer run: one line each way, removed only where the PID is no
# process at all (ESRCH), else named for the user to remove.
made="$(PYTHONPATH="$repo/scripts" "$python" -c 'import os, pathlib, re, signal, stat, sys
STOPS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
class Stopped(BaseException):
    pass
def stop(number, frame):
    for each in STOPS:
        signal.signal(each, signal.SIG_IGN)
    raise Stopped(number)
for each in STOPS:
    if signal.getsignal(each) != signal.SIG_IGN:
        signal.signal(each, stop)
CLAIMED = re.compile(r"a submission of study_slurm\.sh \(pid ([0-9]{1,20}) on (.*), "
                     r"[0-9]{4}-[0-9]{2}-[0-9]{2} [0-9]{2}:[0-9]{2}:[0-9]{2}\) is submitting ")
def stale_claims(out, host, one_line):
    logs, gone, named = out / "slurm", [], []
    try:
        names = sorted(os.listdir(logs)) if logs.is_dir() and not logs.is_symlink() else []
    except OSError:
        names = []
    for name in names:
        if not name.startswith("submission-"):
            continue
        try:  # a claim is a small regular file: never a link, FIFO or device read whole
            fd = os.open(logs / name, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)
            try:
                first = (os.read(fd, 4096) if stat.S_ISREG(os.fstat(fd).st_mode) else b"")
            finally:
                os.close(fd)
        except OSError:
            continue
        first = first.decode(errors="replace").split("\n", 1)[0]
        match = CLAIMED.match(first)
        if not match or match.group(2) != host:
            continue  # another host: not for this one to judge
        pid = int(match.group(1))
        try:
            if pid == 0:
                raise ValueError(pid)  # kill(0, 0) is this group, no process of its own
            os.kill(pid, 0)
        except ProcessLookupError:  # no such process, for certain
            try:
                (logs / name).unlink()
                gone.append(f"slurm/{name} (pid {pid})")
            except OSError:
                named.append(f"slurm/{name} (pid {pid}, which is no process)")
            continue
        except PermissionError:
            pass  # a process all the same, of another user
        except (OverflowError, ValueError):
            named.append(f"slurm/{name} (pid {pid}, which is no process)")
            continue
        try:
            words = pathlib.Path(f"/proc/{pid}/cmdline").read_bytes()
        except OSError:
            continue  # cannot tell: taken as running
        if b"study_slurm" not in words:
            named.append(f"slurm/{name} (pid {pid} is another program)")
    comma = ", "
    if gone:
        print(f"study_slurm: --out {one_line(out)}: removed the claims of submissions from "
              f"this host that no longer run: {one_line(comma.join(gone))}", file=sys.stderr)
    if named:
        print(f"study_slurm: --out {one_line(out)}: claimed by submissions from this host "
              f"that do not run: {one_line(comma.join(named))}; remove each such file if no "
              "such submission runs", file=sys.stderr)
'"$undo_py"'
try:
    from study_out_folder import LOCK_NAME, foreign_folder_problem
    from script_cli import one_line
    out, claim = pathlib.Path(sys.argv[1]), sys.argv[2]
    if out.is_symlink() and not out.exists():
        sys.exit(f"study_slurm: --out {one_line(out)}: a link to {one_line(os.readlink(out))}, "
                 "which does not exist")
    if problem := foreign_folder_problem(out):
        sys.exit(f"study_slurm: --out {one_line(out)}: {problem}")
    stale_claims(out, sys.argv[4], one_line)
    levels, here = 0, out  # what is made here, printed for a stop to undo: no more
    while not os.path.lexists(here):
        levels, here = levels + 1, here.parent
    slurm = not os.path.lexists(out / "slurm")
    lock = not os.path.lexists(out / LOCK_NAME)
    try:
        (out / "slurm").mkdir(parents=True, exist_ok=True)
        (out / LOCK_NAME).touch()
        (out / "slurm" / claim).write_text(f"{sys.argv[3]}made {levels} {int(slurm)} {int(lock)}\n")
        for each in STOPS:  # printed, it is the script that undoes it
            signal.signal(each, signal.SIG_IGN)
        print(levels, int(slurm), int(lock), flush=True)
    except OSError as error:
        undo(out, levels, slurm, lock, claim)
        sys.exit(f"study_slurm: --out {one_line(out)}: {one_line(error.strerror or error)}")
    except Stopped as stopped:
        undo(out, levels, slurm, lock, claim)
        sys.exit(128 + stopped.args[0])
except Stopped as stopped:
    sys.exit(128 + stopped.args[0])' \
  "$out" "$claim" "$claim_text" "$host")" || {
  status=$?
  [[ $status -le 128 ]] && exit 2
  echo "study_slurm: the check of --out was ended by $(signal_name "$status"); nothing submitted (what it made for --out is removed)" >&2
  exit "$status"
}
phase=shards
status=0
# bash's own stderr /dev/null while it runs, sbatch's the real one (fd 3): an sbatch ended
# by a signal is said below in a line of this script's, not in bash's notice as well.
{
  notices=yes shards_started=yes
  # shellcheck disable=SC2086  # --sbatch holds several options, split on purpose
  sbatch --parsable $extra_sbatch --array="1-$shards" --job-name=overlap-study \
    --output="$out/slurm/shard-%a.log" --chdir="$repo" \
    --wrap="$(sh_quoted "${shard[@]}") --shard \$SLURM_ARRAY_TASK_ID/$shards" \
    > "$said" 2>&3 3>&- || status=$?
} 3>&2 2> /dev/null
notices=""
# Its --parsable line is the array's id (and ";cluster"): anything else and no report job
# is submitted (its --dependency=afterok: would name no job, or another); of what was made
# for --out, what nothing else has written into is removed, as a stop's.  An id printed
# is a job submitted, whatever sbatch's exit status after it.
if read_id "$said"; then
  array="$id_read"
  record_job ||
    echo "study_slurm: the shards' job $array is submitted, but $unrecorded; its report job is submitted all the same" >&2
  if [[ $status -gt 128 ]]; then
    echo "study_slurm: sbatch printed the shards' job $array, then was ended by $(signal_name "$status") (exit $status); the job is taken as submitted (squeue -j $array shows it)" >&2
  elif [[ $status -ne 0 ]]; then
    echo "study_slurm: sbatch printed the shards' job $array, then exited $status; the job is taken as submitted (squeue -j $array shows it)" >&2
  fi
else
  trap '' INT TERM HUP  # what was made is removed, and this said, whatever stop comes now
  undo_made
  if [[ $status -gt 128 ]]; then
    echo "study_slurm: sbatch was ended by $(signal_name "$status") (exit $status) while submitting the shards, before it printed a job id; taken as nothing submitted (squeue --name overlap-study lists this user's study jobs, should one be there all the same)" >&2
  elif [[ $status -ne 0 ]]; then
    echo "study_slurm: sbatch refused the shards (exit $status); nothing submitted" >&2
  else
    echo "study_slurm: sbatch printed no job id for the shards ($(printed "$said")); see squeue --name overlap-study" >&2
  fi
  exit 1
fi
phase=report
echo "study_slurm: shards: job $array, $shards tasks, logs in $shown_out/slurm/shard-N.log"
# The report job's sbatch runs in the background, its --parsable line (the job's id, which
# sbatch prints on submitting, before --wait waits) read from a file: a stop while it
# waits is handled at once, knowing the job is submitted, and its exit status is the
# job's own (sbatch(1): with --wait, the submitted job's exit code).
buffered=(); command -v stdbuf > /dev/null && buffered=(stdbuf -oL)  # the id at once
# From its start to its wait, bash's own stderr (fd 2) is /dev/null and the real one fd 3
# (sbatch's, this script's lines): an sbatch ended by a signal is said below in a line of
# this script's, not also in bash's notice "line N: PID Killed  stdbuf -oL sbatch ...".
status=0
{
  notices=yes
  # shellcheck disable=SC2086
  "${buffered[@]}" sbatch --parsable "${wait[@]}" $extra_sbatch --dependency="afterok:$array" \
    --kill-on-invalid-dep=yes --job-name=overlap-study-report --output="$out/slurm/report.log" \
    --chdir="$repo" --wrap="$(sh_quoted "${report[@]}")" > "$ids" 2>&3 3>&- &
  sbatch_pid=$!
  until report_id || ! kill -0 "$sbatch_pid" 2> /dev/null; do sleep 0.1; done
  if report_id && [[ ${#wait[@]} -gt 0 ]]; then
    phase=waiting
    echo "study_slurm: report: job $report_job, when every shard has ended well: $shown_out/REPORT.md; waiting for it to end"
  fi
  wait "$sbatch_pid" || status=$?
} 3>&2 2> /dev/null
notices=""
report_id ended || true
trap - INT TERM HUP
if [[ -z "$report_job" && $status -gt 128 ]]; then
  echo "study_slurm: sbatch was ended by $(signal_name "$status") (exit $status) while submitting the report job; the shards' job $array is submitted: see squeue --name overlap-study-report, and scancel $array if it lists no report job" >&2; exit 1
elif [[ -z "$report_job" && $status -eq 0 ]]; then
  echo "study_slurm: sbatch exited 0 for the report job but printed no job id ($(printed "$ids")): it may be submitted all the same; see squeue --name overlap-study-report before submitting it again (the shards' job $array is submitted)" >&2; exit 1
elif [[ -z "$report_job" ]]; then
  echo "study_slurm: sbatch refused the report job (exit $status); the shards' job $array runs without it (scancel $array, or submit the report: $(sh_quoted "${report[@]}"))" >&2; exit 1
elif [[ ${#wait[@]} -eq 0 ]]; then
  [[ $status -eq 0 ]] || { echo "study_slurm: sbatch submitted the report job $report_job, then exited $status; see squeue -j $report_job" >&2; exit 1; }
  echo "study_slurm: report: job $report_job, when every shard has ended well: $shown_out/REPORT.md"
elif [[ $status -eq 0 ]]; then
  echo "study_slurm: report: job $report_job ended well: $shown_out/REPORT.md"
else
  # (sbatch --wait ended by a signal gives 128 + N too, as a job so ended does)
  ended=""
  [[ $status -le 128 ]] || ended="; or sbatch ended by $(signal_name "$status") while waiting: squeue -j $report_job shows whether the job goes on"
  echo "study_slurm: the report job $report_job ended with exit status $status (or never ran: a shard failed${ended}); see $shown_out/slurm/report.log and sacct -j $array,$report_job" >&2
  exit "$status"
fi
