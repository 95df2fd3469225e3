#!/usr/bin/env bash
# One GPU loan in two commands (docs/GPU.md), each from the
# repository root of a machine with an NVIDIA GPU and no Bullet, oneTBB,
# OSMesa or network, the build carried by scripts/gpu_pack.sh:
#   scripts/gpu_check.sh [--dry-run] [--only STEP,...]           the check
#   scripts/gpu_check.sh --study [--dry-run]                      the study
# Steps, in order, each under its own time budget (a timeout), one line each.
# Both parts:
#   unpack        .gpu-carry/overlap-gpu.tar.xz into the tree; the packed
#                 checkout's path made to lead here; CTest's cmake and python3
#                 pointed at this machine's where the packed ones are absent
#   info          the machine, the GPU, the tools, the build's manifest
#   archive       everything into $OUT/gpu_check.tar.xz (the study:
#                 $OUT/gpu_study.tar.xz), at most 16 MiB
# The check (DEADLINE_S 285 s; the H100's step times sum to about 270):
#   gpu-tests     overlap_gpu_tests; fails if any test is skipped
#   sanitizer-T   compute-sanitizer memcheck (leak check), racecheck, synccheck,
#                 initcheck on the GPU finders' tests, all four at once, beside
#                 ctest and streams; racecheck without MatchesOracleFrameAfterFrame
#                 (its many launches took 115 s of gpusap's 139 under racecheck)
#   ctest         the whole suite but the gpu label (gpu-tests ran it), none
#                 skipped; the study label only where a python3 has matplotlib
#   streams       `overlap generate` scene-4 streams for the benchmark
#   bench-paper   the broadphase benchmark at 500-3500 boxes, every finder
#   bench-big     at 10^4 and 3*10^4 (bvh, cpusap, the GPU finders)
#   bench-huge    at 10^5 and 3*10^5, and bench-million at 10^6: cpusap and each
#                 GPU finder whose frame at the step before's largest n took at
#                 most twice cpusap's (the others take minutes)
#   frames-A      `overlap run` of scene 4 with --compare-sync, for cpusap and
#                 each GPU finder no slower than cpusap at 3500 boxes in
#                 bench-paper; frames-demo: the demo as it is
# The study (--study; DEADLINE_S 395 s):
#   study         scripts/study.py --runs-only with docs/REPORT.md's options,
#                 one shard per core into one --out, until the time left runs
#                 out; only Python's standard library is needed there
#   study-jobs    how many of the study's jobs are done (fails unless all are)
#   report        (dry run only) the report made from the archive, as here after
#                 a GPU loan: study.py --from-archive
# The GPU finders are those `overlap --list-algos --json` says need a device,
# so a new one is checked with no edit here.  Rules, each with its reason:
# - Each part ends by its DEADLINE_S, 10 s inside the command's limit (docs/GPU.md):
#   what is unfinished at the limit comes back with nothing archived.
# - Only the correctness steps run side by side; every timed step runs alone.
# - The study's shards start one after another, each once the one before has
#   probed the GPU: concurrent probes into one --out removed each other's files.
#   Runs compared with each other are in one shard, one after another
#   (study.py's shard_share); the report says what ran beside what.
# - What comes back is the archive and $OUT/gpu_check_summary.txt (the study:
#   gpu_study_summary.txt; the step table, rewritten after each step, so a
#   stopped run still tells); the logs are archived from $OUT/gpu-check/ (the
#   study: $OUT/gpu-study/).
# - A study stopped by its deadline resumes: copy the returned
#   gpu_study.tar.xz to .gpu-carry/resume.tar.xz and call --study again.
# - The report is made on the development machine from the returned archive:
#   scripts/study.py --from-archive gpu_study.tar.xz --out out/gpu-study --report
# --dry-run runs the same steps here on the CUDA emulation build
# (build-emulation/), at tiny sizes, compute-sanitizer replaced by a plain run
# of the same tests: a check of this script, never of the GPU.
# OUT: where results go (default out/gpu-check).  Knobs: DEADLINE_S,
# STUDY_SHARDS (cores), STUDY_OPTIONS (instead of REPORT.md's), CTEST_JOBS
# (12; dry run 2), CTEST_TIMEOUT (120 s a test; dry run 1500).
set -uo pipefail

