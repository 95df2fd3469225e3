#!/usr/bin/env python3
"""Rewrites a .cu file for the CUDA emulation build (OVERLAP_CUDA_EMULATION).

The only CUDA syntax that is not C++ is the launch, `kernel<<<config>>>(args)`.
Each becomes `::overlap::cuda_emulation::launchKernel(kernel, "kernel",
config)(args)` without adding or removing a line, and a #line directive at the
top names the .cu file, so that compiler errors and the emulation's call sites
point at the .cu source.  Usage: rewrite_launches.py INPUT.cu OUTPUT.cpp
"""
import re
import sys

# A kernel name (possibly qualified, possibly with template arguments free of
# angle brackets), the launch configuration, and the opening parenthesis.
LAUNCH = re.compile(r"([A-Za-z_][\w:]*(?:<[^<>]*>)?)(\s*)<<<(.*?)>>>(\s*)\(", re.DOTALL)


def rewrite(source: str) -> tuple[str, int]:
    def replace(match: re.Match) -> str:
        kernel, space_before, config, space_after = match.groups()
        name = kernel.split("<")[0]
        return (f'::overlap::cuda_emulation::launchKernel({kernel},{space_before}"{name}", '
                f"{config}){space_after}(")

    rewritten, count = LAUNCH.subn(replace, source)
    if "<<<" in rewritten:
        line = rewritten[: rewritten.index("<<<")].count("\n") + 1
        raise SystemExit(f"line {line}: a kernel launch this script cannot rewrite")
    if source.count("\n") != rewritten.count("\n"):
        raise SystemExit("the rewrite changed the line count")
    return rewritten, count


def main() -> None:
    if len(sys.argv) != 3:
        raise SystemExit(__doc__)
    source_path, output_path = sys.argv[1], sys.argv[2]
    with open(source_path, encoding="utf-8") as source:
        rewritten, _ = rewrite(source.read())
    escaped = source_path.replace("\\", "\\\\").replace('"', '\\"')
    text = f'#line 1 "{escaped}"\n{rewritten}'
    try:
        with open(output_path, encoding="utf-8") as existing:
            if existing.read() == text:
                return  # unchanged: keep the timestamp, skip the recompile
    except FileNotFoundError:
        pass
    with open(output_path, "w", encoding="utf-8") as output:
        output.write(text)


if __name__ == "__main__":
    main()
