"""Reading a large TDMS file: rigval against nptdms, time and peak memory.

Generates a TDMS file (default 1 GiB: 4 float64 channels, segments of 2**20 samples per channel)
in the temporary folder, warms the page cache, then runs each method in its own subprocess and
prints wall time and that subprocess's peak RSS (``ru_maxrss``, imports included). Imports and
xarray's one-time set-up (it imports dask on first use, about 1.5 s here) happen before the clock
starts, for every method alike. The file is deleted at the end.

Methods:

- ``nptdms stream``: ``TdmsFile.open`` + ``data_chunks()`` (sums every chunk);
- ``nptdms read``: ``TdmsFile.read``;
- ``nptdms dataframe``: ``TdmsFile.read(...).as_dataframe()``;
- ``rigval read``: ``rigval.acquisition.read`` into one stream Dataset (``checksum`` on and off);
- ``rigval stream``: ``rigval.acquisition.iter_stream`` windows of 2**20 samples (sums every
  window; ``checksum`` on and off).

Usage: ``python benchmarks/bench_read.py [--gib 1.0] [--methods ...]``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

CHANNELS = 4
SEGMENT_SAMPLES = 1 << 20

METHODS = {
    "nptdms stream": """
from nptdms import TdmsFile
total = 0.0
with TdmsFile.open(PATH) as f:
    for chunk in f.data_chunks():
        for group in chunk.groups():
            for channel in group.channels():
                total += float(channel[:].sum())
""",
    "nptdms read": """
from nptdms import TdmsFile
f = TdmsFile.read(PATH)
total = sum(float(c[:].sum()) for g in f.groups() for c in g.channels())
""",
    "nptdms dataframe": """
from nptdms import TdmsFile
frame = TdmsFile.read(PATH).as_dataframe()
total = float(frame.to_numpy().sum())
""",
    "rigval read": """
import rigval.acquisition as acq
ds = acq.read_stream(PATH, checksum=CHECKSUM)
total = sum(float(ds[v].values.sum()) for v in ds.data_vars if v not in ("valid", "segment"))
""",
    "rigval stream": """
import rigval.acquisition as acq
total = 0.0
for window in acq.iter_stream(PATH, chunk_samples=1 << 20, checksum=CHECKSUM):
    total += sum(float(window[v].values.sum()) for v in window.data_vars
                 if v not in ("valid", "segment"))
""",
}


def generate(path: Path, gib: float) -> int:
    """Write the test file segment by segment (bounded memory); return samples per channel."""
    from nptdms import ChannelObject, GroupObject, RootObject, TdmsWriter

    segments = max(1, round(gib * 2**30 / (SEGMENT_SAMPLES * CHANNELS * 8)))
    props = {"wf_start_time": np.datetime64("2026-11-21T05:00:00.000000"),
             "wf_increment": 1 / 51_200, "wf_start_offset": 0.0, "unit_string": "Volts"}
    rng = np.random.default_rng(0)
    block = rng.normal(size=(CHANNELS, SEGMENT_SAMPLES))
    with TdmsWriter(path) as writer:
        for k in range(segments):
            objects = [ChannelObject("task", f"ai{c}", block[c] + k, props if k == 0 else {})
                       for c in range(CHANNELS)]
            writer.write_segment(([RootObject({}), GroupObject("task")] if k == 0 else [])
                                 + objects)
    return segments * SEGMENT_SAMPLES


def run_method(name: str, path: Path, checksum: bool) -> dict[str, float]:
    """Run one method in a fresh interpreter; return its wall time and peak RSS."""
    code = f"""
import json, resource, time
import numpy as np, xarray as xr, nptdms, rigval.acquisition
xr.Dataset({{"a": ("t", np.zeros(3))}})  # xarray imports its duck-array modules on first use
PATH = {str(path)!r}
CHECKSUM = {checksum!r}
start = time.perf_counter()
{METHODS[name]}
elapsed = time.perf_counter() - start
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(json.dumps({{"seconds": elapsed, "peak_mib": peak, "total": total}}))
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def baseline_mib() -> float:
    """Peak RSS of an interpreter that only imports rigval.acquisition (MiB)."""
    code = ("import resource, rigval.acquisition, nptdms; "
            "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    return float(out.stdout.strip())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--gib", type=float, default=1.0, help="file size in GiB")
    parser.add_argument("--methods", nargs="*", default=list(METHODS), choices=list(METHODS))
    parser.add_argument("--repeat", type=int, default=1, help="runs per method (best kept)")
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="rigval_bench_"))
    path = folder / "big.tdms"
    try:
        t = time.perf_counter()
        samples = generate(path, args.gib)
        size = path.stat().st_size
        print(f"file: {size / 2**30:.2f} GiB, {CHANNELS} float64 channels x {samples} samples, "
              f"{samples // SEGMENT_SAMPLES} segments, written in {time.perf_counter() - t:.1f} s")
        with open(path, "rb") as handle:  # warm the page cache: every method reads warm
            while handle.read(1 << 26):
                pass
        print(f"cpu cores: {os.cpu_count()}, interpreter + imports: {baseline_mib():.0f} MiB, "
              f"max RSS of this driver: "
              f"{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MiB")
        runs = [(m, False) for m in args.methods]
        runs += [(m, True) for m in args.methods if m.startswith("rigval")]
        results = {}
        for name, checksum in runs:
            label = name + (" (+sha256)" if checksum else "")
            best = min((run_method(name, path, checksum) for _ in range(args.repeat)),
                       key=lambda r: r["seconds"])
            results[label] = best
        reference = results.get("nptdms stream", {}).get("seconds")
        print(f"{'method':<28}{'time s':>9}{'x stream':>10}{'peak RSS MiB':>14}")
        for label, r in results.items():
            ratio = f"{r['seconds'] / reference:.2f}" if reference else "-"
            print(f"{label:<28}{r['seconds']:>9.2f}{ratio:>10}{r['peak_mib']:>14.0f}")
    finally:
        path.unlink(missing_ok=True)
        folder.rmdir()


if __name__ == "__main__":
    main()