cd "$(dirname "$0")/.." || exit 1
readonly ROOT="$PWD" SELF="$PWD/scripts/gpu_check.sh"

note() { echo "$*" >"$GC_WORK/notes/$GC_STEP"; }
die() {
  echo "gpu_check: $*" >&2
  exit 1
}
python_with() { "$GC_PYTHON" -c "$1"; }

# ---- Steps (each runs as `gpu_check.sh --step NAME FUNCTION ARGS...` under timeout) ----

step_unpack() {
  local pack=.gpu-carry/overlap-gpu.tar.xz
  [[ -f "$pack" ]] || die "$pack is missing: run scripts/gpu_pack.sh on the development machine and carry .gpu-carry"
  tar -xJf "$pack" || die "$pack did not unpack"
  local manifest="$GC_BUILD/gpu-pack/manifest"
  [[ -f "$manifest" ]] || die "$manifest is missing: the pack is not scripts/gpu_pack.sh's of $GC_BUILD"
  local source_dir
  source_dir="$(sed -n 's/^source_dir=//p' "$manifest")"
  if [[ "$source_dir" != "$ROOT" ]]; then
    if [[ -e "$source_dir" || -L "$source_dir" ]]; then
      [[ "$(realpath "$source_dir")" == "$(realpath "$ROOT")" ]] ||
        die "$source_dir (the packed build's checkout) exists here and is not this tree"
    else
      mkdir -p "$(dirname "$source_dir")" && ln -s "$ROOT" "$source_dir" ||
        die "cannot make $source_dir lead to $ROOT"
    fi
    echo "unpack: $source_dir -> $ROOT (the CTest files and the tests name it)"
  fi
  local changed
  changed="$(sha256sum --quiet -c "$GC_BUILD/gpu-pack/sums" 2>/dev/null | sed 's/: .*//')"
  echo "unpack: files changed since the pack: ${changed:-none}"
  if grep -Eq '\.(cpp|h|cu|cuh|cmake)$|CMakeLists\.txt$|^tests/' <<<"$changed"; then
    die "sources changed since the pack (above): run scripts/gpu_pack.sh again"
  fi
  # The layering checks call the configuring machine's cmake; study.quick its python3.
  local packed_cmake packed_python here_cmake fixed=""
  packed_cmake="$(sed -n 's/^cmake=//p' "$manifest")"
  packed_python="$(sed -n 's/^study_python=//p' "$manifest")"
  here_cmake="$(command -v cmake || true)"
  if [[ -n "$packed_cmake" && ! -x "$packed_cmake" && -n "$here_cmake" ]]; then
    find "$GC_BUILD" -name CTestTestfile.cmake -exec sed -i "s|\"$packed_cmake\"|\"$here_cmake\"|g" {} +
    fixed+=" cmake: $here_cmake;"
  fi
  if [[ -n "$packed_python" && "$packed_python" != "$GC_PLOT_PYTHON" && -n "$GC_PLOT_PYTHON" ]]; then
    find "$GC_BUILD" -name CTestTestfile.cmake -exec sed -i "s|\"$packed_python\"|\"$GC_PLOT_PYTHON\"|g" {} +
    fixed+=" python3: $GC_PLOT_PYTHON (matplotlib);"
  fi
  note "$(sed -n 's/^commit=/commit /p' "$manifest");${fixed:- CTest files as packed}"
}

step_info() {
  {
    echo "== date: $(date -u +%FT%TZ)"
    echo "== host: $(uname -srm); $(nproc) cores; $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2)"
    free -g | sed -n 2p
    [[ -f "$GC_BUILD/gpu-pack/manifest" ]] && cat "$GC_BUILD/gpu-pack/manifest"
    "$GC_BUILD/overlap" --version
    "$GC_BUILD/overlap" --list-algos
    echo "== GPU finders: $GC_GPU_FINDERS; python3: $GC_PYTHON; with matplotlib: ${GC_PLOT_PYTHON:-none}"
    if [[ "$GC_MODE" == gpu ]]; then
      nvidia-smi
      nvcc --version | tail -2
      "$GC_SANITIZER" --version | head -2
    fi
    cmake --version | head -1
  } 2>&1 | tee "$GC_WORK/info.txt"
  [[ "$GC_MODE" == dry ]] || nvidia-smi -L >/dev/null || die "nvidia-smi sees no GPU"
  note "$( [[ "$GC_MODE" == gpu ]] && nvidia-smi --query-gpu=name,driver_version --format=csv,noheader || echo 'dry run: no GPU')"
}

