#!/usr/bin/env bash
# Installs the Debian packages Overlap needs (idempotent: apt-get update runs
# once, and only when something is missing), then configures build/ with the
# preset CI builds (CMakePresets.json's release: Release, Ninja, unity batches
# of 16 sources, ccache) and builds
#   scripts/setup.sh          the demo: the overlap program and what it links
#   scripts/setup.sh --all    everything: the tests and the benchmark too
# ccache makes a rebuild, or a build in another clone with the same
# CCACHE_BASEDIR, compile only what changed.  The CUDA kernels: for this
# machine's GPU (CUDAARCHS=native) where nvidia-smi sees one, else for sm_90
# alone, as CI (no kernel runs here; the H100 and H200 are sm_90); CUDAARCHS
# chooses others (CMakeLists.txt's default is a fat binary of five).
set -euo pipefail

readonly PACKAGES=(
  build-essential cmake pkg-config git
  libbullet-dev libeigen3-dev libosmesa6-dev libtbb-dev
  googletest libgtest-dev libgmock-dev libcli11-dev
  nlohmann-json3-dev libpng-dev python3-matplotlib
  libboost-context-dev  # fibers for the CUDA emulation build (gpu/emulation/)
  ccache ninja-build  # the release preset builds with Ninja, through ccache
)

case "${1:-}" in
  "") target=overlap what="the demo: overlap and the libraries it links, 16 of the build's 32 compiles (the CUDA ones among them), about 3 minutes cold on 2 cores (docs/results/readme_first_command.csv)" ;;
  --all) target=all what="everything: the demo, every test and the benchmark, 32 compiles (docs/results/ci_stages.csv)" ;;
  *) echo "setup: unknown argument '$1' (none: the demo; --all: everything)" >&2 && exit 2 ;;
esac

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
if [[ -f build/CMakeCache.txt ]] && ! grep -q '^CMAKE_GENERATOR:INTERNAL=Ninja$' build/CMakeCache.txt; then
  echo "setup: build/ was configured with another generator than the preset's Ninja: remove it (rm -rf build) and run again" >&2
  exit 2
fi
if [[ -z "${CUDAARCHS:-}" ]]; then
  if nvidia-smi -L >/dev/null 2>&1; then export CUDAARCHS=native; else export CUDAARCHS=90; fi
fi
echo "setup: building $what into build/ (CUDA kernels for $CUDAARCHS)" >&2
cmake --preset release >/dev/null
cmake --build build -j "$(nproc)" --target "$target"
