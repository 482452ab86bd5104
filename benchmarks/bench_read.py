"""Reading a large TDMS file: rigval against nptdms, time and memory growth.

Writes a TDMS file (default 1 GiB: 4 float64 channels, segments of ``2**18`` samples per channel,
written with ``nptdms.TdmsWriter``), warms the page cache, then runs every method of
:data:`rigval.validation.bench.read_cases.READERS` in its own fresh interpreter (imports done
before the clock starts), the methods alternating (one run of each per round, ``--repeat``
rounds), and prints

- the wall time of the read (best of ``--repeat``), its ratio to nptdms streaming, and the CPU
  time of the reading process (all its threads: the SHA-256 runs in a second thread);
- the growth of the resident memory during the read (peak ``VmHWM`` minus ``VmRSS`` after the
  imports, from ``/proc/self/status``) in MiB and as a multiple of the channels' data
  (samples x channels x 8 bytes);
- the relative error of the sum of the values read against the sum written.

The goal of issue 28 ("read, equal work", docs/performance.md) is checked on the
``read_stream`` row with the SHA-256, against nptdms doing the same work: nptdms streaming while a
second thread hashes the file (column ``x +sha``); wall time <= 1.3 x, memory growth <= 1.05 x
the channels' data.
Every run's wall and CPU time is printed too (the load of a shared machine moves them), and the
SHA-256 alone over as many bytes in memory (the floor of any read with the hash on, since
SHA-256 runs on one core).

Usage: ``python benchmarks/bench_read.py [--mib 1024] [--repeat 3] [--keep FILE]``.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from rigval.sample_data.big_tdms import write_big_tdms
from rigval.validation.bench.read_cases import BASELINE, HASHED_BASELINE, READERS, run_reader

MEMORY_GOAL = 1.05
TIME_GOAL = 1.3
#: The rigval method the goal is set for (against :data:`HASHED_BASELINE`, the same work).
GOAL_METHOD = "rigval read_stream (Dataset, sha256)"
#: The SHA-256 alone, from memory: the floor of any read with the hash on (one core).
_HASH_ALONE = """
import hashlib, json, time
data = bytearray(%d)
view = memoryview(data)
digest = hashlib.sha256()
wall, cpu = time.perf_counter(), time.process_time()
for start in range(0, len(data), 1 << 22):
    digest.update(view[start:start + (1 << 22)])
