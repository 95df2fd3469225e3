#!/usr/bin/env bash
# The two calls of a GPU loan (docs/GPU_LOAN.md: the steps, their budgets, the rules):
#   scripts/gpu_check.sh [--dry-run] [--only STEP,...]   the check: test presets, benchmark, frames
#   scripts/gpu_check.sh --study [--dry-run]             the study: study.py --profile gpu
# A step passes when it exits 0 (ctest's own status for a preset); each runs in its own
# process group, and a signal to this script ends them all.  A bad argument, or a run that
# cannot start, exits 2 before an earlier run's files are touched.  --dry-run: the same on
# build-emulation/ (presets emulation-*), tiny sizes.  OUT (default out/gpu-check), DEADLINE_S;
# STUDY_SHARDS, CTEST_JOBS (each plain digits).  --study unpacks .gpu-carry/resume.tar.xz (a
# returned gpu_study.tar.xz) with study_archive.py's checks, before an earlier run is touched.
set -uo pipefail
cd "$(dirname "$0")/.." || exit 2
export ROOT="$PWD" SELF="$PWD/scripts/gpu_check.sh" PY="${PYTHON:-$(command -v python3)}"
note() { echo "$*" >"$WORK/notes/$STEP"; } && fail() { echo "gpu_check: $STEP: $*" >&2 && exit 1; }
checked() { local status=$? && note "$1" && ((status == 0)) || fail "$1"; } # checked "$(COMMAND)"
steps() { "$PY" scripts/gpu_check_steps.py "$@" 2>&1; } && refuse() { echo "gpu_check: $*" >&2 && exit 2; }
step_info() {
  { date -u +%FT%TZ; uname -srm; nproc; grep -m1 'model name' /proc/cpuinfo; free -g | sed -n 2p; cmake --version | head -1
    cat "$BUILD/gpu-pack/manifest" 2>/dev/null; "$BUILD/overlap" --version && "$BUILD/overlap" --list-algos
    [[ $MODE == dry ]] || { nvidia-smi; nvcc --version | tail -2; "$COMPUTE_SANITIZER" --version | head -2; }; } 2>&1 | tee "$WORK/info.txt"
  [[ $MODE == dry ]] || nvidia-smi -L >/dev/null || fail "nvidia-smi sees no GPU"
  note "GPU finders: $GPU_FINDERS"
}
step_ctest() { # PRESET [JOBS]: the step's status is ctest's, its counts from ctest's JUnit file
  ctest --preset "$PRESETS$1" -j "${2:-$CTEST_JOBS}" --timeout "$TEST_TIMEOUT" --output-junit "$WORK/$1.xml"
  local status=$? && note "$(steps junit "$WORK/$1.xml") (ctest exit $status)" && exit $status
}
step_streams() {
  local n pid failed=0 && mkdir -p "$STREAMS"
  for n in $SMALL $BIG $HUGE $MILLION; do
    set -- $FRAMES_BY_SIZE && while ((n > $1)); do shift 2; done
    "$BUILD/overlap" generate --scene 4 --objects "$n" --frames "$2" --skip 40 --out "$STREAMS/g$n.aabbs" &
  done
  for pid in $(jobs -p); do wait "$pid" || failed=$((failed + 1)); done
  note "$(ls "$STREAMS" | wc -l) streams, $(du -sh "$STREAMS" | cut -f1)" && ((failed == 0)) || fail "$failed failed"
}
step_bench() { # NAME "N..." ALGOS|from:BENCH REPEATS WARMUP; the benchmark fails on a missed or wrong pair
  local inputs=() n algos=$3 && [[ $algos == from:* ]] && { algos="$(steps within 2 "$GPU_FINDERS" "$WORK/bench/${3#from:}.json")" || fail "$algos"; }
  for n in $2; do inputs+=("$STREAMS/g$n.aabbs"); done && mkdir -p "$WORK/bench"
  "$BUILD/overlap_bench_broadphase" --input "${inputs[@]}" --algos "$algos" --repeats "$4" --warmup "$5" --out "$WORK/bench/$1" || fail "failed"
  checked "$(steps has "$algos" "$WORK/bench/$1.json")"
}
step_frames() { # ALGO FOLDER OPTIONS...: one `overlap run`; ALGO must be the one that ran
  local algo=$1 out="$WORK/frames/$2" && shift 2
  "$BUILD/overlap" run "$@" --out "$out" || fail "overlap run failed"
  checked "$(steps ran "$algo" "$out/summary.json")"
}
step_study() { # one shard per core into one --out; each starts once the one before probed the GPU
  local i log failed=0 # (a resume archive's ./study is there, checked and unpacked before the steps)
  for ((i = 1; i <= SHARDS; i++)); do # a shard prints nothing before its GPU probe
    log="$WORK/logs/study_shard$i.log"; PYTHONUNBUFFERED=1 "$PY" scripts/study.py $STUDY --out "$WORK/study" \
      --shard "$i/$SHARDS" --runs-only >"$log" 2>&1 &
    for _ in {1..300}; do [[ -s "$log" ]] || ! kill -0 $! 2>/dev/null && break; sleep 0.1; done
  done
  for i in $(jobs -p); do wait "$i" || failed=$((failed + 1)); done
  note "$SHARDS shards, $failed failed (logs/study_shard*.log)" && ((failed == 0)) || fail "$failed shards failed"
} && checked_jobs() { checked "$(steps jobs $STUDY --out "$WORK/study")"; }
step_report() { # what the development machine runs on the returned archive, kept in $OUT/gpu-study-report
  local py="$PY" && "$py" -c 'import matplotlib' 2>/dev/null || py=/usr/bin/python3 # the figures need it
  "$py" scripts/study.py --from-archive "$OUT/gpu_study.tar.xz" --overlap "$ROOT/$BUILD/overlap" \
    --out "$OUT/gpu-study-report" && [[ -s "$OUT/gpu-study-report/REPORT.md" ]] || fail "no report from the archive"
  note "REPORT.md and $(find "$OUT/gpu-study-report/report" -name '*.png' | wc -l) figures from the archive"
}
step_archive() {
  tar -C "$WORK" --exclude='*.aabbs' -cf - . | xz -6 -T0 >"$OUT/$ARCHIVE" || fail "tar failed"
  local size && size=$(stat -c %s "$OUT/$ARCHIVE") && note "$ARCHIVE: $((size / 1024)) KiB"
  ((size <= 16 * 1024 * 1024)) || fail "the archive is over 16 MiB"
}
[[ "${1:-}" == --step ]] && { STEP=$2 && shift 2 && "$@"; exit; }
launched=$(date +%s) # the deadline counts from here: a resume archive's unpack is within it

MODE=gpu PART=check only=""
while (($#)); do
  case "$1" in
    --dry-run) MODE=dry ;; --study) PART=study ;;
    --only) (($# > 1)) && [[ -n ${2//,/} ]] || refuse "--only needs STEP,..." && only=",$2," && shift ;;
    -h | --help) sed -n '2,/^set -uo/p' "$0" | sed '$d; s/^# \{0,1\}//' && exit 0 ;; *) refuse "unknown option '$1' (--study, --dry-run, --only STEP,...)" ;;
  esac && shift
done
all="unpack info gpu-tests sanitizer-memcheck sanitizer-racecheck sanitizer-initcheck sanitizer-synccheck ctest streams bench-paper bench-big bench-huge bench-million frames-demo frames-ALGO archive"
[[ $PART == study ]] && all="unpack info study study-jobs archive report"
for name in ${only//,/ }; do [[ " $all " == *" $name "* || ($PART == check && $name =~ ^frames-(cpusap|gpubf|gpubf-paper|gpusap)$) ]] ||
  refuse "--only $name: no such step (the $PART's: $all)"; done
export MODE PART OUT="$(realpath -m "${OUT:-$ROOT/out/gpu-check}")" SHARDS="${STUDY_SHARDS:-$(nproc)}"
export WORK="$OUT/gpu-$PART" ARCHIVE="gpu_$PART.tar.xz" SCRATCH="${TMPDIR:-/tmp}/gpu-check-$$"
export STREAMS="$SCRATCH/streams" COMPUTE_SANITIZER="$(command -v compute-sanitizer || echo /usr/local/cuda/bin/compute-sanitizer)"
if [[ $MODE == gpu ]]; then # the sizes: the paper's, 10^4, 10^5, 10^6, and each one's stream frames
  export BUILD=build PRESETS="" CTEST_JOBS="${CTEST_JOBS:-12}" TEST_TIMEOUT=120 SMALL="500 1250 2000 2750 3500" BIG="10000 30000"
  export HUGE="100000 300000" MILLION=1000000 FRAMES_BY_SIZE="3500 64 30000 16 300000 8 1000000 3" DEMO=""
  export FRAME_OPTIONS="--scene 4 --objects 3500 --frames 12" STUDY="--profile gpu --overlap $ROOT/build/overlap" &&
    deadline_s=${DEADLINE_S:-$([[ $PART == study ]] && echo 395 || echo 285)} scale=1 paper="3 8" big="2 4"
  [[ -f .gpu-carry/overlap-gpu.tar.xz ]] || refuse ".gpu-carry/overlap-gpu.tar.xz is missing: run scripts/gpu_pack.sh first"
else # the demo keeps enough boxes that the default rule still picks gpubf, as for 1000 on a GPU
  export BUILD=build-emulation PRESETS=emulation- CTEST_JOBS="${CTEST_JOBS:-2}" TEST_TIMEOUT=1500 SMALL="50 90" BIG=200
  export HUGE=400 MILLION=800 FRAMES_BY_SIZE="90 6 400 4 800 3" SHARDS="${STUDY_SHARDS:-2}" DEMO="--objects 600 --frames 6"
  export FRAME_OPTIONS="--scene 4 --objects 60 --frames 4" STUDY="--profile gpu-dry --threads 1 --overlap $ROOT/$BUILD/overlap"
  deadline_s=${DEADLINE_S:-7200} scale=10 paper="1 1" big="1 1" && "$BUILD/overlap" --list-algos --json &>/dev/null || refuse "$BUILD/overlap is missing or fails: cmake --preset cuda-emulation && cmake --build --preset cuda-emulation"
fi
# The numbers read from the environment, as plain digits (no sign, no leading 0, which bash's
# arithmetic reads as octal, no unit), checked before an earlier run's files are touched.
number() { [[ $2 =~ $3 ]] || refuse "$1=${2//[^[:print:]]/?}: expected $4"; } # NAME VALUE REGEX WHAT
number DEADLINE_S "$deadline_s" '^(0|[1-9][0-9]{0,6})$' "whole seconds, 0 to 9999999 (no unit)"
number STUDY_SHARDS "$SHARDS" '^[1-9][0-9]{0,3}$' "a count of shards, 1 to 9999"
number CTEST_JOBS "$CTEST_JOBS" '^[1-9][0-9]{0,3}$' "a count of jobs, 1 to 9999"
mkdir -p "$OUT" || refuse "OUT=$OUT cannot be made"
# A study to resume: its archive is another run's returned one, as untrusted as any (links,
# absolute or '..' names, devices, bad text or runs refused: study_archive.py's checks), so
# it is unpacked and checked beside $WORK first: a bad one refuses the call, $WORK as it was.
RESUME="" done_so_far="an earlier run's files as they were" && trap 'rm -rf "$SCRATCH" ${RESUME:+"$RESUME"}' EXIT
early_stop() { echo "gpu_check: stopped by SIG$1 before any step; $done_so_far" >&2 && exit $((128 + $(kill -l "$1"))); }
trap 'early_stop TERM' TERM && trap 'early_stop INT' INT && trap 'early_stop HUP' HUP
if [[ $PART == study && -f .gpu-carry/resume.tar.xz ]]; then
  RESUME="$OUT/.gpu-resume-$$" && rm -rf "$RESUME"
  said="$(steps resume .gpu-carry/resume.tar.xz "$RESUME")" || refuse ".gpu-carry/resume.tar.xz: ${said//$'\n'/; }"
fi
done_so_far="the earlier run's files removed" && rm -rf "$WORK" "$OUT/$ARCHIVE" && mkdir -p "$WORK/logs" "$WORK/notes" "$SCRATCH"
if [[ -n $RESUME ]]; then mv "$RESUME/study" "$WORK/study" && rmdir "$RESUME" || refuse "$RESUME: cannot be moved to $WORK/study"; fi
readonly summary="$OUT/gpu_${PART}_summary.txt" started=$launched && table=() running=() failures=0 reserve=10
readonly deadline=$((started + deadline_s))
record() { # NAME STATUS SECONDS BUDGET NOTE: one line of the table, rewritten to $summary
  table+=("$(printf '%-20s %-11s %4s s of %4s  %s' "$1" "$2" "$3" "$4" "${5:0:150}")") && [[ $2 == pass ]] || ((failures++))
  echo "gpu_check: ${table[-1]}"
  printf '%s\n' "scripts/gpu_check.sh ($MODE run, the $PART), started $(date -u -d "@$started" +%FT%TZ)" "${table[@]}" >"$summary"
}
start() { # NAME BUDGET FUNCTION ARGS...: in the background, in timeout's own process group
  local name=$1 budget=$(($2 * scale)) left=$((deadline - $(date +%s) - reserve)) && shift 2
  [[ -z $only || $only == *",$name,"* || $name == unpack || $name == info ]] || return 0 && ((budget > left)) && budget=$left
  ((budget >= 5)) || { record "$name" skip 0 0 "no time left before the deadline" && return 0; }
  timeout -k 5 "$budget" "$SELF" --step "$name" "$@" >"$WORK/logs/$name.log" 2>&1 &
  running+=("$name $! $budget $(date +%s)")
}
finish() { # waits for the started steps, then records each (its time: to its log's last line)
  local entry name pid budget began status && for entry in "${running[@]}"; do
    read -r name pid budget began <<<"$entry" && wait "$pid"
    case $? in 0) status=pass ;; 124 | 137) status=TIMEOUT ;; *) status=FAIL ;; esac
    record "$name" $status $(($(stat -c %Y "$WORK/logs/$name.log") - began)) "$budget" "$(cat "$WORK/notes/$name" 2>/dev/null || tail -1 "$WORK/logs/$name.log")"
  done && running=()
}
stop() { # SIGNAL: every running step's process group ends (TERM, then KILL), then this script
  trap - TERM INT HUP && local entry signal pid
  for signal in TERM KILL; do for entry in "${running[@]}"; do read -r _ pid _ <<<"$entry" && kill -"$signal" -- "-$pid" 2>/dev/null; done; sleep 1; done
  wait && for entry in "${running[@]}"; do record "${entry%% *}" INTERRUPTED 0 0 "stopped by SIG$1"; done
  exit $((128 + $(kill -l "$1")))
}
trap 'stop TERM' TERM && trap 'stop INT' INT && trap 'stop HUP' HUP
run() { start "$@" && finish; } # start and wait: one step alone
[[ $MODE == gpu ]] && run unpack 30 scripts/gpu_pack.sh --unpack
export GPU_FINDERS && GPU_FINDERS="$(steps gpu-finders "$BUILD/overlap")" ||
  { record finders FAIL 0 0 "$GPU_FINDERS" && run archive 10 step_archive; exit 1; }
