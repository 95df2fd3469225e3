#!/usr/bin/env bash
# Packs, on the development machine, what scripts/gpu_check.sh needs on a GPU
# machine that has no Bullet, oneTBB, OSMesa or network (docs/GPU_LOAN.md):
#   scripts/gpu_pack.sh [--no-build] [BUILD_DIR]      (default: build, the nvcc Release build)
# writes .gpu-carry/overlap-gpu.tar.xz (git ignores .gpu-carry/; the device
# tool's call names it in `carry`).  On the GPU machine, gpu_check.sh's first step
#   scripts/gpu_pack.sh --unpack
# unpacks it into the tree: the packed checkout's path made to lead here, the
# tracked files compared with the pack's sums (a changed source stops it), and
# the CTest files' cmake and python3 pointed at this machine's where the packed
# ones are absent.  Rules, each with its reason:
# - It holds BUILD_DIR's binaries (every ELF executable and shared object),
#   its CTest files (CTestTestfile.cmake, GoogleTest's discovered lists),
#   CMakeCache.txt and the headers CMake wrote for the tests, and in
#   BUILD_DIR/gpu-pack/lib every shared library they load (ldd) except the C
#   and C++ runtimes, the loader and libcuda: those belong to the GPU machine,
#   the rest is absent there (OSMesa's LLVM included).
# - Each executable X travels as X.real beside a wrapper X that sets
#   LD_LIBRARY_PATH to gpu-pack/lib and execs X.real under X's name: only the
#   project's binaries (and what they start) load the carried libraries, never
#   the machine's own python3, cmake or compute-sanitizer.
# - The sources do not travel in it: a GPU loan copies the working tree there.
#   gpu-pack/sums holds the SHA-256 of every file git tracks here, so the
#   check can tell the tree it runs in from the one this build came from.
# - Paths stay absolute (CTest files, the test binaries' compiled-in source
#   paths): gpu-pack/manifest names this checkout's root, and the check makes
#   that path lead to its own root on the GPU machine.
# - What travels (the pack plus the working tree) must stay under the 64 MiB
#   a GPU loan carries: the size of each is printed, and the script fails over it.
# - The pack is checked before it is kept: unpacked into a scratch folder,
#   every wrapper runs and every library each binary loads resolves to the
#   pack or to the runtimes left out.
# The build is brought up to date first (cmake --build, niced; --no-build skips).
set -euo pipefail

cd "$(dirname "$0")/.."
readonly ROOT="$PWD"
readonly CARRY=".gpu-carry"
readonly PACK="$CARRY/overlap-gpu.tar.xz"
readonly TRAVEL_LIMIT=$((64 * 1024 * 1024))
# The C and C++ runtimes, the loader and the CUDA driver: the GPU machine's own.
readonly RUNTIME_LIBS='^(libc|libm|libmvec|libpthread|libdl|librt|libresolv|libutil|libstdc\+\+|libgcc_s|ld-linux-x86-64|libcuda)\.so'

fail() {
  echo "gpu_pack: $*" >&2
  exit 1
}

