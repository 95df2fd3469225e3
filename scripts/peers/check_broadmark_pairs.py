#!/usr/bin/env python3
"""Checks each Broadmark CPU broadphase's pairs against our exact set on a .aabbs stream.

The exact set is `overlap pairs --algo cpubf` (every frame, frame,a,b).  Each
algorithm runs once through broadmark_driver (--warmup 1 --repeats 1
--pairs-out), which lists its distinct pairs per frame and counts what it
reported (duplicates included).  Stored frame 0 is Broadmark's untimed
Initialize, so frames 1..F are compared.  Per algorithm the table gives the
pairs per frame it reported, its distinct pairs, its duplicates, pairs not in
the exact set (extra: e.g. KD's 0.01 margin, DBVT's fattened leaves) and exact
pairs it missed (summed over frames); exit 1 if any algorithm missed one.

Example (from the repository's top, after scripts/peers/build_broadmark.sh):
  scripts/peers/check_broadmark_pairs.py --driver BM_BUILD/broadmark_driver \\
      --overlap build/overlap --input s4_n500_f16.aabbs --out docs/results/peers_pairs_n500
"""
import collections
import csv
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from script_cli import BadInput, Parser, run  # noqa: E402  (scripts/, one folder up)


def frame_pairs(path):
    """frame -> set of (a, b) from a frame,a,b CSV with a header line."""
    pairs = collections.defaultdict(set)
    with open(path, newline="") as rows:
        reader = csv.reader(rows)
        next(reader)
        for frame, a, b in reader:
            a, b = int(a), int(b)
            pairs[int(frame)].add((min(a, b), max(a, b)))
    return pairs


def main():
    parser = Parser(description=__doc__.splitlines()[0])
    parser.add_argument("--driver", required=True, help="broadmark_driver")
    parser.add_argument("--overlap", required=True, help="our overlap executable")
    parser.add_argument("--input", required=True, help="a .aabbs stream (small n: cpubf is exact and O(n^2))")
    parser.add_argument("--algos", help="comma-separated Broadmark names (default: broadmark_driver --list)")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--out", help="also write OUT.csv")
    args = parser.parse_args()
    if not Path(args.input).is_file():
        raise BadInput(f"--input {args.input}: no such file")
    for option, program in (("--driver", args.driver), ("--overlap", args.overlap)):
        if not os.access(program, os.X_OK):
            raise BadInput(f"{option} {program}: not an executable")

    algos = (args.algos.split(",") if args.algos else
             subprocess.run([args.driver, "--list"], check=True, capture_output=True,
                            text=True).stdout.splitlines())
    with tempfile.TemporaryDirectory() as scratch:
        exact_csv = Path(scratch) / "exact.csv"
        with open(exact_csv, "w") as out:
            subprocess.run([args.overlap, "pairs", "--algo", "cpubf", "--input", args.input],
                           check=True, stdout=out)
        exact = frame_pairs(exact_csv)
        rows = []
        for algo in algos:
            prefix = Path(scratch) / algo.replace(" ", "_")
            subprocess.run([args.driver, "--algo", algo, "--input", args.input, "--warmup", "1",
                            "--repeats", "1", "--threads", str(args.threads), "--out", str(prefix),
                            "--pairs-out", f"{prefix}.pairs"],
                           check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            listed = frame_pairs(f"{prefix}.pairs")
            counts = json.loads(Path(f"{prefix}.json").read_text())["pairs_per_frame"]
            frames = [c["frame"] for c in counts]
            extra = sum(len(listed[f] - exact[f]) for f in frames)
            missed = sum(len(exact[f] - listed[f]) for f in frames)
            rows.append({
                "algorithm": algo,
                "frames": len(frames),
                "exact_per_frame": sum(len(exact[f]) for f in frames) / len(frames),
                "reported_per_frame": sum(c["reported"] for c in counts) / len(frames),
                "distinct_per_frame": sum(c["distinct"] for c in counts) / len(frames),
                "duplicates_per_frame": sum(c["reported"] - c["distinct"] for c in counts) / len(frames),
                "extra_per_frame": extra / len(frames),
                "missed_total": missed,
                "verdict": ("MISSES PAIRS" if missed else "exact" if extra == 0 else
                            "superset (extra pairs)"),
            })

    header = list(rows[0])
    print(f"{Path(args.input).name}: frames 1..{rows[0]['frames']}, exact = overlap pairs --algo cpubf")
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for row in rows:
        print("| " + " | ".join(f"{v:.1f}" if isinstance(v, float) else str(v) for v in row.values()) + " |")
    if args.out:
        with open(f"{args.out}.csv", "w", newline="") as out:
            out.write(f"# stream {Path(args.input).name}; exact set: overlap pairs --algo cpubf; "
                      f"frames 1..{rows[0]['frames']} (0 is Broadmark's Initialize)\n")
            writer = csv.DictWriter(out, fieldnames=header)
            writer.writeheader()
            writer.writerows(rows)
    return 1 if any(row["missed_total"] for row in rows) else 0


if __name__ == "__main__":
    sys.exit(run(main, "check_broadmark_pairs"))
