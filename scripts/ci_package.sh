#!/usr/bin/env bash
# The package as a Bullet program meets it (docs/PACKAGE.md): installs the
# Release build into a temporary prefix, configures tests/package_consumer/
# against that prefix alone, builds it and runs it (cpusap's pairs against
# bf's on every step).  Usage: scripts/ci_package.sh [BUILD_DIR] (default build)
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir="${1:-build}"
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT

cmake --install "$build_dir" --prefix "$scratch/prefix" >"$scratch/install.log"
echo "ci_package: installed $(grep -c Installing "$scratch/install.log") files into a temporary prefix"
launcher=()
if command -v ccache >/dev/null; then launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi
cmake -S tests/package_consumer -B "$scratch/consumer" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$scratch/prefix" "${launcher[@]}" >"$scratch/configure.log" ||
  { cat "$scratch/configure.log" >&2; exit 1; }
cmake --build "$scratch/consumer" -j "$(nproc)"
"$scratch/consumer/package_consumer"
