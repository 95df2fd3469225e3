#!/usr/bin/env bash
# scripts/gpu_check.sh's own promises, checked without a GPU or a build: a copy
# of the driver in a scratch tree, beside a fake build-emulation/overlap.
#   gpu_check_test.sh refuses-an-unknown-step   --only bogus (frames-bogus, ","): exit 2 naming it,
#                                               nothing removed
#   gpu_check_test.sh refuses-what-cannot-run   no build or one that fails, no pack: exit 2 naming
#                                               it, nothing removed
#   gpu_check_test.sh a-signal-ends-every-step  SIGTERM: every step's processes end, nothing
#                                               more is written into $OUT, the table says so
set -uo pipefail
readonly SOURCE="$(cd "$(dirname "$0")/../.." && pwd)"
tree="$(mktemp -d)" && trap 'rm -rf "$tree"' EXIT
mkdir -p "$tree/scripts" && cp "$SOURCE/scripts/gpu_check.sh" "$SOURCE/scripts/gpu_check_steps.py" "$tree/scripts/"
export OUT="$tree/out"
failed() { echo "gpu_check_test: FAILED: $*" >&2 && exit 1; }
earlier_run() { mkdir -p "$OUT/gpu-check/logs" && echo earlier >"$OUT/gpu_check.tar.xz" && echo log >"$OUT/gpu-check/logs/ctest.log"; }
earlier_run_kept() { [[ "$(cat "$OUT/gpu_check.tar.xz" 2>/dev/null)" == earlier && -f "$OUT/gpu-check/logs/ctest.log" ]]; }
refused() { # EXPECTED_MESSAGE ARGS...: gpu_check.sh ARGS exits 2 with the message, the earlier run kept
  local expected="$1" status && shift && earlier_run
  "$tree/scripts/gpu_check.sh" "$@" 2>"$tree/stderr"
  status=$?
  ((status == 2)) || failed "gpu_check.sh $* exited $status, not 2: $(cat "$tree/stderr")"
  grep -qF -- "$expected" "$tree/stderr" || failed "gpu_check.sh $*: no '$expected' in: $(cat "$tree/stderr")"
  earlier_run_kept || failed "gpu_check.sh $* removed the earlier run's archive or logs"
}

case "${1:-}" in
  refuses-an-unknown-step)
    refused "--only bogus: no such step" --dry-run --only gpu-tests,bogus
    refused "--only bogus: no such step" --only bogus
    refused "--only ctest: no such step (the study's" --study --dry-run --only ctest
    refused "--only needs STEP" --only
    refused "--only needs STEP" --dry-run --only ,
    refused "--only frames-bogus: no such step" --dry-run --only frames-bogus
    refused "unknown option '--bogus'" --bogus
    ;;
  refuses-what-cannot-run)
    refused "build-emulation/overlap is missing or fails" --dry-run
    mkdir -p "$tree/build-emulation" && printf '#!/bin/sh\nexit 1\n' >"$tree/build-emulation/overlap"
    chmod +x "$tree/build-emulation/overlap"
    refused "build-emulation/overlap is missing or fails" --dry-run
    refused ".gpu-carry/overlap-gpu.tar.xz is missing" --study
    ;;
  a-signal-ends-every-step)
    # The fake overlap lists one GPU finder, and in the info step (--version) it and a
    # child of its own write into $OUT until they are ended.
    mkdir -p "$tree/build-emulation" "$tree/pids" && export PIDS="$tree/pids"
    cat >"$tree/build-emulation/overlap" <<'FAKE'
#!/bin/bash
if [[ "$*" == "--list-algos --json" ]]; then
  echo '{"broadphases": [{"name": "gpubf", "needs_device": true}]}' && exit 0
fi
[[ "$1" == --version ]] || exit 0
(while :; do echo child >>"$OUT/written_by_a_step"; sleep 0.1; done) &
echo $! >"$PIDS/child" && echo $$ >"$PIDS/overlap"
while :; do echo overlap >>"$OUT/written_by_a_step"; sleep 0.1; done
FAKE
    chmod +x "$tree/build-emulation/overlap"
    "$tree/scripts/gpu_check.sh" --dry-run >"$tree/stdout" 2>&1 &
    driver=$!
    for _ in {1..600}; do [[ -s "$PIDS/child" && -s "$PIDS/overlap" ]] && break; sleep 0.1; done
    [[ -s "$PIDS/child" && -s "$PIDS/overlap" ]] || failed "the info step never started: $(cat "$tree/stdout")"
    kill -TERM "$driver"
    wait "$driver"
    status=$?
    ((status == 143)) || failed "gpu_check.sh exited $status after SIGTERM, not 143: $(cat "$tree/stdout")"
    for pid in $(cat "$PIDS/child" "$PIDS/overlap"); do
      ! kill -0 "$pid" 2>/dev/null || failed "process $pid of the info step still runs after gpu_check.sh ended"
    done
    size="$(stat -c %s "$OUT/written_by_a_step")" && sleep 0.5
    [[ "$(stat -c %s "$OUT/written_by_a_step")" == "$size" ]] || failed "something still writes into \$OUT"
    grep -q "^info  *INTERRUPTED .*stopped by SIGTERM" "$OUT/gpu_check_summary.txt" ||
      failed "the step table does not say the info step was stopped: $(cat "$OUT/gpu_check_summary.txt")"
    ;;
  *) echo "gpu_check_test: the case is one of refuses-an-unknown-step, refuses-what-cannot-run, a-signal-ends-every-step" >&2 && exit 2 ;;
esac
echo "gpu_check_test: $1: passed"
