"""Processing figures that ``rigval bench`` does not sweep: rig-like alignment, chunking, long data.

Angle resampling (interpolation order, anti-aliasing), drive-angle derivatives and edge timing
(linear against sinc) are stages of ``rigval bench`` (``--stage resampling``, ``--stage
derivatives``, ``--stage alignment``; docs/performance.md). This script prints what those
sweeps leave out:

1. clock alignment over 12 random 20 s runs of the processing tests' synthetic rig (edge
   refinement, one or both edges; the lifting shaft's twice-per-revolution pulses against
   encoder-angle crossings);
2. zero-phase filtering one-shot vs chunked;
3. a 30-minute record: time and peak memory of the main steps.

Run: ``python benchmarks/bench_processing.py`` (about a minute on 2 cores).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from rigval.processing import angle, clock_fit, encoder, excitation, filters, pulses

FS = 5000.0
W = 2 * np.pi
RNG = np.random.default_rng(2026)


def timed(func: Callable[[], Any], repeat: int = 3) -> tuple[Any, float]:
    """Return the result and the best wall time in s of ``repeat`` calls."""
    best = np.inf
    result = None
    for _ in range(repeat):
        start = time.perf_counter()
        result = func()
        best = min(best, time.perf_counter() - start)
    return result, best


def bench_alignment() -> None:
    print("\n1. Clock alignment, 12 random runs: 20 s, ~1 rev/s with speed wander, 10 % pulses "
          "missing, 2 spurious, start times 2 s off, 60 dB pulse SNR")
    import importlib.util
    import sys
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "tests" / "processing" / "conftest.py"
    spec = importlib.util.spec_from_file_location("processing_synthetic_rig", path)
    assert spec is not None and spec.loader is not None
    rig_module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = rig_module
    spec.loader.exec_module(rig_module)
    rows: dict[str, list[tuple[float, float]]] = {}
    for seed in range(12):
        rig = rig_module.build_rig(seed)
        for refine in ("linear", "sinc"):
            kinds = []
            for polarity in ("rising", "falling"):
                ref = pulses.detect_edges(rig.opt1, rig.t_ref, refine=refine, polarity=polarity)
                dev = pulses.detect_edges(rig.opt2, rig.t_dev, refine=refine, polarity=polarity)
                kinds.append((pulses.classify_pulses(ref).good,
                              pulses.classify_pulses(dev).good - rig.delay))
            for label, use in (("rising", kinds[:1]), ("rising+falling", kinds)):
                clock = clock_fit.estimate_clock([k[0] for k in use], [k[1] for k in use],
                                             coarse_offset_s=0.0)
                rows.setdefault(f"{refine}, {label}", []).append(
                    ((clock.offsets_s[0] - rig.offset) * 1e6, (clock.drift - rig.drift) * 1e6))
        rows.setdefault("opt3 (2/rev) vs encoder", []).append(_opt3_errors(rig))
    print(f"   {'edges':<26}{'offset rms':>12}{'offset max':>12}{'drift rms':>11}"
          f"{'drift max':>11}")
    for label, values in rows.items():
        arr = np.abs(np.array(values))
        print(f"   {label:<26}{np.sqrt(np.mean(arr[:, 0]**2)):>9.2f} us{arr[:, 0].max():>9.2f} us"
              f"{np.sqrt(np.mean(arr[:, 1]**2)):>7.3f} ppm{arr[:, 1].max():>7.3f} ppm")


def _opt3_errors(rig: Any) -> tuple[float, float]:
    """Clock errors (us, ppm) of the twice-per-revolution pulses against encoder crossings."""
    step = 2 * np.pi / 8192
    theta = encoder.counts_to_angle(encoder.unwrap_counts(rig.counts), 8192)
    smooth = excitation.drive_angle(rig.t_ref, theta, fs=FS, step_rad=step)
    opt1 = pulses.classify_pulses(pulses.detect_edges(rig.opt1, rig.t_ref, refine="sinc")).good
    zero, _ = angle.zero_at_reference(rig.t_ref, smooth.angle, opt1)
    events = clock_fit.reference_event_times(rig.t_ref, smooth.angle - zero, event_angle=0.3,
                                         events_per_rev=2)
    dev = pulses.detect_edges(rig.opt3, rig.t_dev, refine="sinc") - rig.delay
    clock = clock_fit.estimate_clock(events, dev, coarse_offset_s=1.2)
    return (clock.offsets_s[0] - rig.offset) * 1e6, (clock.drift - rig.drift) * 1e6


def bench_filter() -> None:
    print("\n2. Zero-phase Butterworth (4th order, 20 Hz) on 10 million samples")
    x = np.cumsum(RNG.standard_normal(10_000_000))
    one, seconds_one = timed(lambda: filters.zero_phase(x, FS, 20.0, chunk_samples=1 << 30),
                             repeat=1)
    chunked, seconds_chunked = timed(lambda: filters.zero_phase(x, FS, 20.0), repeat=1)
    diff = np.max(np.abs(one - chunked)) / np.max(np.abs(one))
    print(f"   one shot {seconds_one:.2f} s, chunks of 2**20 samples {seconds_chunked:.2f} s, "
          f"largest relative difference {diff:.1e}")


def bench_long_record() -> None:
    print("\n3. A 30-minute record at 5 kS/s (9 million samples): time and peak of new allocations")
    import tracemalloc

    t = np.arange(0.0, 1800.0, 1 / FS)
    theta = W * t + 0.05 * np.sin(W * t)
    counts = np.floor(theta / (2 * np.pi) * 8192)
    raw = encoder.counts_to_angle(counts, 8192)
    signal = np.sin(3 * theta)
    size_mb = t.nbytes / 1e6
    steps: list[tuple[str, Callable[[], Any]]] = [
        ("drive_angle (Butterworth 8 Hz)", lambda: excitation.drive_angle(
            t, raw, fs=FS, step_rad=2 * np.pi / 8192)),
        ("resample_to_angle, 360 points/rev", lambda: angle.resample_to_angle(
            t, signal, t, theta, points_per_rev=360, fs=FS)),
        ("zero_phase 20 Hz", lambda: filters.zero_phase(signal, FS, 20.0)),
    ]
    for label, step in steps:
        tracemalloc.start()
        start = time.perf_counter()
        step()
        seconds = time.perf_counter() - start
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        print(f"   {label:<36} {seconds:6.2f} s   peak {peak / 1e6:7.0f} MB "
              f"({peak / 1e6 / size_mb:.1f} x one float64 channel)")


def main() -> None:
    bench_alignment()
    bench_filter()
    bench_long_record()


if __name__ == "__main__":
    main()
