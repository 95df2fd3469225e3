#!/usr/bin/env bash
# CI under sanitizers, after scripts/setup.sh and the Release suite: what only
# a sanitizer build can show.  First AddressSanitizer + UBSan (preset "asan",
# a CUDA emulation build: the .cu files run on the CPU, so every GPU test
# runs, none may skip (it fails under OVERLAP_REQUIRE_DEVICE=1), and ASan
# stands in for compute-sanitizer's memcheck) over ASAN_TARGETS: the GPU
# finders, physics, the hard cases, the renderer and the fuzz corpora's
# replays (label fuzz), but the whole runs of hundreds to thousands of
# frames (label long), the studies and the end-to-end CLI tests, which run in
# the Release suite.  Then the unit tests of the threaded code (label
# threads: cpubf's and cpusap's search jobs, the frame scheduler and job
# graph, the sound and AI tasks, the stream generator, the parallel
# narrowphase and solver) under ThreadSanitizer (preset "tsan", CPU code
# only: TSan cannot follow the emulation's fibers).
# tests/lsan.supp holds OSMesa's known leak, for a program that draws (the
# renderer's tests carry the same rule compiled in); tests/tsan.supp and the
# TSan section below deal with oneTBB, which is not TSan-instrumented.  Both
# builds go through ccache where it is installed.
# Usage: [SANITIZERS="asan tsan"] scripts/ci_sanitizers.sh [ASAN_BUILD_DIR] [TSAN_BUILD_DIR]
# (default: both, in the presets' build-asan and build-tsan).
set -euo pipefail
cd "$(dirname "$0")/.."
readonly ASAN_DIR="${1:-build-asan}"
readonly TSAN_DIR="${2:-build-tsan}"
readonly JOBS="$(nproc)"
# -O1 with line tables halves the compile time of -O2 -g (docs/results/ci_stages.md) and
# keeps the sanitizers' stack traces.
readonly SANITIZER_FLAGS="-O1 -g1 -DNDEBUG"
# Unity builds, 16 sources a compile: the engine's sources each include
# CLI11 whole (header-only), which one file at a time cost most of the
# build (docs/results/ci_stages.md).
readonly UNITY=(-DCMAKE_UNITY_BUILD=ON -DCMAKE_UNITY_BUILD_BATCH_SIZE=16)
# The ASan + UBSan stage's executables: the GPU finders on the emulation
# (which the Release suite skips without a device), the physics and hard
# cases the finders feed, the renderer, and the fuzz corpora's replays.  The
# CLI's end-to-end tests, the engine's and the stubs' unit tests run in the
# Release suite (the stubs' and the scheduler's under TSan too): on 2 cores
# the whole suite under ASan took 596 s, build included, of CI's 900.
readonly ASAN_TARGETS=(overlap_gpu_tests overlap_cuda_emulation_tests overlap_physics_tests
  overlap_solver_tests overlap_narrowphase_tests overlap_hard_cases_tests render_tests
  replay_aabb_stream replay_command_line overlap_finder_memory_tests)
readonly ASAN_LABELS='gpu|emulation|physics|hard_cases|render|fuzz'
# The test executables labelled threads (tests/*/CMakeLists.txt).
readonly TSAN_TARGETS=(overlap_gpu_tests overlap_scheduler_tests stubs_tests overlap_stream_tests
  overlap_narrowphase_tests overlap_solver_tests)

section() { printf '\n== %s: %s\n' "$(date +%T)" "$*"; }

readonly SANITIZERS="${SANITIZERS:-asan tsan}"

tsan_build() {
  cmake --preset tsan -B "$TSAN_DIR" -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="$SANITIZER_FLAGS" \
    "${UNITY[@]}" >/dev/null
  cmake --build "$TSAN_DIR" -j "$JOBS" --target "${TSAN_TARGETS[@]}"
}
# With both, the TSan build runs at low priority beside the ASan suite, which
# leaves part of the two CPUs idle (268 CPU-seconds in 229 s,
# docs/results/ci_stages.md); its output follows the suite's.
tsan_log=""
if [[ " $SANITIZERS " == *" asan "* && " $SANITIZERS " == *" tsan "* ]]; then
  tsan_log=$(mktemp)
  trap 'wait; rm -f "$tsan_log"' EXIT
fi

if [[ " $SANITIZERS " == *" asan "* ]]; then
section "ASan + UBSan: configure and build ($ASAN_DIR)"
cmake --preset asan -B "$ASAN_DIR" -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="$SANITIZER_FLAGS" \
  "${UNITY[@]}" >/dev/null
cmake --build "$ASAN_DIR" -j "$JOBS" --target "${ASAN_TARGETS[@]}"
if [[ -n "$tsan_log" ]]; then
  section "TSan: configure and build ($TSAN_DIR) beside the ASan suite"
  (renice -n 10 -p "$BASHPID" >/dev/null; tsan_build) >"$tsan_log" 2>&1 &
  tsan_pid=$!
fi
section "ASan + UBSan: the GPU finders on the CUDA emulation, physics, hard cases, renderer, fuzz corpora"
# The long whole runs, the studies, the end-to-end tests and the CPU
# broadphases' memory counts (not built here: a test of an executable not
# built has no label) run in the Release suite alone (under ASan, beside the
# TSan build, study.quick, study.archive and study.verdicts each ran past
# their timeouts).
# OVERLAP_REQUIRE_DEVICE=1: the emulation is the device, so a GPU test that would
# skip fails (tests/needs_device.h); ctest's exit status is the verdict, its JUnit
# file the record.
OVERLAP_REQUIRE_DEVICE=1 \
ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:strict_string_checks=1:check_initialization_order=1" \
LSAN_OPTIONS="suppressions=$PWD/tests/lsan.supp:print_suppressions=0" \
UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1" \
  ctest --test-dir "$ASAN_DIR" --output-on-failure -j "$JOBS" -L "$ASAN_LABELS" -LE 'long|study|e2e' \
    --output-junit ctest-junit.xml  # in $ASAN_DIR
fi

if [[ " $SANITIZERS " == *" tsan "* ]]; then

if [[ -n "$tsan_log" ]]; then
  section "TSan: the build beside the ASan suite"
  tsan_status=0
  wait "$tsan_pid" || tsan_status=$?
  cat "$tsan_log"
  ((tsan_status == 0)) || exit "$tsan_status"
else
  section "TSan: configure and build ($TSAN_DIR)"
  tsan_build
fi
section "TSan: the tests labelled threads"
# Two workers really run: the TSan build's task system is gpu/task_system.h's
# plain-thread back end (Debian's oneTBB is not built with TSan, and its
# hand-overs would look racy), which starts every thread it is asked for,
# so the tests' systems of 2 to 8 threads race on both CPUs.
# Left to the Release suite: the narrowphase equality beside finders that
# search on no task thread (bf, cpubf and cpusap stay: the search beside the
# narrowphase is theirs).  The whole-step thread-count runs of scenes 3 and 4
# are label long (scenes 1 and 2 run every parallel part of the step the same
# way; 3 and 4 took 122 of this stage's 351 test-seconds here).
TSAN_OPTIONS="suppressions=$PWD/tests/tsan.supp:halt_on_error=1:second_deadlock_stack=1" \
  ctest --test-dir "$TSAN_DIR" --output-on-failure -j "$JOBS" -L threads \
    -E '^EveryBroadphase/Narrowphase\..*/(bvh|sap|sap32|gpubf|gpubf_paper|gpusap)( |$)'
fi
section "sanitizers: no finding"
