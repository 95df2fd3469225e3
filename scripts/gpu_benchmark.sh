#!/usr/bin/env bash
# The GPU session's run on the device machine (an H100, no Bullet, no package
# registry), from the repository root:
#   scripts/gpu_benchmark.sh [BUILD_DIR] [STEP...]   STEP: tests, sanitize, record, bench
# With no step it runs all four in that order.  Each step fits the device
# tool's 10-minute limit on its own, so a session can run them as separate calls.
#
# Before, on the development machine (CUDA code is compiled there, sm_75 to sm_90):
#   cmake --build BUILD_DIR --target overlap_bench_broadphase overlap_gpu_tests
#   scripts/gpu_bundle.sh BUILD_DIR      # Bullet, oneTBB... into BUILD_DIR/gpu-libs
# and carry BUILD_DIR/overlap_bench_broadphase, BUILD_DIR/tests/gpu/overlap_gpu_tests
# and BUILD_DIR/gpu-libs (plus out/streams to reuse streams recorded there).
#
#   tests   the GPU tests (gtest binary; ctest's paths point at the other
#           machine); fails if any test fails or is skipped.
#   sanitize  the GPU finders' tests under compute-sanitizer: memcheck (out of
#           bounds, misaligned, leaks) and racecheck (shared-memory hazards);
#           fails on any report.  What the CUDA emulation's ASan build cannot
#           see: the real device, its memory model and its driver.
#   record  records the missing streams into out/streams, one process per n
#           (Bullet runs on one thread per process).
#   bench   overlap_bench_broadphase with every algorithm at the paper's n and
#           bvh, cpubf, gpubf at BIG_OBJECTS; fails if no GPU algorithm ran.
# Writes into $OUT: nvidia-smi.txt, gpu_tests.{log,xml}, record_n*.log,
# sanitizer_{memcheck,racecheck}.log, broadphase_gpu.{csv,json}, bench.log.
# Knobs (environment): BIG_OBJECTS (10000,30000,100000), BIG_FRAMES (frames
# recorded at BIG_OBJECTS, 24: 17 measured after 8 warm-up frames; 100000
# boxes took 787 s for 24 frames on the 2-core development machine, so run
# `record` as a call of its own), REPEATS (5).
set -euo pipefail

cd "$(dirname "$0")/.."
build_dir="${1:-build}"
shift || true
steps=("$@")
((${#steps[@]})) || steps=(tests sanitize record bench)

: "${OUT:?gpu_benchmark: OUT must name the output folder}"
readonly SMALL_OBJECTS=500,1250,2000,2750,3500
readonly BIG_OBJECTS="${BIG_OBJECTS:-10000,30000,100000}"
readonly BIG_FRAMES="${BIG_FRAMES:-24}"
readonly REPEATS="${REPEATS:-5}"
readonly bench="$build_dir/overlap_bench_broadphase"
readonly tests="$build_dir/tests/gpu/overlap_gpu_tests"
export LD_LIBRARY_PATH="$build_dir/gpu-libs${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
mkdir -p "$OUT"

fail() {
  echo "gpu_benchmark: $*" >&2
  exit 1
}

run_tests() {
  "$tests" --gtest_output="xml:$OUT/gpu_tests.xml" 2>&1 | tee "$OUT/gpu_tests.log"
  if grep -q '^\[  SKIPPED \]' "$OUT/gpu_tests.log"; then
    fail "GPU tests were skipped on the device machine (see gpu_tests.log)"
  fi
}

run_sanitizers() {
  local sanitizer
  sanitizer="$(command -v compute-sanitizer || echo /usr/local/cuda/bin/compute-sanitizer)"
  [[ -x "$sanitizer" ]] || fail "compute-sanitizer not found (CUDA toolkit's bin/)"
  local tool
  for tool in memcheck racecheck; do
    local extra=()
    [[ "$tool" == memcheck ]] && extra=(--leak-check full)
    "$sanitizer" --tool "$tool" "${extra[@]}" --error-exitcode 1 \
      "$tests" --gtest_filter='*gpubf*' 2>&1 | tee "$OUT/sanitizer_$tool.log" ||
      fail "compute-sanitizer $tool found errors (see sanitizer_$tool.log)"
  done
}

record_streams() {
  local pids=() n
  for n in ${SMALL_OBJECTS//,/ }; do
    "$bench" --record-only --objects "$n" --big-objects 0 >"$OUT/record_n$n.log" 2>&1 &
    pids+=($!)
  done
  for n in ${BIG_OBJECTS//,/ }; do
    "$bench" --record-only --objects 0 --big-objects "$n" --big-record-frames "$BIG_FRAMES" \
      >"$OUT/record_n$n.log" 2>&1 &
    pids+=($!)
  done
  local failed=0 pid
  for pid in "${pids[@]}"; do wait "$pid" || failed=1; done
  grep -h "overlap_bench_broadphase: n=" "$OUT"/record_n*.log || true
  ((failed == 0)) || fail "recording failed (see record_n*.log)"
}

run_bench() {
  "$bench" --objects "$SMALL_OBJECTS" --algos bf,sap,bvh,cpubf,gpubf,gpubf-paper \
    --big-objects "$BIG_OBJECTS" --big-algos bvh,cpubf,gpubf --big-record-frames "$BIG_FRAMES" \
    --repeats "$REPEATS" --out "$OUT/broadphase_gpu" 2>&1 | tee "$OUT/bench.log"
  if grep -q '^# skipped' "$OUT/broadphase_gpu.csv"; then
    fail "the GPU algorithms did not run (see broadphase_gpu.csv's header)"
  fi
}

nvidia-smi >"$OUT/nvidia-smi.txt" 2>&1 || echo "gpu_benchmark: nvidia-smi failed" >&2
for step in "${steps[@]}"; do
  case "$step" in
    tests) run_tests ;;
    sanitize) run_sanitizers ;;
    record) record_streams ;;
    bench) run_bench ;;
    *) fail "unknown step '$step' (tests, sanitize, record, bench)" ;;
  esac
done
