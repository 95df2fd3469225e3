#!/usr/bin/env bash
# What the GPU finders cost, read from their machine code and counted by the
# CUDA emulation; no GPU is needed and no time is measured.
#   scripts/gpu_kernel_cost.sh [--rev REV] [EMULATION_BUILD_DIR]
#
# 1. Compiles gpu/cuda/gpu_brute_force.cu, gpu/cuda/paper_brute_force.cu and
#    gpu/cuda/gpu_sweep_and_prune.cu (of the work tree, or of git revision REV,
#    under the names that revision gave them; a revision without gpusap
#    skips it) for sm_90 with this machine's nvcc at
#    -O3, and disassembles them (cuobjdump -sass).  CUB's own kernels (gpusap's
#    sorts, scan and selections) are listed by name only: they are the
#    library's, tuned per architecture, and cost a few passes over the data.
# 2. Per kernel, walks its inner loop (the innermost loop around the ballot;
#    without one, around the loads; without a loop, the whole thread) along
#    the common path: a conditional branch that skips a block holding an
#    atomic (a change to append) or a CALL (the 64-bit division or the slow
#    square root, for values these kernels see only past 65536 slots or never)
#    and no load or ballot is taken; other conditional branches are not, so
#    an inner loop counts once and a divergence fallback never.  Prints the instructions on that
#    path per 32 pairs and the bytes its global loads request per pair: a
#    load's full width per lane, or 1/32 of it where its address is the same
#    in every lane (its registers, followed back along the path and into the
#    loop, never depend on SR_TID / SR_LANEID other than through tid / 32).
#    These are static counts of one path, not a profile.  gpusap's
#    sweepKernel ballots once per 32 candidates (a candidate is a pair it
#    tests), so its figures are per 32 candidates; its other kernels have no
#    ballot and are given per pass of their innermost loop (a grid-stride
#    pass is one box; packKernel's one pair of the head).
# 3. Per frame, the API calls, copies and bytes over the bus of one steady
#    frame of each finder, from the emulation build's counters
#    (overlap_gpu_frame_cost in EMULATION_BUILD_DIR, default build-emulation;
#    skipped with a note when it is not built).
# The last line is gpubf's instructions per 32 pairs.
#
# Needs nvcc (CUDA 12+) and cuobjdump.  Without a toolkit's cuobjdump:
#   pip install nvidia-cuda-cuobjdump nvidia-cuda-nvdisasm
set -euo pipefail

cd "$(dirname "$0")/.."
rev=""
if [[ "${1:-}" == "--rev" ]]; then
  rev="${2:?gpu_kernel_cost: --rev needs a git revision}"
  shift 2
fi
emulation_dir="${1:-build-emulation}"

fail() {
  echo "gpu_kernel_cost: $*" >&2
  exit 2
}

find_tool() {
  local name="$1" candidate
  for candidate in "$(command -v "$name" || true)" "/usr/local/cuda/bin/$name" \
    "$(python3 -c 'import nvidia, os; print(os.path.join(nvidia.__path__[0], "cu13", "bin"))' \
      2>/dev/null)/$name" \
    "$(python3 -c 'import nvidia, os; print(os.path.join(nvidia.__path__[0], "cuda_cuobjdump", "bin"))' \
      2>/dev/null)/$name"; do
    [[ -n "$candidate" && -x "$candidate" ]] && {
      echo "$candidate"
      return
    }
  done
  return 1
}

nvcc="$(find_tool nvcc)" || fail "nvcc not found (the CUDA toolkit's bin/ on PATH, or /usr/local/cuda)"
cuobjdump="$(find_tool cuobjdump)" ||
  fail "cuobjdump not found; install it with: pip install nvidia-cuda-cuobjdump nvidia-cuda-nvdisasm"

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
source_root="."
if [[ -n "$rev" ]]; then
  git rev-parse --verify --quiet "$rev^{commit}" >/dev/null || fail "--rev '$rev' is not a commit"
  mkdir "$work/tree"
  git archive "$rev" gpu | tar -x -C "$work/tree"
  source_root="$work/tree"
fi

