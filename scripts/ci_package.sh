#!/usr/bin/env bash
# The package as a Bullet program meets it (docs/PACKAGE.md): installs the
# Release build into a temporary prefix, configures tests/package_consumer/
# against that prefix alone, builds it and runs it (cpusap's pairs against
# bf's on every step).  Then, from a CUDA build, the same consumer again as a
# CPU-only program on a machine without the CUDA toolkit: nvcc off PATH, the
# toolkit's folders ignored by every find_* (CMAKE_IGNORE_PATH), CUDA_PATH
# and the like unset; the consumer's configure fails if CMake can still see
# a toolkit or a CUDA compiler or the package gives it the CUDA finders, the
# program fails if it runs gpubf, and its binary must hold no CUDA runtime
# call while the first one does.  Every verdict is an exit status or a fact
# the consumer's configure wrote, never a log line matched.
# Usage: scripts/ci_package.sh [BUILD_DIR] (default build)
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir="${1:-build}"
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT

cmake --install "$build_dir" --prefix "$scratch/prefix" >"$scratch/install.log"
echo "ci_package: installed $(grep -c Installing "$scratch/install.log") files into a temporary prefix"
launcher=()
if command -v ccache >/dev/null; then launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi

# consumer FOLDER [CMAKE ARGUMENTS...]: configures, builds and runs it; its
# output in FOLDER.out.
consumer() {
  local folder=$1
  shift
  cmake -S tests/package_consumer -B "$folder" -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_PREFIX_PATH="$scratch/prefix" "${launcher[@]}" "$@" >"$folder.configure.log" ||
    { cat "$folder.configure.log" >&2; exit 1; }
  cmake --build "$folder" -j "$(nproc)" >"$folder.build.log" || { cat "$folder.build.log" >&2; exit 1; }
  "$folder/package_consumer" | tee "$folder.out"
}
# Whether the program calls into the CUDA runtime (CUDA's static runtime linked in).
calls_cuda() {
  nm -C "$1/package_consumer" >"$1.symbols"
  grep -q ' cudaGetDeviceCount$' "$1.symbols"
}

consumer "$scratch/consumer" -DOVERLAP_CONSUMER_FACTS="$scratch/consumer.with_cuda"
with_cuda=$(<"$scratch/consumer.with_cuda")  # no file: the script stops here
[[ "$with_cuda" == ON ]] || {
  echo "ci_package: the build has no CUDA finders; the CPU-only consumer is the one above"
  exit 0
}
calls_cuda "$scratch/consumer" ||
  { echo "ci_package: the CUDA consumer holds no CUDA runtime call: the check below proves nothing" >&2; exit 1; }

# The CUDA toolkit out of sight: on PATH, a folder holding nvcc (the
# toolkit's bin/, or a wrapper in /usr/local/bin) is replaced by links to
# its other programs; every such folder and every toolkit folder
# (/usr/local/cuda*) with its bin/ is ignored by find_program, find_library,
# find_file and find_path.
hidden_path="" ignored=() copies=0
IFS=: read -r -a path_folders <<<"$PATH"
for folder in "${path_folders[@]}"; do
  if [[ -x "$folder/nvcc" ]]; then
    ignored+=("$folder")
    copies=$((copies + 1))
    mkdir "$scratch/path$copies"
    for program in "$folder"/*; do
      if [[ "${program##*/}" != nvcc ]]; then ln -s "$program" "$scratch/path$copies/"; fi
    done
    folder="$scratch/path$copies"
  fi
  hidden_path="${hidden_path:+$hidden_path:}$folder"
done
# find_program also looks in the system prefixes' bin/, on PATH or not.
for folder in /usr/local/bin /usr/bin /bin; do
  if [[ -x "$folder/nvcc" ]]; then ignored+=("$folder"); fi
done
for root in /usr/local/cuda /usr/local/cuda-* /opt/cuda /usr/lib/cuda; do
  if [[ -e "$root" ]]; then
    ignored+=("$root" "$root/bin" "$(readlink -f "$root")" "$(readlink -f "$root")/bin")
  fi
done
ignore_list=$(IFS=';'; echo "${ignored[*]}")
env -u CUDA_PATH -u CUDA_HOME -u CUDAToolkit_ROOT -u CUDACXX -u CUDAARCHS PATH="$hidden_path" \
  bash -c "$(declare -f consumer); $(declare -p scratch launcher); consumer \"\$@\"" consumer \
  "$scratch/cpu_consumer" -DOVERLAP_CONSUMER_WITHOUT_CUDA=ON -DCMAKE_IGNORE_PATH="$ignore_list"
# The consumer's configure failed above had the package given it the CUDA finders,
# and the program had it run gpubf with them; its binary must not call CUDA either.
! calls_cuda "$scratch/cpu_consumer" ||
  { echo "ci_package: the CPU-only consumer still got the CUDA finders" >&2; exit 1; }
echo "ci_package: a CPU-only consumer with no CUDA toolkit in sight built and ran against the package"