run info 15 step_info # budgets (s); the H100's times in brackets (docs/GPU_LOAN.md)
if [[ $PART == study ]]; then reserve=20 && run study 9999 step_study && reserve=10 && run study-jobs 10 checked_jobs # [3]
else
  run gpu-tests 30 step_ctest gpu # [7]
  for tool in memcheck racecheck initcheck synccheck; do start "sanitizer-$tool" 90 step_ctest $tool $(((CTEST_JOBS + 3) / 4)); done # [25-27]
  start ctest 120 step_ctest device-suite && start streams 90 step_streams && finish # [111; 6]
  run bench-paper 40 step_bench bench-paper "$SMALL" "sap,bvh,cpubf,cpusap,$GPU_FINDERS" $paper # [31 at 5 repeats]
  run bench-big 40 step_bench bench-big "$BIG" "bvh,cpusap,$GPU_FINDERS" $big # [45 at 3 repeats]
  run bench-huge 40 step_bench bench-huge "$HUGE" from:bench-big 2 2 # [10^5: 11]
  run bench-million 30 step_bench bench-million "$MILLION" from:bench-huge 2 2
  run frames-demo 20 step_frames gpubf demo $DEMO # [12]
  finders="cpusap,$GPU_FINDERS" && [[ $MODE == dry ]] || # on a GPU: those no slower than cpusap in bench-paper
    finders="$(steps within 1 "$GPU_FINDERS" "$WORK/bench/bench-paper.json")" || finders="cpusap,$GPU_FINDERS"
  for algo in ${finders//,/ }; do # [25-35 each at 24 frames]
    run "frames-$algo" 25 step_frames "$algo" "$algo" $FRAME_OPTIONS --algo "$algo" --task-load 1 --compare-sync --capture-every 0 --no-wav
  done
fi
reserve=0 && run archive 10 step_archive && [[ $MODE == dry && $PART == study ]] && run report 60 step_report # [1]
[[ $MODE == gpu && -f "$OUT/$ARCHIVE" ]] && rm -rf "$WORK" # only the archive and the summary come back
echo -e "\ngpu_check: $MODE run of the $PART, $(($(date +%s) - started)) s, $failures steps failed or timed out"
printf '  %s\n' "${table[@]}" && exit $((failures > 0))
