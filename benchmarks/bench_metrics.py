"""Time the comparison metrics and, optionally, check ISO/TS 18571 against the TU Graz code.

    python benchmarks/bench_metrics.py
    python benchmarks/bench_metrics.py --reference-python /path/to/venv/bin/python

The second form needs an interpreter with ``objective-rating-metrics`` (the TU Graz reference
implementation of ISO/TS 18571, PyPI) installed; it rates the same curve pairs there and prints the
largest difference of each score. rigval does not depend on that package.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

from rigval.processing import dtw
from rigval.validation.metrics.compare import baseline, compare, iso18571, iso18571_periodic

REFERENCE_SCRIPT = """
import json, sys
import numpy as np
from objective_rating_metrics.rating import ISO18571
data = np.load(sys.argv[1])
out = []
for i in range(len(data.files) // 2):
    a, b = data[f"m{i}"], data[f"c{i}"]
    t = np.arange(a.size) * 1e-4
    r = ISO18571(np.column_stack([t, a]), np.column_stack([t, b]))
    out.append([r.overall_rating(-1), r.corridor_rating(-1), r.phase_rating(-1),
                r.magnitude_rating(-1), r.slope_rating(-1)])
print(json.dumps(out))
"""


def best_of(function, repeats: int = 3) -> tuple[float, float]:
    """Best wall time and best CPU time of a few calls, s (CPU time is steadier on a busy box)."""
    wall, cpu = [], []
    for _ in range(repeats):
        start_wall, start_cpu = time.perf_counter(), time.process_time()
        function()
        wall.append(time.perf_counter() - start_wall)
        cpu.append(time.process_time() - start_cpu)
    return min(wall), min(cpu)


def row(call: str, samples: int, seconds: tuple[float, float]) -> None:
    print(f"| {call} | {samples} | {seconds[0] * 1e3:.1f} | {seconds[1] * 1e3:.1f} |")


def revolution(n: int, lag_deg: float = 0.0, scale: float = 1.0) -> np.ndarray:
    theta = np.arange(n) * 2 * np.pi / n - np.radians(lag_deg)
    return scale * (np.sin(theta) + 0.4 * np.sin(3 * theta + 0.5) + 0.1 * np.cos(7 * theta))


def timing_table() -> None:
    print("| call | samples | wall (ms) | CPU (ms) |")
    print("|---|---:|---:|---:|")
    for n in (360, 720, 1440, 2880, 5000):
        measured, model = revolution(n), revolution(n, 4.0, 1.05)
        row("iso18571_periodic", n, best_of(lambda m=measured, c=model: iso18571_periodic(m, c)))
    for n in (1000, 5000, 20000):
        t = np.arange(n) / n
        measured = np.sin(2 * np.pi * 3 * t) * np.exp(-t)
        model = 1.1 * np.sin(2 * np.pi * 3 * (t - 0.01)) * np.exp(-t)
        row("iso18571 (decimated above 5000)", n,
            best_of(lambda m=measured, c=model, k=n: iso18571(m, c, dt=1.0 / k)))
    measured, model = revolution(720), revolution(720, 4.0, 1.05)
    row("compare, default metrics", 720, best_of(lambda: compare(measured, model)))
    for n in (360, 720):  # all cycles in one batched DTW sweep (docs/metrics.md)
        cycles = revolution(n) + 0.02 * np.random.default_rng(0).normal(size=(20, n))
        row("baseline, 20 cycles, default metrics", n,
            best_of(lambda c=cycles: baseline(c), 1))


def long_record_table(revolutions: int = 3600, n: int = 360) -> None:
    """The DTW of a 1 h record's comparison (one row per revolution) by batch bound.

    Three revolutions per row (the periodic magnitude), the ISO band of 10 % of a revolution;
    time against the work space a batch holds (``processing.dtw.BATCH_BYTES``).
    """
    radius = int(np.ceil(0.1 * n)) - 1
    rows = np.tile(revolution(n), 3) + 0.1 * np.random.default_rng(0).normal(
        size=(revolutions, 3 * n))
    reference = np.tile(revolution(n, 4.0, 1.05), 3)[np.newaxis]
    print(f"\nDTW of {revolutions} rows of 3 x {n} samples, band radius {radius}:")
    print("| batch bound (MiB) | pairs a batch | work space (MiB) | wall (s) | CPU (s) |")
    print("|---:|---:|---:|---:|---:|")
    default = dtw.BATCH_BYTES
    for mib in (8, 32, 128):
        dtw.BATCH_BYTES = mib * 2**20
        space = np.empty(dtw.workspace_size(revolutions, 3 * n, radius), dtype=np.uint8)
        wall, cpu = best_of(lambda w=space: sum(1 for _ in dtw.dtw_paths(
            rows, reference, radius, y_from=n, workspace=w)), 1)
        print(f"| {mib} | {dtw.pairs_per_batch(revolutions, 3 * n, radius)} | "
              f"{space.nbytes / 2**20:.0f} | {wall:.2f} | {cpu:.2f} |")
    dtw.BATCH_BYTES = default


def reference_pairs() -> list[tuple[str, np.ndarray, np.ndarray]]:
    """Curve pairs at 10 kHz: analytic cases and random walks with shift, scale and noise."""
    t = np.arange(1501) * 1e-4

    def pulse(t0: float, width: float) -> np.ndarray:
        return np.exp(-(((t - t0) / width) ** 2))

    two = pulse(0.05, 0.01) - 0.4 * pulse(0.09, 0.008)
    pairs = [("identical", two, two.copy()), ("scale 1.3", two, 1.3 * two),
             ("delay 4 ms", two, np.interp(t - 0.004, t, two)),
             ("shift beyond window", pulse(0.03, 0.005), pulse(0.11, 0.005)),
             ("inverted sine", np.sin(2 * np.pi * 25 * t), -np.sin(2 * np.pi * 25 * t)),
             ("offset", two, two + 0.1)]
    rng = np.random.default_rng(7)
    pairs.append(("5 % noise", two, two + 0.05 * rng.normal(size=t.size)))
    for k in range(8):
        n = int(rng.integers(200, 1600))
        walk = np.cumsum(rng.normal(size=n))
        walk -= walk.mean()
        other = (np.roll(walk, int(rng.integers(-n // 8, n // 8))) * rng.uniform(0.7, 1.3)
                 + 0.3 * walk.std() * rng.normal(size=n))
        pairs.append((f"random walk {k}", walk, other))
    return pairs


def cross_check(python: str) -> None:
    pairs = reference_pairs()
    with tempfile.TemporaryDirectory() as folder:
        data = Path(folder) / "pairs.npz"
        np.savez(data, **{f"m{i}": m for i, (_, m, _) in enumerate(pairs)},
                 **{f"c{i}": c for i, (_, _, c) in enumerate(pairs)})
        start = time.perf_counter()
        result = subprocess.run([python, "-c", REFERENCE_SCRIPT, str(data)], check=True,
                                capture_output=True, text=True)
        reference_seconds = time.perf_counter() - start
    expected = np.array(json.loads(result.stdout))
    start = time.perf_counter()
    ours = np.array([[s.rating, s.corridor, s.phase, s.magnitude, s.slope]
                     for s in (iso18571(m, c, fs=1e4) for _, m, c in pairs)])
    our_seconds = time.perf_counter() - start
    print(f"\nISO/TS 18571 against objective-rating-metrics, {len(pairs)} pairs")
    print("| pair | R | max |difference| of R, Z, E_P, E_M, E_S |")
    print("|---|---:|---:|")
    for (name, _, _), row, ref in zip(pairs, ours, expected, strict=True):
        print(f"| {name} | {row[0]:.6f} | {np.abs(row - ref).max():.1e} |")
    print(f"largest difference: {np.abs(ours - expected).max():.1e}; time: rigval "
          f"{our_seconds:.2f} s, reference {reference_seconds:.2f} s (with its imports)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reference-python", help="interpreter with objective-rating-metrics")
    args = parser.parse_args()
    timing_table()
    long_record_table()
    if args.reference_python:
        cross_check(args.reference_python)


if __name__ == "__main__":
    main()
