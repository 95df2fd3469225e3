#!/usr/bin/env bash
# Copies the shared libraries the GPU binaries need into BUILD_DIR/gpu-libs/,
# so they travel with the build folder to a machine that has a GPU but no
# Bullet, oneTBB or package registry (scripts/gpu_benchmark.sh runs there with
# LD_LIBRARY_PATH=BUILD_DIR/gpu-libs).  The C and C++ runtimes, the loader and
# the CUDA driver (libcuda, which belongs to the GPU machine) are left out.
# Usage: scripts/gpu_bundle.sh [BUILD_DIR]   (default: build)
set -euo pipefail

cd "$(dirname "$0")/.."
build_dir="${1:-build}"
binaries=("$build_dir/overlap_bench_broadphase" "$build_dir/tests/gpu/overlap_gpu_tests")
libs_dir="$build_dir/gpu-libs"

for binary in "${binaries[@]}"; do
  if [[ ! -x $binary ]]; then
    echo "gpu_bundle: $binary is missing; build it first:" >&2
    echo "  cmake --build $build_dir --target overlap_bench_broadphase overlap_gpu_tests" >&2
    exit 1
  fi
done

rm -rf "$libs_dir"
mkdir -p "$libs_dir"
# ldd lines look like "libfoo.so.1 => /path/libfoo.so.1 (0x...)".
ldd "${binaries[@]}" |
  awk '$2 == "=>" && $3 ~ /^\// { print $3 }' |
  grep -Ev '/(libc|libm|libpthread|libdl|librt|libresolv|libstdc\+\+|libgcc_s|ld-linux[^/]*|libcuda)\.so' |
  sort -u |
  while read -r library; do
    cp -L "$library" "$libs_dir/"
  done

if ldd "${binaries[@]}" | grep -q "not found"; then
  echo "gpu_bundle: a library the binaries need was not found here:" >&2
  ldd "${binaries[@]}" | grep "not found" >&2
  exit 1
fi
echo "gpu_bundle: $(du -sh "$libs_dir" | cut -f1) in $libs_dir:" >&2
find "$libs_dir" -type f -printf '  %f\n' | sort >&2
