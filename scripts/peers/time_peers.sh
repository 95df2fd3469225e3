#!/usr/bin/env bash
# Usage: scripts/peers/time_peers.sh DRIVER OUT_DIR STREAM.aabbs...   (from the repository's top)
#
# Times Broadmark's fastest CPU broadphases (broadmark_driver, built by
# scripts/peers/build_broadmark.sh) and our cpusap (build/overlap_bench_broadphase)
# on the same streams in one job: per stream, cpusap, then each peer, then
# cpusap again, so a change in the machine's load shows up between the two
# cpusap runs.  Each writes OUT_DIR/n<N>_<algorithm>.csv/.json; then
# scripts/peers/peers_table.py OUT_DIR makes the table.  Environment:
# PEERS (Broadmark names, DBVT_D for "DBVT D"), WARMUP (2), REPEATS (3), THREADS (2).
set -euo pipefail
program=scripts/peers/time_peers.sh
if (($# < 3)); then
  echo "usage: $program DRIVER OUT_DIR STREAM.aabbs..." >&2
  exit 2
fi
driver=$1 out=$2
shift 2
peers=${PEERS:-SAP_AVX_Parallel SAP_SSE_Parallel SAP_AVX SAP_SSE Grid_2D_SAP_Parallel Grid_3D_SAP_Parallel KD DBVT_D Tracy_Parallel}
warmup=${WARMUP:-2} repeats=${REPEATS:-3} threads=${THREADS:-2}
[[ -x "$driver" ]] || { echo "$program: DRIVER $driver: not an executable" >&2; exit 2; }
[[ -x build/overlap_bench_broadphase ]] || { echo "$program: run from the repository's top after building" >&2; exit 2; }
for stream in "$@"; do
  [[ -f "$stream" ]] || { echo "$program: $stream: no such stream" >&2; exit 2; }
done
mkdir -p "$out"
echo "$program: load average $(cut -d' ' -f1-3 /proc/loadavg) at start" >&2

cpusap() {  # STREAM N RUN
  build/overlap_bench_broadphase --input "$1" --algos cpusap --warmup "$warmup" --repeats "$repeats" \
    --out "$out/n$2_cpusap_$3"
}
for stream in "$@"; do
  n=$(od -An -t d4 -j 256 -N 4 "$stream" | tr -d ' ')
  cpusap "$stream" "$n" a
  for peer in $peers; do
    start=$SECONDS
    "$driver" --algo "$peer" --input "$stream" --warmup "$warmup" --repeats "$repeats" \
      --threads "$threads" --out "$out/n${n}_$peer" >/dev/null  # KD prints to stdout
    echo "$program: n=$n $peer took $((SECONDS - start)) s" >&2
  done
  cpusap "$stream" "$n" b
  echo "$program: load average $(cut -d' ' -f1-3 /proc/loadavg) after n=$n" >&2
done