# Exits non-zero unless LOG shows passed tests and none skipped.
tests_all_ran() {
  local log="$1" passed skipped
  passed="$(sed -n 's/^\[  PASSED  \] \([0-9]*\) test.*/\1/p' "$log" | tail -1)"
  skipped="$(grep -c '^\[  SKIPPED \]' "$log")"
  note "${passed:-0} passed, $skipped skipped"
  [[ -n "$passed" && "$passed" -gt 0 ]] || die "no test passed"
  ((skipped == 0)) || die "$skipped tests were skipped"
}

step_gpu_tests() {
  "$GC_BUILD/tests/gpu/overlap_gpu_tests" --gtest_output="xml:$GC_WORK/gpu_tests.xml" || die "GPU tests failed"
  tests_all_ran "$GC_WORK/logs/$GC_STEP.log"
}

step_sanitizer() {
  local tool="$1" filter
  filter="$(sed 's/[^,][^,]*/*&*/g; s/-/_/g; s/,/:/g' <<<"$GC_GPU_FINDERS")"
  # racecheck instruments every shared-memory access: MatchesOracleFrameAfterFrame's
  # 280 finder runs took 115 s of gpusap's 139 on the H100. Its sizes (0 to 3500, CUB's
  # boundaries) stay covered by the tests kept: the change-list capacities, the growing
  # slot count, 2000 boxes for 20 frames against cpubf.
  [[ "$tool" == racecheck ]] && filter+="-*MatchesOracleFrameAfterFrame*"
  local command=("$GC_BUILD/tests/gpu/overlap_gpu_tests" --gtest_filter="$filter")
  if [[ "$GC_MODE" == gpu ]]; then
    local extra=()
    [[ "$tool" == memcheck ]] && extra=(--leak-check full)
    command=("$GC_SANITIZER" --tool "$tool" "${extra[@]}" --target-processes all --error-exitcode 1 "${command[@]}")
  else
    echo "dry run: in place of compute-sanitizer --tool $tool:"
  fi
  "${command[@]}" || die "$tool: errors or failed tests"
  tests_all_ran "$GC_WORK/logs/$GC_STEP.log"
  [[ "$GC_MODE" == dry ]] || note "$(cat "$GC_WORK/notes/$GC_STEP"); $(grep -Eo '(ERROR|RACECHECK) SUMMARY: [0-9]+ [a-z]+' \
    "$GC_WORK/logs/$GC_STEP.log" | tail -1)"
}

# The whole suite but the gpu label, which gpu-tests ran just before (the same
# binary); the study label (its figures need matplotlib) only where a python3 has it.
step_ctest() {
  local exclude=gpu
  [[ -n "$GC_PLOT_PYTHON" ]] || exclude="gpu|study"
  # The longest tests first (on the H100 study.quick took 54 s and Determinism's 53 s and
  # they started last, making ctest 111 s): ctest orders by the costs in this file.
  mkdir -p "$GC_BUILD/Testing/Temporary"
  ctest --test-dir "$GC_BUILD" -N | sed -n 's/^ *Test *#[0-9]*: \([^ ]*\).*/\1/p' |
    awk '{ print $1, 1, ($1 ~ /^(study\.|Determinism\.|Scenes3And4\/FiftyGScenes\.)/ ? 60 : 1) }' \
      >"$GC_BUILD/Testing/Temporary/CTestCostData.txt"
  ctest --test-dir "$GC_BUILD" -j "$GC_CTEST_JOBS" --timeout "$GC_CTEST_TIMEOUT" --output-on-failure \
    --output-junit "$GC_WORK/ctest.xml" -LE "^($exclude)\$"
  local rc=$? log="$GC_WORK/logs/$GC_STEP.log"
  local total failed skipped
  # ctest's summary line: "100% tests passed out of 486" when all pass,
  # "97% tests passed, 3 tests failed out of 486" otherwise.
  total="$(sed -En 's/.*% tests passed(, [0-9]+ tests failed)? out of ([0-9]+).*/\2/p' "$log" | tail -1)"
  failed="$(sed -En 's/.*% tests passed, ([0-9]+) tests failed out of.*/\1/p' "$log" | tail -1)"
  [[ -n "$total" && -z "$failed" ]] && failed=0
  skipped="$(grep -c '(Skipped)' "$log")"
  sed -n '/The following tests/,$p' "$log" >"$GC_WORK/ctest_summary.txt"
  note "${total:-?} tests, ${failed:-?} failed, $skipped skipped; not run: label $exclude (ctest_summary.txt)"
  ((rc == 0)) || die "ctest failed"
  ((skipped == 0)) || die "$skipped tests were skipped: with a device (or its emulation) none may be"
}