echo "# gpu_kernel_cost: commit $(git rev-parse --short "${rev:-HEAD}")$([[ -z "$rev" && -n "$(git status --porcelain gpu)" ]] && echo ' + uncommitted gpu/ changes'), nvcc $("$nvcc" --version | sed -n 's/.*release \([0-9.]*\), V\([0-9.]*\).*/\2/p'), sm_90, -O3"
# The CUDA finders' folder: gpu/cuda/, or gpu/ in revisions before it.
cuda_dir=gpu/cuda
[[ -d "$source_root/$cuda_dir" ]] || cuda_dir=gpu
if [[ -f "$source_root/$cuda_dir/gpu_brute_force.cu" ]]; then
  sources=(gpu_brute_force paper_brute_force gpu_sweep_and_prune)
else  # the names before the finders were named after their algorithms
  sources=(gpu_pair_finder gpu_pair_finder_paper)
  [[ -f "$source_root/$cuda_dir/gpu_sap_pair_finder.cu" ]] && sources+=(gpu_sap_pair_finder)
fi
for source in "${sources[@]}"; do
  "$nvcc" -std=c++20 -O3 -arch=sm_90 -cubin -I"$source_root" \
    "$source_root/$cuda_dir/$source.cu" -o "$work/$source.cubin" ||
    fail "nvcc could not compile $cuda_dir/$source.cu"
  "$cuobjdump" -sass "$work/$source.cubin" >"$work/$source.sass"
done

sass_files=()
for source in "${sources[@]}"; do sass_files+=("$work/$source.sass"); done
kernels="$(python3 - "${sass_files[@]}" <<'PYTHON'
import os
import re
import sys

INSTRUCTION = re.compile(r"/\*([0-9a-f]{4,})\*/\s+(.*?)\s*;")
FUNCTION = re.compile(r"Function : (\S+)")
BRANCH = re.compile(r"^(@!?U?P\w+\s+)?BRA(\.\w+)*\s+(?:`?\(?)(0x[0-9a-f]+)")
LOAD = re.compile(r"^(?:@!?P\w+\s+)?(LDG|LD)(\.[\w.]+)?\s+(R\d+|RZ),\s*(?:desc\[\w+\])?\[(R\d+)")
REGISTER = re.compile(r"\b(U?R\d+|U?P\d+)\b")


def functions(path):
    result = {}
    name = None
    for line in open(path):
        match = FUNCTION.search(line)
        if match:
            name = match.group(1)
            result[name] = []
            continue
        match = INSTRUCTION.search(line)
        if match and name:
            result[name].append((int(match.group(1), 16), match.group(2)))
    return result


def opcode(text):
    return re.sub(r"^@!?U?P\w+\s+", "", text).split()[0]


def split(text):
    """(predicate or None, opcode, operand list) of one instruction."""
    predicate = re.match(r"^@(!?)(U?P\w+)\s+", text)
    body = text[predicate.end():] if predicate else text
    op, _, rest = body.partition(" ")
    operands = [o.strip() for o in rest.split(",")] if rest.strip() else []
    return (predicate.group(2) if predicate else None), op, operands


def registers(operand, op=""):
    """The registers an operand names (a .64 address names two)."""
    names = []
    for name in REGISTER.findall(operand):
        names.append(name)
        if name.startswith("R") and ".64" in operand:
            names.append(f"R{int(name[1:]) + 1}")
    return names


def destinations(op, operands):
    if not operands or op.startswith(("ST", "BRA", "EXIT", "BSSY", "BSYNC", "RED", "CALL", "RET")):
        return []
    first = registers(operands[0])
    if first and first[0].startswith("R"):
        count = 4 if ".128" in op else 2 if (".64" in op or ".WIDE" in op) else 1
        first = [f"R{int(first[0][1:]) + k}" for k in range(count)]
    result = list(first)
    # a carry-out or second predicate: "IADD3 R7, P0, ...", "ISETP P0, PT, ..."
    if len(operands) > 1 and re.fullmatch(r"!?U?P\d+", operands[1]) and not op.startswith("SEL"):
        result.append(operands[1].lstrip("!"))
    return result


