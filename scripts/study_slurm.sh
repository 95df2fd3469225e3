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
# returns when the report job has ended, with its exit status.  A shard that
# stopped (a node lost, a time limit) is rerun by submitting the same command
# again: finished runs are kept, only the missing ones run.
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
python="${PYTHON:-/usr/bin/python3}"
usage() { sed -n '2,17p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }
die() { echo "study_slurm: $*" >&2; exit 2; }

out="" shards="" profile="full" extra_sbatch="" wait=()
while [[ $# -gt 0 ]]; do
  case "$1" in
    --out) out="${2:?--out needs a folder}"; shift 2 ;;
    --shards) shards="${2:?--shards needs a count}"; shift 2 ;;
    --profile) profile="${2:?--profile needs a name}"; shift 2 ;;
    --sbatch) extra_sbatch="${2?--sbatch needs options}"; shift 2 ;;
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
# A stop from here on says what was made and submitted: a fresh --out with nothing
# submitted is removed, shards submitted without their report job are cancelled.
fresh_out=""; [[ -e "$out" ]] || fresh_out="$out"
submitting="" submitted=""
stopped() {
  trap - INT TERM HUP
  if [[ -n "$submitting" && -z "$submitted" ]]; then
    echo "study_slurm: stopped by SIG$1 while sbatch was submitting the shards: see squeue --name overlap-study, and scancel what it lists" >&2
  elif [[ -z "$submitted" ]]; then
    [[ -n "$fresh_out" ]] && rm -rf -- "$fresh_out"
    echo "study_slurm: stopped by SIG$1; nothing submitted" >&2
  else
    command -v scancel > /dev/null && scancel "$submitted" 2> /dev/null
    echo "study_slurm: stopped by SIG$1; the shards' job $submitted, submitted without its report job, is cancelled (or cancel it: scancel $submitted)" >&2
  fi
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
PYTHONPATH="$repo/scripts" "$python" -c 'import pathlib, sys
from study_out_folder import LOCK_NAME, foreign_folder_problem
from script_cli import one_line
out = pathlib.Path(sys.argv[1])
if problem := foreign_folder_problem(out):
    sys.exit(f"study_slurm: --out {one_line(out)}: {problem}")
try:
    (out / "slurm").mkdir(parents=True, exist_ok=True)
    (out / LOCK_NAME).touch()
except OSError as error:
    sys.exit(f"study_slurm: --out {one_line(out)}: {one_line(error.strerror or error)}")' \
  "$out" || exit 2
# Words for the jobs' /bin/sh (sbatch --wrap: "a simple sh shell script"): each in single
# quotes, a ' as '\'' -- every byte as it is, in any locale (bash's printf %q writes $'...',
# which sh reads as a $ and a quoted word).
sh_quoted() {
  local word words=()
  for word in "$@"; do words+=("'${word//\'/\'\\\'\'}'"); done
  printf '%s' "${words[*]}"
}
# shellcheck disable=SC2086  # --sbatch holds several options, split on purpose
submitting=1
array="$(sbatch --parsable $extra_sbatch --array="1-$shards" --job-name=overlap-study \
  --output="$out/slurm/shard-%a.log" --chdir="$repo" \
  --wrap="$(sh_quoted "${shard[@]}") --shard \$SLURM_ARRAY_TASK_ID/$shards")"
array="${array%%;*}"
submitted="$array"
echo "study_slurm: shards: job $array, $shards tasks, logs in $shown_out/slurm/shard-N.log"
# shellcheck disable=SC2086
report_job="$(sbatch --parsable "${wait[@]}" $extra_sbatch --dependency="afterok:$array" \
  --kill-on-invalid-dep=yes --job-name=overlap-study-report --output="$out/slurm/report.log" \
  --chdir="$repo" --wrap="$(sh_quoted "${report[@]}")")" || {
  echo "study_slurm: sbatch refused the report job; the shards' job $array runs without it (scancel $array, or submit the report: ${report[*]})" >&2; exit 1; }
trap - INT TERM HUP
echo "study_slurm: report: job ${report_job%%;*}, when every shard has ended well: $shown_out/REPORT.md"