step_streams() {
  local pids=() n
  mkdir -p "$GC_STREAMS"
  for n in $GC_SMALL $GC_BIG $GC_HUGE $GC_MILLION; do
    local frames="$GC_BIG_FRAMES"
    [[ " $GC_SMALL " == *" $n "* ]] && frames="$GC_SMALL_FRAMES"
    [[ " $GC_HUGE " == *" $n "* ]] && frames="$GC_HUGE_FRAMES"
    [[ " $GC_MILLION " == *" $n "* ]] && frames="$GC_MILLION_FRAMES"
    "$GC_BUILD/overlap" generate --scene 4 --objects "$n" --frames "$frames" --skip 40 \
      --out "$GC_STREAMS/g$n.aabbs" &
    pids+=($!)
  done
  local failed=0 pid
  for pid in "${pids[@]}"; do wait "$pid" || failed=$((failed + 1)); done
  ls -l "$GC_STREAMS"
  note "$(ls "$GC_STREAMS" | wc -l) streams, $(du -sh "$GC_STREAMS" | cut -f1)"
  ((failed == 0)) || die "$failed generations failed"
}

# bench NAME "N..." ALGOS REPEATS WARMUP: one benchmark run; fails on a
# skipped algorithm (no device), a missed pair or an exact finder's mismatch.
step_bench() {
  local name="$1" sizes="$2" algos="$3" repeats="$4" warmup="$5" inputs=() n
  for n in $sizes; do inputs+=("$GC_STREAMS/g$n.aabbs"); done
  mkdir -p "$GC_WORK/bench"
  "$GC_BUILD/overlap_bench_broadphase" --input "${inputs[@]}" --algos "$algos" \
    --repeats "$repeats" --warmup "$warmup" --out "$GC_WORK/bench/$name" || die "the benchmark failed"
  if grep -q '^# skipped' "$GC_WORK/bench/$name.csv"; then
    die "algorithms were skipped: $(grep '^# skipped' "$GC_WORK/bench/$name.csv")"
  fi
  GC_JSON="$GC_WORK/bench/$name.json" python_with '
import json, os
rows = json.load(open(os.environ["GC_JSON"]))["rows"]
bad = [r["algorithm"] + " n=" + str(r["n"]) for r in rows
       if (r["missed_pairs"] or 0) > 0 or (r["mismatched_frames"] or 0) > 0]
print(len(rows), "rows:", ",".join(sorted({r["algorithm"] for r in rows})))
if bad:
    raise SystemExit("missed or mismatched pairs: " + ", ".join(bad))
' >"$GC_WORK/notes/$GC_STEP" || die "wrong pairs (see the note)"
}

# bench_scaled NAME "N..." FROM REPEATS: the benchmark at larger sizes for
# cpusap and each GPU finder whose frame at FROM's largest n took at most twice
# cpusap's there: one that falls further behind takes minutes at the next size.
step_bench_scaled() {
  local name="$1" sizes="$2" from="$3" repeats="$4" algos
  algos="$(GC_JSON="$GC_WORK/bench/$from.json" python_with '
import json, os
finders = os.environ["GC_GPU_FINDERS"].split(",")
rows = json.load(open(os.environ["GC_JSON"]))["rows"]
largest = max(r["n"] for r in rows)
frame = {r["algorithm"]: r["median_us"] for r in rows if r["n"] == largest}
print(",".join(["cpusap"] + [f for f in finders if f in frame and frame[f] <= 2 * frame["cpusap"]]))
')" || die "$from's results are missing: nothing tells which finders scale"
  step_bench "$name" "$sizes" "$algos" "$repeats" 2
}