class Uniformity:
    """Whether a register at a point of the hot path may differ between the
    lanes of a warp: optimistic (a value that depends only on itself around
    the loop is uniform), seeded by the thread index; tid / 32 (a right shift
    by 5 or more) is the warp's index and uniform."""

    def __init__(self, code, path, entry):
        self.code, self.path, self.entry = code, path, entry
        self.memo = {}

    def instruction_varies(self, i, busy):
        predicate, op, operands = split(self.code[i][1])
        text = self.code[i][1]
        if "SR_TID" in text or "SR_LANEID" in text:
            return "tid"
        if op.startswith("VOTE") or (op.startswith("SHFL.IDX") and "RZ" in operands[2:3]):
            return False
        outputs = set(destinations(op, operands))
        sources = [r for o in operands for r in registers(o) if r not in outputs or o is not operands[0]]
        sources = [r for r in sources if not r.startswith("U") and r not in ("RZ", "PT")]
        if predicate and not predicate.startswith("U"):
            sources.append(predicate)
        kinds = {self.varies(r, i, busy) for r in sources}
        if "tid" in kinds and op.startswith("SHF.R") and any(
                o.startswith("0x") and int(o, 16) >= 5 for o in operands):
            kinds.discard("tid")
            return bool(kinds - {False})
        if "tid" in kinds:
            return True
        return True in kinds

    def definitions_before(self, register, i):
        """Where `register` was last set before instruction i on the path,
        else around the loop and on the way into it."""
        position = self.path.index(i) if i in self.path else len(self.path)
        for j in reversed(self.path[:position]):
            if register in destinations(*split(self.code[j][1])[1:]):
                return [j]
        found = [j for j in self.path[position:]
                 if register in destinations(*split(self.code[j][1])[1:])]
        for j in reversed(self.entry):
            if register in destinations(*split(self.code[j][1])[1:]):
                return found + [j]
        return found

    def varies(self, register, i, busy=frozenset()):
        key = (register, i)
        if key in self.memo:
            return self.memo[key]
        if key in busy:
            return False
        busy = busy | {key}
        kinds = {self.instruction_varies(j, busy) for j in self.definitions_before(register, i)}
        result = "tid" if kinds == {"tid"} else (True if (True in kinds or "tid" in kinds) else False)
        self.memo[key] = result
        return result


def load_bytes(text):
    op = opcode(text)
    for width, size in ((".128", 16), (".64", 8), (".U8", 1), (".S8", 1), (".U16", 2)):
        if width in op:
            return size
    return 4


def walk(code, index, start, head, end, stop=None):
    """The instructions run from `start` within [head, end] on the path where
    no pair changes, up to `end` (or before `stop`)."""
    path = []
    i = start
    seen = set()
    while head <= i <= end and i != stop and i not in seen:
        seen.add(i)
        address, text = code[i]
        op = opcode(text)
        if op == "NOP":
            i += 1
            continue
        path.append(i)
        if i == end or text.split()[0] in ("EXIT", "RET.REL.NODEC", "RET"):
            break
        match = BRANCH.match(text)
        if match:
            target = index.get(int(match.group(3), 16))
            conditional = match.group(1) is not None
            if match.group(2) and ".DIV" in match.group(2):
                i += 1
                continue
            if target is None or not head <= target <= end:
                i += 1 if conditional else end + 1
                continue
            if not conditional:
                i = target if target > i else end + 1
                continue
            skipped = code[i + 1:target] if target > i else []
            rare = any(opcode(t).startswith(("ATOM", "RED", "CALL")) for _, t in skipped)
            main = any(LOAD.match(t) or opcode(t).startswith("VOTE") for _, t in skipped)
            if rare and not main:
                i = target
            else:
                i += 1
            continue
        i += 1
    return path


def hot_path(code):
    """The inner loop's instructions on the path where no pair changes."""
    index = {address: i for i, (address, _) in enumerate(code)}
    # The loop around the ballot; a kernel without one, the loop around its loads.
    votes = [i for i, (_, text) in enumerate(code) if opcode(text).startswith("VOTE")] or [
        i for i, (_, text) in enumerate(code) if LOAD.match(text)]
    # Code after the last unconditional EXIT is out of line (divergence
    # fallbacks that branch back): its branches are no loops.
    exits = [i for i, (_, text) in enumerate(code) if text.split()[0] == "EXIT"]
    last = exits[-1] if exits else len(code) - 1
    loops = []
    for i, (address, text) in enumerate(code[:last]):
        match = BRANCH.match(text)
        if match and int(match.group(3), 16) <= address and not match.group(2):
            head = index.get(int(match.group(3), 16))
            if head is not None:
                loops.append((head, i))
    around = [(head, end) for head, end in loops if any(head <= v <= end for v in votes)]
    if around:
        head, end = min(around, key=lambda loop: loop[1] - loop[0])
    else:
        head, end = 0, len(code) - 1  # no loop: one thread's whole run
    path = walk(code, index, head, head, end)
    # The way into the loop, for the values its registers hold on entry.
    entry = walk(code, index, 0, 0, len(code) - 1, stop=head) if head > 0 else []
    return path, head, entry


