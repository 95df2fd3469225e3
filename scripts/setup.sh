#!/usr/bin/env bash
# Installs the Debian packages Overlap needs (idempotent: apt-get update runs
# once, and only when something is missing), then configures and builds the
# project with CMake in Release, through ccache (a rebuild, or a build in
# another clone with the same CCACHE_BASEDIR, compiles only what changed).
# The CUDA architectures: CMakeLists.txt's five, or CMake's CUDAARCHS.
# Usage: scripts/setup.sh [BUILD_DIR [CMAKE_ARGS...]] (the arguments go to
# the configure step: .ci/run asks for a unity build)
set -euo pipefail

readonly PACKAGES=(
  build-essential cmake pkg-config git
  libbullet-dev libeigen3-dev libosmesa6-dev libtbb-dev
  googletest libgtest-dev libgmock-dev libcli11-dev
  nlohmann-json3-dev libpng-dev python3-matplotlib
  libboost-context-dev  # fibers for the CUDA emulation build (gpu/emulation/)
  ccache ninja-build  # .ci/run builds with Ninja
)

missing=()
for pkg in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$pkg")
  fi
done

if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}" >&2
  SUDO=""
  if [[ $(id -u) -ne 0 ]]; then SUDO="sudo"; fi
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

cd "$(dirname "$0")/.."
build_dir="${1:-build}"
cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_CUDA_COMPILER_LAUNCHER=ccache "${@:2}"
cmake --build "$build_dir" -j "$(nproc)"