# The finders worth a whole frame: cpusap and each GPU finder no slower than
# cpusap at bench-paper's largest n (the dry run: every one, to check the steps).
frame_finders() {
  [[ "$GC_MODE" == dry ]] && echo "cpusap ${GC_GPU_FINDERS//,/ }" && return
  GC_JSON="$GC_WORK/bench/bench-paper.json" python_with '
import json, os
finders = os.environ["GC_GPU_FINDERS"].split(",")
rows = json.load(open(os.environ["GC_JSON"]))["rows"]
largest = max(r["n"] for r in rows)
frame = {r["algorithm"]: r["median_us"] for r in rows if r["n"] == largest}
print(" ".join(["cpusap"] + [f for f in finders if f in frame and frame[f] <= frame["cpusap"]]))
' 2>/dev/null || echo "cpusap ${GC_GPU_FINDERS//,/ }"
}

# frames ALGO FOLDER [OPTIONS...]: one `overlap run`; the algorithm that ran must be ALGO.
step_frames() {
  local algo="$1" folder="$GC_WORK/frames/$2"
  shift 2
  "$GC_BUILD/overlap" run "$@" --out "$folder" || die "overlap run failed"
  GC_SUMMARY="$folder/summary.json" GC_ALGO="$algo" python_with '
import json, os
s = json.load(open(os.environ["GC_SUMMARY"]))
ran = s["parameters"]["algorithm"]
wanted = os.environ["GC_ALGO"]
t, sync = s["timings_ms"], s.get("compare_sync") or {}
frame, physics, broadphase = (t[k]["median"] for k in ("total_ms", "physics_ms", "broadphase_ms"))
state = s["state_hash"]
line = f"ran {ran}; frame {frame:.2f} ms, physics {physics:.2f}, broadphase {broadphase:.3f}; state {state}"
if sync:
    speedup, same = sync["speedup"], sync["identical_state"]
    line += f"; sync/async {speedup:.2f}, same state {same}"
print(line)
if ran != wanted:
    raise SystemExit(f"ran {ran}, not {wanted}")
' >"$GC_WORK/notes/$GC_STEP" || die "$(cat "$GC_WORK/notes/$GC_STEP")"
}

step_study() {
  local out="$GC_WORK/study" shards="$GC_STUDY_SHARDS" options i pids=()
  read -ra options <<<"$GC_STUDY_OPTIONS"
  mkdir -p "$out"
  if [[ -f "$GC_RESUME" ]]; then
    tar -C "$GC_WORK" -xJf "$GC_RESUME" ./study && echo "study: resumed from $GC_RESUME"
  fi
  for ((i = 1; i <= shards; i++)); do
    local log="$GC_WORK/logs/study_shard$i.log"
    PYTHONUNBUFFERED=1 "$GC_PYTHON" scripts/study.py "${options[@]}" --overlap "$ROOT/$GC_BUILD/overlap" \
      --out "$out" --shard "$i/$shards" --runs-only >"$log" 2>&1 &
    pids+=($!)
    local tries=0 # one GPU probe at a time (header's rules): a shard prints nothing before it
    until [[ -s "$log" ]] || ! kill -0 "$!" 2>/dev/null || ((tries++ > 300)); do
      sleep 0.1
    done
    echo "study: shard $i/$shards started at $(date +%T)"
  done
  local failed=0 pid
  for pid in "${pids[@]}"; do wait "$pid" || failed=$((failed + 1)); done
  note "$shards shards, $failed exited non-zero (logs/study_shard*.log)"
  ((failed == 0)) || die "$failed shards failed"
}

step_study_jobs() {
  local options counts
  read -ra options <<<"$GC_STUDY_OPTIONS"
  counts="$("$GC_PYTHON" - "${options[@]}" --overlap "$ROOT/$GC_BUILD/overlap" \
    --out "$GC_WORK/study" --no-runs <<'PY'
import sys
sys.path.insert(0, "scripts")
import broadphases, study
args = study.parse_args(sys.argv[1:])
broadphases.load(args.overlap)
jobs = study.plan(args)
print(sum(job.done() for job in jobs), len(jobs))
PY
  )" || die "could not count the study's jobs"
  read -r done_jobs total <<<"$counts"
  note "$done_jobs of $total jobs done$( ((done_jobs < total)) && echo ": resume with the archive")"
  ((done_jobs == total)) || die "the study is incomplete: copy the archive to .gpu-carry/resume.tar.xz and call --study again"
}

