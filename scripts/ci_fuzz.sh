#!/usr/bin/env bash
# Fuzzing, after scripts/setup.sh (.ci/run runs it when FUZZ_SECONDS is set;
# the corpora are replayed in every CI run by scripts/ci_sanitizers.sh, in the
# ASan build): builds the libFuzzer targets of
# tests/fuzz in a clang build (ASan + UBSan, CUDA off), replays each
# committed corpus, then fuzzes each target for FUZZ_SECONDS (default 20) on
# a scratch copy of its corpus with its dictionary.  Exits non-zero on any
# crash, sanitizer report or broken promise; the input that did it is kept
# as BUILD_DIR/fuzz-findings/<target>-crash-*.
# Usage: scripts/ci_fuzz.sh [BUILD_DIR]   (default build-fuzz)
set -euo pipefail
cd "$(dirname "$0")/.."
readonly BUILD_DIR="${1:-build-fuzz}"
readonly SECONDS_PER_TARGET="${FUZZ_SECONDS:-20}"
readonly INPUTS=(aabb_stream command_line)

if ! command -v clang++ >/dev/null ||
   ! echo 'extern "C" int LLVMFuzzerTestOneInput(const char*, unsigned long) { return 0; }' |
     clang++ -fsanitize=fuzzer -x c++ - -o /dev/null 2>/dev/null; then
  echo "ci_fuzz: needs clang++ with libFuzzer (Debian: clang libclang-rt-14-dev)" >&2
  exit 2
fi

# -O1 with line tables, asserts on: quicker to build than -O2 -g, as fast to fuzz.
CC=clang CXX=clang++ cmake -S . -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1" -DOVERLAP_FUZZ=ON -DOVERLAP_WITH_CUDA=OFF >/dev/null
cmake --build "$BUILD_DIR" -j "$(nproc)" --target "${INPUTS[@]/#/fuzz_}"
ctest --test-dir "$BUILD_DIR" -L fuzz --output-on-failure

findings="$BUILD_DIR/fuzz-findings"
mkdir -p "$findings"
status=0
for input in "${INPUTS[@]}"; do
  scratch="$BUILD_DIR/fuzz-corpus/$input"  # libFuzzer adds what it learns to the first folder
  mkdir -p "$scratch"
  log="$findings/$input.log"
  if "$BUILD_DIR/tests/fuzz/fuzz_$input" -max_total_time="$SECONDS_PER_TARGET" \
       -dict="tests/fuzz/$input.dict" -artifact_prefix="$findings/$input-" \
       -print_final_stats=1 "$scratch" "tests/fuzz/corpus/$input" >"$log" 2>&1; then
    echo "fuzz_$input: $(grep -m1 '^Done' "$log"), no finding"
  else
    status=1
    echo "fuzz_$input: FINDING (input kept in $findings/):" >&2
    grep -v '^"' "$log" | grep -v '^#' | tail -n 40 >&2
  fi
done
exit "$status"