def report(name, code):
    path, head, entry = hot_path(code)
    uniformity = Uniformity(code, path, entry)
    words = sum(1 for i in path if opcode(code[i][1]).startswith("VOTE")) or None
    looped = path and path[0] > 0
    loads = []
    for i in path:
        text = code[i][1]
        match = LOAD.match(text)
        if match:
            per_lane = load_bytes(text)
            uniform = uniformity.varies(match.group(4), i) is False
            if os.environ.get("GPU_KERNEL_COST_DEBUG"):
                print(f"  load {'uniform' if uniform else 'per lane'}: {text}")
            loads.append(per_lane / 32 if uniform else per_lane)
    kernel = re.search(r"([a-z][A-Za-z]*Kernel)E", name)
    source = re.search(r"((?:gpu_pair_finder|gpu_brute_force|paper_brute_force)\w*?)_cu", name)
    short = (f"{source.group(1)}.cu {kernel.group(1)}" if kernel and source else name)
    if kernel and "sap_kernels" in name:
        short = f"gpu_sweep_and_prune_kernels.cuh {kernel.group(1)}"
        if words and kernel.group(1) == "sweepKernel":  # the others' VOTEs are shuffles' masks
            per32 = len(path) / words
            print(f"{short}: {per32:.1f} instructions per 32 candidates (warp), "
                  f"{sum(loads) / words:.2f} bytes loaded per candidate ({len(path)} instructions, "
                  f"{words} ballots per loop pass)")
        else:
            per32 = len(path)
            print(f"{short}: {per32} instructions per pass of its innermost loop (a lane), "
                  f"{sum(loads):.2f} bytes loaded per pass")
        return per32
    if words:
        # One ballot is one word of 32 pairs, each lane one pair.
        per32 = len(path) / words
        bytes_per_pair = sum(loads) / words
        print(f"{short}: {per32:.1f} instructions per 32 pairs (warp), "
              f"{bytes_per_pair:.2f} bytes loaded per pair ({len(path)} instructions, "
              f"{words} words per loop pass)")
    elif looped:
        # A loop without a ballot (collectChangesKernel): one word per pass.
        per32 = len(path)
        print(f"{short}: {per32:.1f} instructions per 32 pairs (warp, one word per pass), "
              f"{sum(loads) / 32:.2f} bytes loaded per pair")
    else:
        # One thread per pair (the paper's kernel): a warp's pass is 32 pairs.
        per32 = len(path)
        print(f"{short}: {per32:.1f} instructions per 32 pairs (one thread per pair), "
              f"{sum(loads):.2f} bytes loaded per pair")
    return per32


costs = {}
cub_kernels = set()
for path in sys.argv[1:]:
    for name, code in functions(path).items():
        if name.startswith("_ZN3cub"):
            found = re.search(r"([A-Z][A-Za-z]*Kernel)", name)
            cub_kernels.add(found.group(1) if found else name[:48])
            continue
        # The pair kernels only: the sort of gpubf change lists walks no pairs.
        if "Kernel" in name and "Probe" not in name and "sortHeads" not in name:
            costs[name] = report(name, code)
if cub_kernels:
    print("gpusap CUB kernels: " + ", ".join(sorted(cub_kernels)))
gpubf = [cost for name, cost in costs.items() if "findPairsKernel" in name]
print(f"gpubf instructions per 32 pairs: {gpubf[0]:.1f}" if gpubf else "gpubf: no findPairsKernel")
PYTHON
)"
echo "# per kernel: the inner loop on the path where no pair changes"
grep -v '^gpubf instructions per 32 pairs' <<<"$kernels"

echo "# per steady frame, counted by the CUDA emulation (requests, the same on a GPU)"
frame_cost="$emulation_dir/tests/gpu/overlap_gpu_frame_cost"
if [[ -n "$rev" ]]; then
  echo "(not counted for --rev: $emulation_dir is built from the work tree)"
elif [[ -x "$frame_cost" ]]; then
  "$frame_cost" 3500 || fail "$frame_cost failed"
else
  echo "(not built: cmake --preset cuda-emulation && cmake --build $emulation_dir --target overlap_gpu_frame_cost)"
fi
grep '^gpubf instructions per 32 pairs' <<<"$kernels"