# Dry run only: what the development machine runs on the archive a GPU returns.
step_report() {
  mkdir -p "$GC_SCRATCH/no-notes" # the committed notes are the full report's
  "$GC_PLOT_PYTHON" scripts/study.py --from-archive "$OUT/gpu_study.tar.xz" --notes "$GC_SCRATCH/no-notes" \
    --overlap "$ROOT/$GC_BUILD/overlap" --out "$GC_SCRATCH/report-study" || die "no report from the archive"
  grep -q "^## Machine and runs" "$GC_SCRATCH/report-study/REPORT.md" || die "the report has no machine"
  note "REPORT.md and $(find "$GC_SCRATCH/report-study/report" -name '*.png' | wc -l) figures from the archive"
}

step_archive() {
  local archive="$OUT/$GC_ARCHIVE" limit=$((16 * 1024 * 1024)) excluded=""
  # Streams are made again in seconds; a run's timeline only if the archive needs the room.
  local leave_out=(--no-wildcards-match-slash --exclude='*.aabbs')
  tar -C "$GC_WORK" "${leave_out[@]}" -cf - . | xz -6 -T0 >"$archive" || die "tar failed"
  if (($(stat -c %s "$archive") > limit)); then
    excluded="runs' timeline.json (but the study's timeline run)"
    leave_out+=(--exclude='./study/*/*/timeline.json' --exclude='./frames/*/timeline.json')
    tar -C "$GC_WORK" "${leave_out[@]}" -cf - . | xz -6 -T0 >"$archive" || die "tar failed"
  fi
  local size
  size="$(stat -c %s "$archive")"
  note "$archive: $((size / 1024)) KiB${excluded:+, without the $excluded (over 16 MiB with them)}"
  ((size <= limit)) || die "the archive is over 16 MiB"
}

if [[ "${1:-}" == "--step" ]]; then
  GC_STEP="$2" function="$3"
  shift 3
  "$function" "$@"
  exit
fi

# ---- The run: configuration, then the steps ----

mode=gpu only="" part=check
while (($#)); do
  case "$1" in
    --dry-run) mode=dry ;;
    --study) part=study ;;
    --only) only=",$2," && shift ;;
    -h | --help) sed -n '2,/^set -uo/p' "$0" | sed '$d; s/^# \{0,1\}//' && exit 0 ;;
    *) echo "gpu_check: unknown option '$1' (--study, --dry-run, --only STEP,...)" >&2 && exit 2 ;;
  esac
  shift
done

OUT="$(realpath -m "${OUT:-$ROOT/out/gpu-check}")"
export GC_MODE="$mode" OUT
export GC_WORK="$OUT/gpu-$part" GC_SCRATCH="${TMPDIR:-/tmp}/gpu-check-$$" GC_ARCHIVE="gpu_$part.tar.xz"
export GC_STREAMS="$GC_SCRATCH/streams" GC_RESUME="$ROOT/.gpu-carry/resume.tar.xz"
export GC_STUDY_SHARDS="${STUDY_SHARDS:-$(nproc)}"
if [[ "$mode" == gpu ]]; then
  export GC_BUILD="${BUILD_DIR:-build}" GC_CTEST_JOBS="${CTEST_JOBS:-12}" GC_CTEST_TIMEOUT="${CTEST_TIMEOUT:-120}"
  export GC_SMALL="500 1250 2000 2750 3500" GC_BIG="10000 30000" GC_HUGE="100000 300000"
  export GC_MILLION=1000000 GC_SMALL_FRAMES=64 GC_BIG_FRAMES=16 GC_HUGE_FRAMES=8 GC_MILLION_FRAMES=3
  export GC_FRAME_OPTIONS="--scene 4 --objects 3500 --frames 12" GC_DEMO_OPTIONS=""
  default_deadline=$([[ "$part" == study ]] && echo 395 || echo 285)
  deadline_s="${DEADLINE_S:-$default_deadline}" paper=(3 8) big=(2 4) scale=1
  GC_SANITIZER="$(command -v compute-sanitizer || echo /usr/local/cuda/bin/compute-sanitizer)"
  export GC_SANITIZER