# The pack into this tree, on the GPU machine (the header above).
unpack() {
  local pack="$PACK" manifest source_dir changed packed_cmake packed_python here_cmake python fixed=""
  [[ -f "$pack" ]] || fail "$pack is missing: run scripts/gpu_pack.sh on the development machine and carry $CARRY"
  tar -xJf "$pack" || fail "$pack did not unpack"
  manifest="$(tar -tJf "$pack" | grep 'gpu-pack/manifest$')" || fail "$pack holds no gpu-pack/manifest"
  source_dir="$(sed -n 's/^source_dir=//p' "$manifest")"
  if [[ "$source_dir" != "$ROOT" ]]; then
    if [[ -e "$source_dir" || -L "$source_dir" ]]; then
      [[ "$(realpath "$source_dir")" == "$(realpath "$ROOT")" ]] ||
        fail "$source_dir (the packed build's checkout) exists here and is not this tree"
    else
      mkdir -p "$(dirname "$source_dir")" && ln -s "$ROOT" "$source_dir" || fail "cannot make $source_dir lead to $ROOT"
    fi
    echo "gpu_pack: $source_dir -> $ROOT (the CTest files and the tests name it)"
  fi
  changed="$(sha256sum --quiet -c "$(dirname "$manifest")/sums" 2>/dev/null | sed 's/: .*//' || true)"
  echo "gpu_pack: files changed since the pack: ${changed:-none}"
  if grep -Eq '\.(cpp|h|cu|cuh|cmake)$|CMakeLists\.txt$|CMakePresets\.json$|^tests/' <<<"$changed"; then
    fail "sources changed since the pack (above): run scripts/gpu_pack.sh again"
  fi
  # The tests' launcher and the layering checks call the configuring machine's cmake,
  # study.* its python3 (here one with matplotlib, where there is one).
  packed_cmake="$(sed -n 's/^cmake=//p' "$manifest")" packed_python="$(sed -n 's/^study_python=//p' "$manifest")"
  here_cmake="$(command -v cmake || true)"
  for python in python3 /usr/bin/python3; do
    "$python" -c 'import matplotlib, numpy' 2>/dev/null && python="$(command -v "$python")" && break
    python=""
  done
  local -a ctest_files
  mapfile -t ctest_files < <(find "$(dirname "$(dirname "$manifest")")" \( -name CTestTestfile.cmake -o -name '*_tests.cmake' \))
  if [[ -n "$packed_cmake" && ! -x "$packed_cmake" && -n "$here_cmake" ]]; then
    sed -i "s|$packed_cmake\([]\"]\)|$here_cmake\1|g" "${ctest_files[@]}" && fixed+=" cmake: $here_cmake;"
  fi
  if [[ -n "$packed_python" && -n "$python" && "$packed_python" != "$python" ]]; then
    sed -i "s|$packed_python\([]\"]\)|$python\1|g" "${ctest_files[@]}" && fixed+=" python3: $python (matplotlib);"
  fi
  echo "gpu_pack: $(sed -n 's/^commit=/commit /p' "$manifest");${fixed:- CTest files as packed}"
}
if [[ "${1:-}" == "--unpack" ]]; then
  unpack
  exit
fi

build=1
if [[ "${1:-}" == "--no-build" ]]; then
  build=0
  shift