print(json.dumps({"time_s": time.perf_counter() - wall, "cpu_s": time.process_time() - cpu}))
"""


def hash_alone(size: int, repeat: int) -> dict[str, float]:
    """Return the best wall and CPU time of SHA-256 over ``size`` bytes already in memory."""
    runs = []
    for _ in range(repeat):
        out = subprocess.run([sys.executable, "-c", _HASH_ALONE % size], capture_output=True,
                             text=True, check=True)
        runs.append(json.loads(out.stdout))
    return min(runs, key=lambda r: r["time_s"])


def print_huge_page_decision(nbytes: int) -> None:
    """Print whether a direct read of ``nbytes`` gets huge pages here, and why (its DEBUG log)."""
    from rigval.acquisition.hugepages import use_huge_pages

    log = logging.getLogger("rigval.acquisition.hugepages")
    handler = logging.StreamHandler(sys.stdout)
    handler.setFormatter(logging.Formatter("%(message)s"))
    log.addHandler(handler)
    log.setLevel(logging.DEBUG)
    try:
        use_huge_pages(nbytes)
    finally:
        log.removeHandler(handler)
        log.setLevel(logging.NOTSET)


def alternating_runs(methods: list[str], path: Path,
                     repeat: int) -> dict[str, list[dict[str, float]]]:
    """Run the methods in turn, ``repeat`` rounds; return every run of each method.

    The methods alternate (one run of each per round) so that a change of the machine's load
    during the benchmark falls on all of them alike.
    """
    runs: dict[str, list[dict[str, float]]] = {label: [] for label in methods}
    for _ in range(repeat):
        for label in methods:
            runs[label].append(run_reader(label, path))
    return runs


def print_goal(results: dict[str, dict[str, float]], data_bytes: int) -> None:
    """Print the goal line: the read with the SHA-256 against nptdms doing the same work."""
    if GOAL_METHOD not in results or HASHED_BASELINE not in results:
        return
    r, base = results[GOAL_METHOD], results[HASHED_BASELINE]
    growth = r["peak_mib"] * 2**20 / data_bytes
    ratio = r["time_s"] / base["time_s"]
    print(f"goal {GOAL_METHOD}: time {ratio:.2f} x {HASHED_BASELINE} "
          f"({'met' if ratio <= TIME_GOAL else 'NOT met'}, <= {TIME_GOAL}; CPU "
          f"{r['cpu_s'] / base['cpu_s']:.2f} x), memory {growth:.2f} x data "
          f"({'met' if growth <= MEMORY_GOAL else 'NOT met'}, <= {MEMORY_GOAL})")


def main() -> None:
    """Run the reading benchmark and print one line per method."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--mib", type=float, default=1024.0, help="file size in MiB")
    parser.add_argument("--repeat", type=int, default=3, help="runs per method (best kept)")
    parser.add_argument("--keep", type=Path, default=None,
                        help="write the file here (or reuse it if it exists) and keep it")
    parser.add_argument("--methods", nargs="*", default=list(READERS), choices=list(READERS))
    args = parser.parse_args()
    folder = None
    if args.keep is None:
        folder = tempfile.TemporaryDirectory(prefix="rigval_bench_")
        path = Path(folder.name) / "bench.tdms"
    else:
        path = args.keep
    try:
        start = time.perf_counter()
        if not path.exists():
            write_big_tdms(path, args.mib)
            print(f"written in {time.perf_counter() - start:.1f} s")
        from nptdms import TdmsFile

        with TdmsFile.open(path) as tdms:
            channels = [c for g in tdms.groups() for c in g.channels()]
            data_bytes = sum(len(c) * c.dtype.itemsize for c in channels)
            total = float(sum(c[:].sum() for c in channels))
            count = sum(len(c) for c in channels)
        with open(path, "rb") as handle:  # warm the page cache: every method reads warm
            while handle.read(1 << 24):
                pass
        print(f"file {path.stat().st_size / 2**20:.0f} MiB, {len(channels)} channels, "
              f"channel data {data_bytes / 2**20:.0f} MiB; cpu cores {os.cpu_count()}, "
              f"load {os.getloadavg()[0]:.2f}; best of {args.repeat}")
        print_huge_page_decision(data_bytes)
        runs = alternating_runs(args.methods, path, args.repeat)
        results = {label: min(found, key=lambda r: r["time_s"]) for label, found in runs.items()}
        print(f"load after the runs {os.getloadavg()[0]:.2f}")
        reference = results.get(BASELINE, {}).get("time_s", float("nan"))
        hashed = results.get(HASHED_BASELINE, {}).get("time_s", float("nan"))
        print(f"{'method':<50}{'time s':>8}{'x nptdms':>9}{'x +sha':>8}{'CPU s':>7}"
              f"{'growth MiB':>12}{'x data':>8}{'error':>9}")
        for label, r in results.items():
            error = abs(r["total"] - total) / abs(total) if r["count"] == count else 1.0
            print(f"{label:<50}{r['time_s']:>8.2f}{r['time_s'] / reference:>9.2f}"
                  f"{r['time_s'] / hashed:>8.2f}{r['cpu_s']:>7.2f}{r['peak_mib']:>12.0f}"
                  f"{r['peak_mib'] * 2**20 / data_bytes:>8.2f}{error:>9.1e}")
        floor = hash_alone(path.stat().st_size, args.repeat)
        print(f"SHA-256 of as many bytes in memory, one core (the floor of a read with the hash "
              f"on): {floor['time_s']:.2f} s wall, {floor['cpu_s']:.2f} s CPU = "
              f"{floor['time_s'] / reference:.2f} x nptdms streaming")
        for label, found in runs.items():
            print(f"runs of {label}: wall/CPU s " + ", ".join(
                f"{r['time_s']:.2f}/{r['cpu_s']:.2f}" for r in found))
        print_goal(results, data_bytes)
    finally:
        if folder is not None:
            folder.cleanup()


if __name__ == "__main__":
    main()
