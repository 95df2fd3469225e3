#!/usr/bin/env bash
# The GPU session's run on a borrowed device machine (an H100, no Bullet, no
# package registry), from the repository root, one step per call of the
# device tool (each is sized to finish within its 10-minute limit):
#   scripts/gpu_benchmark.sh [--dry-run] [BUILD_DIR] STEP...
# With no step it lists them.  Steps:
#   tests       the GPU tests (gtest binary; ctest's paths point at the other
#               machine); fails if any test fails or is skipped.
#   memcheck    the GPU finders' tests under compute-sanitizer's memcheck (out
#               of bounds, misaligned, leaks), synccheck (ballot and shuffle
#   synccheck   masks, barriers) and initcheck (device memory read before it
#   initcheck   was written: the "words past the last row are zero"
#               invariant); fails on any report.  What the CUDA emulation's
#               ASan build cannot see: the device, its memory model, the driver.
#   record      records the missing streams of the paper's n and of
#               BIG_OBJECTS, one process per n (Bullet runs on one thread).
#   bench       every algorithm but bf at the paper's n, REPEATS repeats.
#   bench-bf    bf (btSimpleBroadphase, O(n^2) on the CPU) at the paper's n,
#               BF_REPEATS repeats (the reference at those n is then cpubf).
#   bench-big   bvh, cpubf, gpubf at BIG_OBJECTS.
# Streams live in $OUT/streams, which comes back with the step's results;
# streams carried in STREAMS_FROM (default out/streams) are copied there
# first, so a later call reuses what an earlier one recorded.
#
# Before, on the development machine (CUDA code is compiled there, sm_75 to sm_90):
#   cmake --build BUILD_DIR --target overlap_bench_broadphase overlap_gpu_tests
#   scripts/gpu_bundle.sh BUILD_DIR      # Bullet, oneTBB... into BUILD_DIR/gpu-libs
# and carry BUILD_DIR/overlap_bench_broadphase, BUILD_DIR/tests/gpu/overlap_gpu_tests
# and BUILD_DIR/gpu-libs (plus out/streams to reuse streams recorded there).
#
# --dry-run runs the same steps on the CPU, against the CUDA emulation build
# (BUILD_DIR defaults to build-emulation), at tiny sizes and with the
# sanitizer steps running the tests without compute-sanitizer (it needs a
# GPU): a check of the script and its commands, never of the GPU.  E.g.
#   OUT=/tmp/gpu-dry scripts/gpu_benchmark.sh --dry-run tests memcheck record bench bench-bf bench-big
#
# Writes into $OUT: nvidia-smi.txt, gpu_tests.{log,xml}, sanitizer_TOOL.log,
# record_n*.log, streams/, broadphase_{gpu,bf,big}.{csv,json}, bench*.log.
# Knobs (environment): BIG_OBJECTS (10000,30000,100000), BIG_FRAMES (frames
# recorded at BIG_OBJECTS, 16: 8 measured after 8 warm-up frames; 100000
# boxes took 787 s for 24 frames on the 2-core development machine, so about
# 525 s for 16), REPEATS (5), BF_REPEATS (1), STREAMS_FROM (out/streams).
set -euo pipefail

cd "$(dirname "$0")/.."
dry_run=0
if [[ "${1:-}" == "--dry-run" ]]; then
  dry_run=1
  shift
