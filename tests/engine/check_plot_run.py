#!/usr/bin/env python3
"""scripts/plot_run.py on a tiny run: it writes OUT/run.png, a valid PNG (the
signature, then an IHDR chunk whose CRC holds, a plausible size, and an IEND
chunk at the end); a bad OUT is one line naming it, exit 2, nothing written.
Exit 77 (skipped) where this python3 has no matplotlib."""
import argparse
import importlib.util
import pathlib
import shutil
import struct
import subprocess
import sys
import zlib

SCRIPT = pathlib.Path(__file__).resolve().parents[2] / "scripts" / "plot_run.py"


def check_png(path: pathlib.Path) -> None:
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", f"{path}: no PNG signature"
    length, kind = struct.unpack(">I4s", data[8:16])
    assert kind == b"IHDR" and length == 13, f"{path}: the first chunk is not IHDR"
    body = data[16:16 + length]
    (crc,) = struct.unpack(">I", data[16 + length:20 + length])
    assert zlib.crc32(kind + body) == crc, f"{path}: IHDR's CRC does not hold"
    width, height = struct.unpack(">II", body[:8])
    assert 400 <= width <= 4000 and 300 <= height <= 4000, f"{path}: {width}x{height}"
    assert data[-12:-4] == b"\x00\x00\x00\x00IEND", f"{path}: does not end with IEND"


def main() -> int:
    parser = argparse.ArgumentParser(allow_abbrev=False)
    parser.add_argument("--overlap", required=True)
    parser.add_argument("--out", type=pathlib.Path, required=True)
    args = parser.parse_args()
    if importlib.util.find_spec("matplotlib") is None:
        print(f"check_plot_run: {sys.executable} has no matplotlib; skipped")
        return 77
    shutil.rmtree(args.out, ignore_errors=True)
    run = args.out / "run"
    subprocess.run([args.overlap, "run", "--objects", "30", "--frames", "4", "--capture-every",
                    "0", "--no-wav", "--quiet", "--out", str(run)], check=True)
    plot = [sys.executable, str(SCRIPT)]
    subprocess.run(plot + [str(run)], check=True)
    check_png(run / "run.png")

    empty = args.out / "empty"
    empty.mkdir()
    broken = args.out / "broken"
    broken.mkdir()
    (broken / "frames.csv").write_text("frame,update_ms\n0,1\n")
    for bad, words in [(args.out / "missing", "not a folder"), (empty, "has no frames.csv"),
                       (broken, "no column")]:
        result = subprocess.run(plot + [str(bad)], capture_output=True, text=True)
        assert result.returncode == 2, f"{bad}: exit {result.returncode}: {result.stderr}"
        assert result.stderr.count("\n") == 1 and words in result.stderr, result.stderr
        assert str(bad) in result.stderr, result.stderr
        assert not bad.exists() or sorted(p.name for p in bad.iterdir()) in ([], ["frames.csv"]), \
            f"{bad}: something was written"
    print("check_plot_run: run.png is a valid PNG; bad folders exit 2 in one line")
    return 0


if __name__ == "__main__":
    sys.exit(main())