fi
build_dir="${1:-build}"
build_dir="${build_dir%/}"
[[ "$build_dir" != /* && "$build_dir" != *..* ]] ||
  fail "BUILD_DIR must be a folder inside the repository, e.g. build (got $build_dir)"
[[ -f "$build_dir/CMakeCache.txt" ]] ||
  fail "$build_dir is not a configured build (cmake -S . -B $build_dir -DCMAKE_BUILD_TYPE=Release)"

cache_value() { sed -n "s/^$1:[A-Z]*=//p" "$build_dir/CMakeCache.txt" | head -1; }

if ((build)); then
  echo "gpu_pack: bringing $build_dir up to date" >&2
  nice cmake --build "$build_dir" -j 2 >/dev/null || fail "cmake --build $build_dir failed"
fi
if [[ "$(cache_value OVERLAP_CUDA_EMULATION)" == ON ]]; then
  echo "gpu_pack: $build_dir is a CUDA emulation build: a rehearsal of the pack, no GPU code in it" >&2
fi

is_elf() { [[ "$(head -c 4 "$1" 2>/dev/null | od -An -c | tr -d ' ')" == '177ELF' ]]; }

# The build's files that travel, relative to the repository root.
build_files() {
  find "$build_dir" \( -name CMakeFiles -o -name _deps -o -path "$build_dir/gpu-pack" -o -name Testing \) -prune \
    -o -type f \( -name '*.o' -o -name '*.a' -o -name '*.d' \) -prune \
    -o -type f -print |
    while read -r file; do
      case "$file" in
        */CTestTestfile.cmake | *_include.cmake | *_tests.cmake | "$build_dir/CMakeCache.txt") echo "$file" ;;
        "$build_dir"/tests/*.h) echo "$file" ;;
        *) if is_elf "$file"; then echo "$file"; fi ;;
      esac
    done
}

stage="$CARRY/stage"
rm -rf "$stage" "$CARRY/check"
mkdir -p "$stage"
mapfile -t files < <(build_files | sort)
((${#files[@]} > 0)) || fail "nothing to pack in $build_dir"
cp -l --parents "${files[@]}" "$stage/" 2>/dev/null || cp --parents "${files[@]}" "$stage/"

pack_dir="$stage/$build_dir/gpu-pack"
mkdir -p "$pack_dir/lib"
executables=()
for file in "${files[@]}"; do
  [[ -x "$file" && "$file" != *.so && "$file" != *.so.* ]] && is_elf "$file" && executables+=("$file")
done
((${#executables[@]} > 0)) || fail "no executable in $build_dir"

# Every library the binaries load, by the name the loader looks for.
mapfile -t needed < <(ldd "${executables[@]}" 2>/dev/null | awk '$2 == "=>" && $3 ~ /^\// { print $1 " " $3 }' |
  grep -Ev "$RUNTIME_LIBS" | sort -u)
if ldd "${executables[@]}" 2>/dev/null | grep -q "not found"; then
  ldd "${executables[@]}" | grep "not found" | sort -u >&2
  fail "a library the binaries load is missing here"
fi
for entry in "${needed[@]}"; do
  cp -L "${entry#* }" "$pack_dir/lib/${entry%% *}"
done

# Each executable X becomes X.real and a wrapper X (see the rules above).
for file in "${executables[@]}"; do
  staged="$stage/$file"
  mv "$staged" "$staged.real"
  lib_path="$(realpath -m --relative-to="$(dirname "$file")" "$build_dir/gpu-pack/lib")"
  cat >"$staged" <<WRAPPER
#!/bin/bash
# scripts/gpu_pack.sh's wrapper: $(basename "$file").real with the carried libraries.
here="\$(cd "\$(dirname "\${BASH_SOURCE[0]}")" && pwd)"
export LD_LIBRARY_PATH="\$here/$lib_path\${LD_LIBRARY_PATH:+:\$LD_LIBRARY_PATH}"
exec -a "\$0" "\$here/$(basename "$file").real" "\$@"
WRAPPER
  chmod +x "$staged"
done

git ls-files -z | xargs -0 sha256sum >"$pack_dir/sums"
{
  echo "source_dir=$ROOT"
  echo "build_dir=$build_dir"
  echo "commit=$(git rev-parse --short=12 HEAD)$(git diff --quiet HEAD -- 2>/dev/null || echo -dirty)"
  echo "packed=$(date -u +%Y-%m-%dT%H:%M:%SZ) on $(hostname)"
  echo "build_type=$(cache_value CMAKE_BUILD_TYPE)"
  echo "cuda_emulation=$(cache_value OVERLAP_CUDA_EMULATION)"
  echo "nvcc=$("$(command -v nvcc || echo /usr/local/cuda/bin/nvcc)" --version 2>/dev/null | sed -n "s/.*release //p")"
  echo "cmake=$(cache_value CMAKE_COMMAND)"
  echo "study_python=$(cache_value OVERLAP_STUDY_PYTHON)"
  echo "libraries=$(ls "$pack_dir/lib" | tr '\n' ' ')"
} >"$pack_dir/manifest"

unpacked_bytes="$(du -sbL "$stage" | cut -f1)"
echo "gpu_pack: ${#files[@]} build files, ${#needed[@]} libraries, $((unpacked_bytes / 1048576)) MiB unpacked; compressing (xz -6)" >&2
tar -C "$stage" -cf - . | nice xz -6 -T2 >"$PACK.partial"
mv "$PACK.partial" "$PACK"

# The check: unpacked elsewhere, each binary's libraries resolve to the pack or the runtimes.
check="$CARRY/check"
mkdir -p "$check"
tar -C "$check" -xJf "$PACK"
for file in "${executables[@]}"; do
  outside="$(LD_LIBRARY_PATH="$ROOT/$check/$build_dir/gpu-pack/lib" ldd "$ROOT/$check/$file.real" |
    awk -v root="$ROOT/" '$2 == "=>" && index($3, root) != 1 { print $1 " => " $3 }' |
    grep -Ev "$RUNTIME_LIBS" || true)"
  [[ -z "$outside" ]] || fail "$file loads from outside the pack: $outside"
done
"$check/$build_dir/overlap" --version >/dev/null || fail "the packed overlap does not run"
rm -rf "$stage" "$check"

pack_bytes="$(stat -c %s "$PACK")"
tree_bytes="$(git ls-files -co --exclude-standard -z | du -cb --files0-from=- 2>/dev/null | tail -1 | cut -f1)"
total=$((pack_bytes + tree_bytes))
mib() { awk -v b="$1" 'BEGIN { printf "%.1f", b / 1048576 }'; }
echo "gpu_pack: $PACK: $(mib "$pack_bytes") MiB ($pack_bytes bytes); the working tree:" \
  "$(mib "$tree_bytes") MiB; together $(mib "$total") of the 64 MiB a GPU loan carries"
((total <= TRAVEL_LIMIT)) || fail "what travels is over the 64 MiB a GPU loan carries: carry less"
