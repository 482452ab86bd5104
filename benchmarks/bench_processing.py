"""Speed against error for the main processing choices, on synthetic signals with known truth.

Run: ``python benchmarks/bench_processing.py`` (about a minute on 2 cores). Prints tables for

1. angle resampling: interpolation order (np.interp baseline, spline orders 1, 3, 5);
2. anti-aliasing before a coarse angle grid (none vs zero-phase Butterworth);
3. drive-angle derivatives: plain differencing baseline, Savitzky-Golay, Butterworth (corner
   and order), mean-speed Fourier series;
4. reference-pulse edge timing (linear vs band-limited sinc reconstruction);
5. clock alignment over 12 random 20 s runs (edge refinement, one or both edges; the lifting
   shaft's twice-per-revolution pulses against encoder-angle crossings);
6. zero-phase filtering one-shot vs chunked;
7. a 30-minute record: time and peak memory of the main steps.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np
from scipy.signal import savgol_filter
from scipy.special import sici

from rigval.processing import align, angle, encoder, excitation, filters, pulses

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


def ripple_angle(t: np.ndarray) -> np.ndarray:
    return W * t + 0.08 * np.sin(W * t)


def time_of(phi: np.ndarray) -> np.ndarray:
    t = phi / W
    for _ in range(40):
        t -= (ripple_angle(t) - phi) / (W * (1 + 0.08 * np.cos(W * t)))
    return t


def bench_interpolation() -> None:
    print("\n1. Angle resampling, 20 s at 1 rev/s +-8 % speed ripple, 5 kHz, 8192 points/rev")
    print("   max error relative to the amplitude (run ends included); time per run")
    t = np.arange(0.0, 20.0, 1 / FS)
    phi = ripple_angle(t)
    print(f"   {'method':<24}" + "".join(f"{f:>11}" for f in ("0.004 fs", "0.04 fs", "0.05 fs",
                                                            "0.1 fs", "0.2 fs")) + "   time")
    methods: list[tuple[str, Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]]] = [
        ("np.interp (baseline)", lambda x: _baseline_interp(t, phi, x)),
        *[(f"spline order {k}", lambda x, k=k: _spline(t, phi, x, k)) for k in (1, 3, 5)],
    ]
    for label, method in methods:
        errors = []
        elapsed = 0.0
        for f_rel in (0.004, 0.04, 0.05, 0.1, 0.2):
            x = np.sin(2 * np.pi * f_rel * FS * t + 0.3)
            (grid_time, y), seconds = timed(lambda x=x, m=method: m(x), repeat=1)
            elapsed = max(elapsed, seconds)
            errors.append(np.nanmax(np.abs(y - np.sin(2 * np.pi * f_rel * FS * grid_time + 0.3))))
        print(f"   {label:<24}" + "".join(f"{e:>11.1e}" for e in errors) + f"   {elapsed:.2f} s")


def _baseline_interp(t: np.ndarray, phi: np.ndarray, x: np.ndarray,
                     ) -> tuple[np.ndarray, np.ndarray]:
    _, grid = angle.cycle_grid(phi[0], phi[-1], 8192)
    grid_time = np.interp(grid, phi, t)
    return time_of(grid), np.interp(grid_time, t, x)


def _spline(t: np.ndarray, phi: np.ndarray, x: np.ndarray, order: int,
            ) -> tuple[np.ndarray, np.ndarray]:
    cyc, _, y = angle.resample_to_angle(t, x, t, phi, points_per_rev=8192, fs=FS, order=order,
                                        anti_alias="none")
    grid = 2 * np.pi * (cyc[:, None] + np.arange(8192)[None, :] / 8192)
    return time_of(grid), y


def bench_anti_alias() -> None:
    print("\n2. Anti-aliasing, 360 points/rev at 1 rev/s: 5 Hz signal + 300 Hz disturbance "
          "(above the grid's 180 orders)")
    t = np.arange(0.0, 20.0, 1 / FS)
    phi = ripple_angle(t)
    x = np.sin(2 * np.pi * 5 * t) + 0.5 * np.sin(2 * np.pi * 300 * t)
    for choice in ("none", "butterworth"):
        (cyc, _, y), seconds = timed(lambda choice=choice: angle.resample_to_angle(
            t, x, t, phi, points_per_rev=360, fs=FS, anti_alias=choice))
        grid = 2 * np.pi * (cyc[:, None] + np.arange(360)[None, :] / 360)
        err = np.abs(y - np.sin(2 * np.pi * 5 * time_of(grid)))[1:-1]
        print(f"   {choice:<12} max error of the 5 Hz part {err.max():.1e}   {seconds:.3f} s")


def bench_derivatives() -> None:
    print("\n3. Drive-angle acceleration, 8192 counts/rev, 5 kHz, 1 rev/s, harmonics 1-4 of "
          "50/20/10/5 mrad, 20 s")
    t = np.arange(0.0, 20.0, 1 / FS)
    harmonics = [(1, 0.05, 0.3), (2, 0.02, 1.1), (3, 0.01, 2.0), (4, 0.005, 0.7)]
    theta = W * t + sum(a * np.sin(k * W * t + p) for k, a, p in harmonics)
    alpha = -sum(a * (k * W) ** 2 * np.sin(k * W * t + p) for k, a, p in harmonics)
    raw = encoder.counts_to_angle(np.floor(theta / (2 * np.pi) * 8192), 8192)
    step = 2 * np.pi / 8192
    inner = (t > 0.5) & (t < 19.5)
    print(f"   {'method':<36}{'rms':>10}{'max inner':>11}{'max all':>10}{'noise est.':>12}"
          f"{'time':>9}")

    def report(label: str, acc: np.ndarray, seconds: float, noise: float | None = None) -> None:
        err = np.abs(acc - alpha)
        noise_text = f"{noise:>12.4f}" if noise is not None else f"{'-':>12}"
        print(f"   {label:<36}{np.sqrt(np.nanmean(err**2)):>10.4f}{np.nanmax(err[inner]):>11.4f}"
              f"{np.nanmax(err):>10.4f}{noise_text}{seconds:>8.3f}s")

    acc, seconds = timed(lambda: np.gradient(np.gradient(raw, 1 / FS), 1 / FS))
    report("central differences (baseline)", acc, seconds)
    for window in (1001, 2001):
        acc, seconds = timed(lambda w=window: savgol_filter(raw, w, 3, deriv=2, delta=1 / FS),
                             repeat=1)
        report(f"Savitzky-Golay cubic, {window} samples", acc, seconds)
    for cutoff, order in ((6.0, 8), (8.0, 8), (12.0, 8), (8.0, 4)):
        result, seconds = timed(lambda c=cutoff, o=order: excitation.drive_angle(
            t, raw, fs=FS, step_rad=step, cutoff_hz=c, order=o))
        report(f"Butterworth {cutoff:g} Hz, order {order} (x2)", result.acceleration, seconds,
               result.acceleration_noise)
    result, seconds = timed(lambda: excitation.drive_angle(t, raw, fs=FS, step_rad=step,
                                                           trend_harmonics=0, padtype="odd"))
    report("Butterworth 8 Hz, no trend, odd pad", result.acceleration, seconds,
           result.acceleration_noise)
    for k in (4, 8):
        result, seconds = timed(lambda k=k: excitation.drive_angle(
            t, raw, fs=FS, step_rad=step, method="fourier", harmonics=k))
        report(f"Fourier series, {k} harmonics", result.acceleration, seconds,
               result.acceleration_noise)


def _pulses(t: np.ndarray, rises: np.ndarray, fs: float, noise: float) -> np.ndarray:
    x = np.zeros_like(t)
    wc = 2 * np.pi * 0.45 * fs
    for r in rises:
        near = np.abs(t - r) < 0.2
        x[near] += (sici(wc * (t[near] - r))[0] - sici(wc * (t[near] - r - 0.03))[0]) / np.pi
    return x + noise * RNG.standard_normal(t.size)


def bench_edges() -> None:
    print("\n4. Edge timing of band-limited (0.45 fs) analog pulses, 200 edges, error in samples")
    t = np.arange(0.0, 205.0, 1 / FS)
    rises = np.arange(1.0, 201.0) + RNG.uniform(0, 1 / FS, 200)
    for noise in (0.0, 1e-3, 1e-2):
        x = _pulses(t, rises, FS, noise)
        for refine in ("linear", "sinc"):
            edges, seconds = timed(lambda x=x, r=refine: pulses.detect_edges(x, t, refine=r),
                                   repeat=1)
            err = (edges - rises) * FS
            print(f"   noise {noise:<6g} {refine:<7} rms {np.sqrt(np.mean(err**2)):.5f}  "
                  f"max {np.abs(err).max():.5f}  {seconds / 200 * 1e6:7.0f} us per edge")


def bench_alignment() -> None:
    print("\n5. Clock alignment, 12 random runs: 20 s, ~1 rev/s with speed wander, 10 % pulses "
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
                clock = align.estimate_clock([k[0] for k in use], [k[1] for k in use],
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
    events = align.reference_event_times(rig.t_ref, smooth.angle - zero, event_angle=0.3,
                                         events_per_rev=2)
    dev = pulses.detect_edges(rig.opt3, rig.t_dev, refine="sinc") - rig.delay
    clock = align.estimate_clock(events, dev, coarse_offset_s=1.2)
    return (clock.offsets_s[0] - rig.offset) * 1e6, (clock.drift - rig.drift) * 1e6


def bench_filter() -> None:
    print("\n6. Zero-phase Butterworth (4th order, 20 Hz) on 10 million samples")
    x = np.cumsum(RNG.standard_normal(10_000_000))
    one, seconds_one = timed(lambda: filters.zero_phase(x, FS, 20.0, chunk_samples=1 << 30),
                             repeat=1)
    chunked, seconds_chunked = timed(lambda: filters.zero_phase(x, FS, 20.0), repeat=1)
    diff = np.max(np.abs(one - chunked)) / np.max(np.abs(one))
    print(f"   one shot {seconds_one:.2f} s, chunks of 2**20 samples {seconds_chunked:.2f} s, "
          f"largest relative difference {diff:.1e}")


def bench_long_record() -> None:
    print("\n7. A 30-minute record at 5 kS/s (9 million samples): time and peak of new allocations")
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
    bench_interpolation()
    bench_anti_alias()
    bench_derivatives()
    bench_edges()
    bench_alignment()
    bench_filter()
    bench_long_record()


if __name__ == "__main__":
    main()