else
  export GC_BUILD=build-emulation GC_CTEST_JOBS="${CTEST_JOBS:-2}" GC_CTEST_TIMEOUT="${CTEST_TIMEOUT:-1500}"
  export GC_SMALL="50 90" GC_BIG="200" GC_HUGE="400" GC_MILLION=800
  export GC_SMALL_FRAMES=6 GC_BIG_FRAMES=4 GC_HUGE_FRAMES=4 GC_MILLION_FRAMES=3
  # The demo keeps enough boxes that the default rule
  # (physics/broadphase/default_broadphase.h) still picks gpubf, as it does
  # for the demo's 1000 on a GPU.
  export GC_FRAME_OPTIONS="--scene 4 --objects 60 --frames 4" GC_DEMO_OPTIONS="--objects 600 --frames 6"
  deadline_s="${DEADLINE_S:-7200}" paper=(1 1) big=(1 1) scale=10 GC_STUDY_SHARDS="${STUDY_SHARDS:-2}"
fi
started="$(date +%s)"
readonly started
readonly deadline=$((started + deadline_s))
rm -rf "$GC_WORK" "$OUT/$GC_ARCHIVE"
mkdir -p "$GC_WORK/logs" "$GC_WORK/notes" "$GC_SCRATCH"
trap 'rm -rf "$GC_SCRATCH"' EXIT
readonly summary="$OUT/gpu_${part}_summary.txt"
table=()
failures=0
reserve=0

write_summary() {
  {
    echo "scripts/gpu_check.sh ($GC_MODE run, the $part), started $(date -u -d "@$started" +%FT%TZ), $(($(date +%s) - started)) s so far"
    printf '%s\n' "${table[@]}"
  } >"$summary"
}

# Steps started with start_step run side by side until finish_steps.
declare -A step_budget step_started
running=()
start_step() {
  local name="$1" budget="$2" function="$3"
  shift 3
  if [[ -n "$only" && "$only" != *",$name,"* && "$name" != unpack && "$name" != info ]]; then
    return 0
  fi
  ((budget *= scale))
  local left=$((deadline - $(date +%s) - reserve))
  ((budget > left)) && budget=$left
  if ((budget < 5)); then
    record "$name" skip 0 0 "no time left before the deadline"
    return 0
  fi
  step_budget[$name]=$budget step_started[$name]=$(date +%s)
  running+=("$name")
  (
    timeout -k 10 "$budget" "$SELF" --step "$name" "$function" "$@" >"$GC_WORK/logs/$name.log" 2>&1
    echo $? >"$GC_WORK/logs/$name.rc"
  ) &
}

finish_steps() {
  wait
  local name rc status
  for name in "${running[@]}"; do
    rc="$(cat "$GC_WORK/logs/$name.rc" 2>/dev/null || echo 1)"
    case "$rc" in 0) status=pass ;; 124 | 137) status=TIMEOUT ;; *) status=FAIL ;; esac
    local note
    note="$(cat "$GC_WORK/notes/$name" 2>/dev/null || tail -1 "$GC_WORK/logs/$name.log")"
    record "$name" "$status" "$(($(stat -c %Y "$GC_WORK/logs/$name.rc") - step_started[$name]))" \
      "${step_budget[$name]}" "$note"
  done
  step_started=() step_budget=() running=()
}

record() {
  local line
  line="$(printf '%-20s %-7s %4s s of %4s  %s' "$1" "$2" "$3" "$4" "${5:0:150}")"
  [[ "$2" == pass ]] || failures=$((failures + 1))
  table+=("$line")
  echo "gpu_check: $line"
  write_summary
}

run_step() { start_step "$@" && finish_steps; }

# Any python3 runs the study and the steps' checks (the standard library is all they
# need); CTest's study tests, and the report's figures, need one with matplotlib.
export GC_PYTHON GC_PLOT_PYTHON=""
GC_PYTHON="$(command -v python3 || echo /usr/bin/python3)"
for candidate in python3 /usr/bin/python3; do
  if "$candidate" -c 'import matplotlib, numpy' 2>/dev/null; then
    GC_PLOT_PYTHON="$(command -v "$candidate")" && break
  fi
done
reserve=10 # the archive's budget, kept from every step before it
[[ "$mode" == gpu ]] && run_step unpack 30 step_unpack
[[ -x "$GC_BUILD/overlap" ]] || die "$GC_BUILD/overlap is missing (dry run: cmake --preset cuda-emulation and build it)"
GC_GPU_FINDERS="$("$GC_BUILD/overlap" --list-algos --json | "$GC_PYTHON" -c '
import json, sys
print(",".join(b["name"] for b in json.load(sys.stdin)["broadphases"] if b["needs_device"]))')"
export GC_GPU_FINDERS
if [[ -z "${STUDY_OPTIONS:-}" && "$mode" == gpu ]]; then
  # The options the committed report was made with, less its folders and --no-runs --report.
  STUDY_OPTIONS="$("$GC_PYTHON" -c '
