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
# A stop from here on says what was made and submitted (phase): before the shards are
# submitted, what this script made (the folders, slurm/ and the lock) is removed if it
# is still as made, never a folder another submission or a study has written into
# meanwhile; shards submitted without their report job are cancelled; once the report
# job is submitted, a stop stops the waiting only.
phase="" made="" array="" report_job="" sbatch_pid="" ids="" notices=""
undo_made() {  # MADE: "LEVELS SLURM LOCK" as the folder's check printed it
  [[ -n "$made" ]] || return 0
  PYTHONPATH="$repo/scripts" "$python" -c 'import os, pathlib, sys
from study_out_folder import LOCK_NAME
out, (levels, slurm, lock) = pathlib.Path(sys.argv[1]), map(int, sys.argv[2].split())
try:
    names = set(os.listdir(out))
    logs = out / "slurm"
    if lock and names <= {LOCK_NAME, "slurm"} and (out / LOCK_NAME).stat().st_size == 0 \
            and not (logs.is_dir() and not logs.is_symlink() and os.listdir(logs)):
        (out / LOCK_NAME).unlink()
    if slurm:
        logs.rmdir()
except OSError:
    pass
for _ in range(levels):  # each folder made, from --out up: only while empty
    try:
        out.rmdir()
    except OSError:
        break
    out = out.parent' "$out" "$made" 2> /dev/null || true
}
report_id() {  # the report job's id, once its sbatch has printed it (a whole line)
  local line=""
  [[ -z "$report_job" && -n "$ids" ]] && IFS= read -r line < "$ids" &&
    [[ "${line%%;*}" =~ ^[0-9]+$ ]] && report_job="${line%%;*}"
  [[ -n "$report_job" ]]
}
stopped() {
  # No errexit in here: a command that fails (a kill of an sbatch the same stop has
  # ended already, a scancel refused) must not end the stop before its line and its
  # exit status; every way out of here is the exit of its own.
  set +e
  trap - INT TERM HUP
  [[ -z $notices ]] || exec 2>&3  # the lines below to stderr, not where bash's notices go
  local i
  if [[ $phase == report ]]; then  # its sbatch is submitting: wait a little for its word
    for ((i = 0; i < 100; i++)); do
      report_id && break; kill -0 "$sbatch_pid" 2> /dev/null || { report_id; break; }; sleep 0.1
    done
    if report_id; then phase=waiting
    elif kill -0 "$sbatch_pid" 2> /dev/null; then
      kill "$sbatch_pid" 2> /dev/null
      echo "study_slurm: stopped by SIG$1 while sbatch was submitting the report job; the shards' job $array is submitted: see squeue --name overlap-study-report, and scancel $array if it lists no report job" >&2
      exit $((128 + $2))
    else phase=shards_only
    fi
  fi
  case $phase in
    shards)
      echo "study_slurm: stopped by SIG$1 while sbatch was submitting the shards: see squeue --name overlap-study, and scancel what it lists" >&2 ;;
    shards_only)
      command -v scancel > /dev/null && scancel "$array" 2> /dev/null
      echo "study_slurm: stopped by SIG$1; the shards' job $array, submitted without its report job, is cancelled (or cancel it: scancel $array)" >&2 ;;
    waiting)
      kill "$sbatch_pid" 2> /dev/null
      echo "study_slurm: stopped by SIG$1${wait:+ while waiting for the report job}; both jobs are submitted and go on (the shards' job $array, the report job $report_job: scancel $array $report_job stops them)" >&2 ;;
    *)
      undo_made
      echo "study_slurm: stopped by SIG$1; nothing submitted${made:+ (of what this script made for --out, what nothing else has written into is removed)}" >&2 ;;
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
# --out is a study's folder, as study.py takes it (study_out_folder.py): refused
# if it holds a user's files; else its logs folder and the lock that marks it.
made="$(PYTHONPATH="$repo/scripts" "$python" -c 'import os, pathlib, sys
from study_out_folder import LOCK_NAME, foreign_folder_problem
from script_cli import one_line
out = pathlib.Path(sys.argv[1])
if problem := foreign_folder_problem(out):
    sys.exit(f"study_slurm: --out {one_line(out)}: {problem}")
levels, here = 0, out  # what is made here, printed for a stop to undo: no more
while not os.path.lexists(here):
    levels, here = levels + 1, here.parent
slurm = not os.path.lexists(out / "slurm")
lock = not os.path.lexists(out / LOCK_NAME)
try:
    (out / "slurm").mkdir(parents=True, exist_ok=True)
    (out / LOCK_NAME).touch()
except OSError as error:
    sys.exit(f"study_slurm: --out {one_line(out)}: {one_line(error.strerror or error)}")
finally:
    print(levels, int(slurm), int(lock))' \
  "$out")" || { made="${made:-}"; undo_made; exit 2; }
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
phase=shards
status=0
# shellcheck disable=SC2086  # --sbatch holds several options, split on purpose
array="$(sbatch --parsable $extra_sbatch --array="1-$shards" --job-name=overlap-study \
  --output="$out/slurm/shard-%a.log" --chdir="$repo" \
  --wrap="$(sh_quoted "${shard[@]}") --shard \$SLURM_ARRAY_TASK_ID/$shards")" || status=$?
# Its --parsable line is the array's id (and ";cluster"): anything else and no report job
# is submitted (its --dependency=afterok: would name no job, or another); of what was made
# for --out, what nothing else has written into is removed, as a stop's.
if [[ $status -gt 128 ]]; then
  undo_made
  echo "study_slurm: sbatch was ended by $(signal_name "$status") (exit $status) while submitting the shards: see squeue --name overlap-study, and scancel what it lists" >&2; exit 1
elif [[ $status -ne 0 ]]; then
  undo_made
  echo "study_slurm: sbatch refused the shards (exit $status); nothing submitted" >&2; exit 1
elif ! [[ "${array%%;*}" =~ ^[0-9]+$ ]]; then
  undo_made
  printed="${array//$'\n'/\\n}"; printed="${printed//$'\r'/\\r}"
  [[ ${#printed} -le 200 ]] || printed="${printed:0:200}..."
  echo "study_slurm: sbatch printed no job id for the shards (${array:+it printed: }${printed:-it printed nothing}); see squeue --name overlap-study" >&2; exit 1
fi
array="${array%%;*}"
phase=report
echo "study_slurm: shards: job $array, $shards tasks, logs in $shown_out/slurm/shard-N.log"
# The report job's sbatch runs in the background, its --parsable line (the job's id, which
# sbatch prints on submitting, before --wait waits) read from a file: a stop while it
# waits is handled at once, knowing the job is submitted, and its exit status is the
# job's own (sbatch(1): with --wait, the submitted job's exit code).
ids="$(mktemp "${TMPDIR:-/tmp}/study_slurm.XXXXXX")" || exit 1
trap 'rm -f -- "$ids"' EXIT
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
report_id || true
trap - INT TERM HUP
if [[ -z "$report_job" && $status -gt 128 ]]; then
  echo "study_slurm: sbatch was ended by $(signal_name "$status") (exit $status) while submitting the report job; the shards' job $array is submitted: see squeue --name overlap-study-report, and scancel $array if it lists no report job" >&2; exit 1
elif [[ -z "$report_job" ]]; then
  echo "study_slurm: sbatch refused the report job; the shards' job $array runs without it (scancel $array, or submit the report: ${report[*]})" >&2; exit 1
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
