#!/usr/bin/env bash
# Usage: scripts/peers/build_broadmark.sh SRC_DIR BUILD_DIR
#
# Builds Broadmark's CPU broadphases (Serpa & Rodrigues, CGF 2020) and our
# broadmark_driver into BUILD_DIR, from SRC_DIR, a checkout you make first:
#   git clone https://github.com/ppgia-unifor/Broadmark SRC_DIR
# Both folders stay outside this repository; nothing of Broadmark is copied
# into it.  Needs clang++ (Broadmark's __declspec(align) wants -fdeclspec),
# libomp-dev (Broadmark's OpenMP), oneTBB (libstdc++'s std::execution) and
# CLI11.  How the MSVC code is met: scripts/peers/CMakeLists.txt.  Then:
#   BUILD_DIR/broadmark_driver --list
#   BUILD_DIR/broadmark_driver --algo SAP_AVX_Parallel --input s.aabbs --out r
set -euo pipefail
program=scripts/peers/build_broadmark.sh
if (($# != 2)); then
  echo "usage: $program SRC_DIR BUILD_DIR (SRC_DIR: a clone of https://github.com/ppgia-unifor/Broadmark)" >&2
  exit 2
fi
here=$(cd "$(dirname "$0")" && pwd)
repository=$(cd "$here/../.." && pwd)
source_dir=$1
build_dir=$(realpath -m "$2")
if [[ ! -f "$source_dir/Broadmark/Algorithms/Broadphase/BroadphaseInterface.h" ]]; then
  echo "$program: SRC_DIR $source_dir: no Broadmark checkout there; clone it first:" >&2
  echo "  git clone https://github.com/ppgia-unifor/Broadmark $source_dir" >&2
  exit 2
fi
source_dir=$(realpath "$source_dir")
for dir in "$source_dir" "$build_dir"; do
  if [[ "$dir/" == "$repository/"* ]]; then
    echo "$program: $dir is inside this repository; Broadmark and its build stay outside it" >&2
    exit 2
  fi
done
if ! command -v clang++ >/dev/null; then
  echo "$program: clang++ not found (apt-get install clang libomp-dev)" >&2
  exit 2
fi
cmake -S "$here" -B "$build_dir" -DBROADMARK_SRC="$source_dir" -DCMAKE_CXX_COMPILER=clang++ \
  -DCMAKE_BUILD_TYPE=Release
cmake --build "$build_dir" -j "$(nproc)"
echo "$program: built $build_dir/broadmark_driver (Broadmark $(git -C "$source_dir" rev-parse --short HEAD 2>/dev/null || echo '?'))"