import re, shlex
line = re.search(r"This report: `scripts/study.py ([^`]*)`", open("docs/REPORT.md").read()).group(1)
words, kept = shlex.split(line), []
while words:
    word = words.pop(0)
    if word in ("--overlap", "--emulation", "--out"): words.pop(0)
    elif word not in ("--no-runs", "--report"): kept.append(word)
print(" ".join(kept))')" || die "docs/REPORT.md names no 'This report: \`scripts/study.py ...\`' line"
elif [[ -z "${STUDY_OPTIONS:-}" ]]; then
  gpu="$GC_GPU_FINDERS"
  STUDY_OPTIONS="--quick --threads 1 --scenes 1,4 --objects 40 --algos bvh,cpusap,$gpu --frames 3
    --figure-objects 40 --pairs-objects 40 --pairs-frames 3 --pairs-algos bf,cpusap,$gpu
    --physics-scenes 1 --physics-objects 40 --physics-frames 3 --physics-substeps 1,auto
    --physics-seeds 7 --latency-scenes 4 --latency-objects 40 --latency-frames 3
    --latency-algos bvh,$gpu --timeline-objects 40 --timeline-frames 3 --overlap-scenes 4
    --overlap-objects 40 --overlap-loads 0,1 --overlap-frames 3 --overlap-repetitions 1"
fi
GC_STUDY_OPTIONS="$(tr -s " \n" "  " <<<"$STUDY_OPTIONS")"
export GC_STUDY_OPTIONS

# Budgets (s) from the H100's step times (docs/results/gpu/h100/README.md), in brackets.
run_step info 15 step_info # [0-1]
if [[ "$part" == check ]]; then
  run_step gpu-tests 30 step_gpu_tests # [7]
  for tool in memcheck racecheck synccheck initcheck; do # [25-27 each; racecheck, see above]
    start_step "sanitizer-$tool" 90 step_sanitizer "$tool"
  done
  start_step ctest 120 step_ctest # [111 at -j 10, the longest tests last]
  start_step streams 90 step_streams # [6 without 10^6]
  finish_steps
  run_step bench-paper 40 step_bench bench-paper "$GC_SMALL" "sap,bvh,cpubf,cpusap,$GC_GPU_FINDERS" "${paper[@]}" # [31 at 5 repeats]
  run_step bench-big 40 step_bench bench-big "$GC_BIG" "bvh,cpusap,$GC_GPU_FINDERS" "${big[@]}" # [45 at 3 repeats]
  run_step bench-huge 40 step_bench_scaled bench-huge "$GC_HUGE" bench-big 2 # [10^5: 11]
  run_step bench-million 30 step_bench_scaled bench-million "$GC_MILLION" bench-huge 2
  run_step frames-demo 20 step_frames gpubf demo $GC_DEMO_OPTIONS # [12]
  for algo in $(frame_finders); do # [25-35 each at 24 frames]
    run_step "frames-$algo" 25 step_frames "$algo" "$algo" $GC_FRAME_OPTIONS --algo "$algo" \
      --task-load 1 --compare-sync --capture-every 0 --no-wav
  done
else
  reserve=20 # study-jobs' and the archive's
  run_step study 9999 step_study
  reserve=10
  run_step study-jobs 10 step_study_jobs # [the study-report step counted them in 3 s]
fi
reserve=0
run_step archive 10 step_archive
if [[ "$mode" == dry && "$part" == study ]]; then
  [[ -n "$GC_PLOT_PYTHON" ]] || die "the dry run's report needs a python3 with matplotlib"
  run_step report 60 step_report
fi
if [[ "$mode" == gpu && -f "$OUT/$GC_ARCHIVE" ]]; then
  rm -rf "$GC_WORK" # only the archive and the summary come back
fi
echo
echo "gpu_check: $GC_MODE run of the $part, $(($(date +%s) - started)) s, $failures steps failed or timed out"
printf '  %s\n' "${table[@]}"
exit $((failures > 0))
