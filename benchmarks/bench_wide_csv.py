"""Reading a CSV of one wide row against the same values written as one column.

Writes three text files of ``--values`` numbers (default 20,000, 17 significant digits, about
420 KB): one row without a names row (a waveform written as a row: read as one channel), the
same values as one column under a names row (the normal layout), and one row under a names row
(one sample of each of 20,000 named channels). Each is read with ``fs=1000`` in a fresh
interpreter after a warm-up read of a small CSV (so the imports and xarray's one-time lazy
imports are paid before the clock starts), ``--repeat`` times; prints the best and median wall
times in s.

Usage: ``python benchmarks/bench_wide_csv.py [--values 20000] [--repeat 5]``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

_TIMED = """
import json, sys, time, warnings
from rigval.acquisition import read
warnings.simplefilter("ignore")
read(sys.argv[1], fs=1000.0, checksum=False)  # warm-up: imports, lazy imports
times = []
for _ in range(int(sys.argv[3])):
    wall = time.perf_counter()
    read(sys.argv[2], fs=1000.0, checksum=False)
    times.append(time.perf_counter() - wall)
print(json.dumps(times))
"""


def write_files(folder: Path, n: int) -> dict[str, Path]:
    """Write the warm-up file and the three layouts of ``n`` values; return them by label."""
    values = np.random.default_rng(0).normal(size=n)
    cells = [f"{v:.17g}" for v in values]
    files = {"warm-up": folder / "small.csv", "one row, no names row": folder / "row.csv",
             "one column under a name": folder / "column.csv",
             "one row under names": folder / "named_row.csv"}
    files["warm-up"].write_text("a\n1\n2\n3\n", encoding="ascii")
    files["one row, no names row"].write_text(",".join(cells) + "\n", encoding="ascii")
    files["one column under a name"].write_text("a\n" + "\n".join(cells) + "\n", encoding="ascii")
    names = ",".join(f"ch{k}" for k in range(n))
    files["one row under names"].write_text(names + "\n" + ",".join(cells) + "\n",
                                            encoding="ascii")
    return files


def main() -> None:
    """Write the files, time each layout in a fresh interpreter and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--values", type=int, default=20_000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        files = write_files(Path(folder), args.values)
        print("| layout | file KB | best s | median s |")
        print("| --- | --- | --- | --- |")
        for label, path in files.items():
            if label == "warm-up":
                continue
            out = subprocess.run([sys.executable, "-c", _TIMED, str(files["warm-up"]),
                                  str(path), str(args.repeat)],
                                 capture_output=True, text=True, check=True)
            times = json.loads(out.stdout)
            print(f"| {label} | {path.stat().st_size / 1e3:.0f} | {min(times):.3f} | "
                  f"{float(np.median(times)):.3f} |")


if __name__ == "__main__":
    main()