fi
build_dir="build"
((dry_run)) && build_dir="build-emulation"
readonly STEPS=" tests memcheck synccheck initcheck record bench bench-bf bench-big "
if [[ $# -gt 0 && "$STEPS" != *" $1 "* ]]; then
  build_dir="$1"
  shift
fi
steps=("$@")

fail() {
  echo "gpu_benchmark: $*" >&2
  exit 1
}

if ((${#steps[@]} == 0)); then
  echo "gpu_benchmark: name the steps to run, one call each on a borrowed machine:" >&2
  echo " $STEPS" >&2
  exit 2
fi

: "${OUT:?gpu_benchmark: OUT must name the output folder}"
if ((dry_run)); then
  readonly SMALL_OBJECTS=40,90
  readonly BIG_OBJECTS=150
  readonly BIG_FRAMES=4 REPEATS=1 BF_REPEATS=1 WARMUP=1 SMALL_FRAMES=4
else
  readonly SMALL_OBJECTS=500,1250,2000,2750,3500
  readonly BIG_OBJECTS="${BIG_OBJECTS:-10000,30000,100000}"
  readonly BIG_FRAMES="${BIG_FRAMES:-16}"
  readonly REPEATS="${REPEATS:-5}"
  readonly BF_REPEATS="${BF_REPEATS:-1}"
  readonly WARMUP=8 SMALL_FRAMES=64
fi
readonly bench="$build_dir/overlap_bench_broadphase"
readonly tests="$build_dir/tests/gpu/overlap_gpu_tests"
readonly streams="$OUT/streams"
export LD_LIBRARY_PATH="$build_dir/gpu-libs${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
mkdir -p "$OUT" "$streams"
for binary in "$bench" "$tests"; do
  [[ -x "$binary" ]] || fail "$binary is missing (see this script's header for what to build and carry)"
done
if [[ -d "${STREAMS_FROM:-out/streams}" ]]; then
  cp -n "${STREAMS_FROM:-out/streams}"/* "$streams"/ 2>/dev/null || true
fi

run_tests() {
  "$tests" --gtest_output="xml:$OUT/gpu_tests.xml" 2>&1 | tee "$OUT/gpu_tests.log"
  if grep -q '^\[  SKIPPED \]' "$OUT/gpu_tests.log"; then
    fail "GPU tests were skipped (see gpu_tests.log)"
  fi
}

# The GPU finders' tests (gpubf and gpubf-paper) under one sanitizer tool.
run_sanitizer() {
  local tool="$1" extra=()
  [[ "$tool" == memcheck ]] && extra=(--leak-check full)
  local command=("$tests" --gtest_filter='*gpubf*')
  if ((dry_run)); then
    echo "gpu_benchmark: dry run: compute-sanitizer --tool $tool ${extra[*]} --error-exitcode 1 runs:" \
      | tee "$OUT/sanitizer_$tool.log"
  else
    local sanitizer
    sanitizer="$(command -v compute-sanitizer || echo /usr/local/cuda/bin/compute-sanitizer)"
    [[ -x "$sanitizer" ]] || fail "compute-sanitizer not found (CUDA toolkit's bin/)"
    command=("$sanitizer" --tool "$tool" "${extra[@]}" --error-exitcode 1 "${command[@]}")
  fi
  "${command[@]}" 2>&1 | tee -a "$OUT/sanitizer_$tool.log" ||
    fail "compute-sanitizer $tool found errors (see sanitizer_$tool.log)"
}

record_streams() {
  local pids=() n
  for n in ${SMALL_OBJECTS//,/ }; do
    "$bench" --record-only --streams "$streams" --warmup "$WARMUP" --objects "$n" --big-objects 0 \
      --record-frames "$SMALL_FRAMES" >"$OUT/record_n$n.log" 2>&1 &
    pids+=($!)
  done
  for n in ${BIG_OBJECTS//,/ }; do
    "$bench" --record-only --streams "$streams" --warmup "$WARMUP" --objects 0 --big-objects "$n" \
      --big-record-frames "$BIG_FRAMES" >"$OUT/record_n$n.log" 2>&1 &
    pids+=($!)
  done
  local failed=0 pid
  for pid in "${pids[@]}"; do wait "$pid" || failed=1; done
  grep -h "overlap_bench_broadphase: n=" "$OUT"/record_n*.log || true
  ((failed == 0)) || fail "recording failed (see record_n*.log)"
}

# run_bench NAME ARGS...: one bench run into $OUT/broadphase_NAME.{csv,json}.
run_bench() {
  local name="$1"
  shift
  "$bench" --streams "$streams" --record-frames "$SMALL_FRAMES" --big-record-frames "$BIG_FRAMES" \
    --warmup "$WARMUP" --out "$OUT/broadphase_$name" "$@" 2>&1 | tee "$OUT/bench_$name.log"
  if grep -q '^# skipped' "$OUT/broadphase_$name.csv"; then
    fail "the GPU algorithms did not run (see broadphase_$name.csv's header)"
  fi
}

if ((dry_run)); then
  echo "gpu_benchmark: dry run on the CPU ($build_dir): no GPU figure comes of it" >"$OUT/nvidia-smi.txt"
else
  nvidia-smi >"$OUT/nvidia-smi.txt" 2>&1 || echo "gpu_benchmark: nvidia-smi failed" >&2
fi
for step in "${steps[@]}"; do
  case "$step" in
    tests) run_tests ;;
    memcheck | synccheck | initcheck) run_sanitizer "$step" ;;
    record) record_streams ;;
    bench)
      run_bench gpu --objects "$SMALL_OBJECTS" --algos sap,bvh,cpubf,cpusap,gpubf,gpubf-paper \
        --big-objects 0 --repeats "$REPEATS"
      ;;
    bench-bf)
      run_bench bf --objects "$SMALL_OBJECTS" --algos bf,cpubf --big-objects 0 \
        --repeats "$BF_REPEATS"
      ;;
    bench-big)
      run_bench big --objects 0 --big-objects "$BIG_OBJECTS" --big-algos bvh,cpubf,gpubf \
        --repeats "$REPEATS"
      ;;
    *) fail "unknown step '$step' (steps:$STEPS)" ;;
  esac
done
