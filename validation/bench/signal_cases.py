"""Angle-resampling and drive-angle-derivative sweeps of ``rigval bench``.

Both run on synthetic signals with an exact truth at 5 kHz:

- resampling: a shaft at 1 rev/s with +-8 % speed ripple, ``phi(t) = 2 pi t + 0.08 sin(2 pi t)``
  known exactly at every sample; a sine of frequency f is resampled onto a uniform phi_F grid and
  compared with the sine at the exact time of each grid angle (Newton inverse of ``phi``).
  Choices: :func:`numpy.interp` for both the inverse map and the amplitudes (the baseline), and
  :func:`rigval.processing.angle.resample_to_angle` with spline order 1, 3, 5; and, on a coarse
  grid (360 points/rev) with a 300 Hz disturbance above its Nyquist order, without and with the
  anti-alias filter.
- derivatives: a drive angle ``2 pi t + sum_k a_k sin(k 2 pi t + p_k)`` (harmonics 1-4 of 50, 20,
  10, 5 mrad) quantised by an 8192-count encoder; speed and acceleration from
  :func:`rigval.processing.excitation.drive_angle` (Butterworth corner and order, Fourier series
  harmonics), from a Savitzky-Golay filter and from plain central differences (the baseline),
  against the analytic derivatives.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable

import numpy as np

from rigval.processing import angle, encoder, excitation
from rigval.processing.arrays import FloatArray
from rigval.processing.scipy_signal import savgol_filter
from rigval.sample_data.synthetic_signals import ripple_angle, ripple_time
from rigval.validation.bench.rows import BenchRow, measure, with_baseline

__all__ = ["derivative_rows", "resampling_rows"]

logger = logging.getLogger(__name__)

FS = 5000.0
TWO_PI = 2 * math.pi
INTERP_BASELINE = "np.interp (time map and amplitudes)"
DIFF_BASELINE = "central differences of the counts"
SAVGOL = "Savitzky-Golay cubic, 1001 samples"
COUNTS_PER_REV = 8192
HARMONICS = ((1, 0.05, 0.3), (2, 0.02, 1.1), (3, 0.01, 2.0), (4, 0.005, 0.7))
#: Interpolation error constants c_k of a sine, max error ~ c_k (2 pi f / fs)**(k + 1) of the
#: amplitude: linear (1/8), not-a-knot cubic spline (5/384), quintic spline (bound incl. run ends).
_SPLINE_CONSTANT = {1: 1 / 8, 3: 5 / 384, 5: 1e-2}

def _interp_baseline(t: FloatArray, phi: FloatArray, x: FloatArray, points: int,
                     ) -> tuple[FloatArray, FloatArray]:
    _, grid = angle.cycle_grid(float(phi[0]), float(phi[-1]), points)
    return grid, np.interp(np.interp(grid, phi, t), t, x)


def _rigval_resample(t: FloatArray, phi: FloatArray, x: FloatArray, points: int, order: int,
                     anti_alias: str) -> tuple[FloatArray, FloatArray]:
    cycles, _, y = angle.resample_to_angle(t, x, t, phi, points_per_rev=points, fs=FS,
                                           order=order, anti_alias=anti_alias)  # type: ignore[arg-type]
    grid = TWO_PI * (cycles[:, None] + np.arange(points)[None, :] / points)
    return grid, y


Resampler = Callable[[FloatArray, FloatArray, FloatArray, int], tuple[FloatArray, FloatArray]]


def resampling_rows(quick: bool = False) -> list[BenchRow]:
    """Angle resampling: interpolation order and anti-aliasing against error and time.

    Parameters
    ----------
    quick : bool, default False
        5 s of data and one content frequency instead of 20 s and three.

    Returns
    -------
    list of BenchRow
        Stage ``"resampling"``; error: largest deviation from the truth over every grid point of
        the whole cycles, relative to the amplitude; baseline: :func:`numpy.interp`.
    """
    seconds = 5.0 if quick else 20.0
    repeats = 2 if quick else 5
    t = np.arange(round(seconds * FS)) / FS
    phi = ripple_angle(t)
    methods: dict[str, tuple[Resampler, int]] = {INTERP_BASELINE: (_interp_baseline, 1)}
    for order in (1, 3, 5):
        methods[f"spline order {order}"] = (
            lambda t, p, x, n, order=order: _rigval_resample(t, p, x, n, order, "none"), order)
    rows: list[BenchRow] = []
    for f_rel in ((0.04,) if quick else (0.004, 0.04, 0.2)):
        x = np.sin(TWO_PI * f_rel * FS * t + 0.3)
        case = f"sine at {f_rel:g} fs, 8192 points/rev, {seconds:g} s at 1 rev/s +-8 % ripple"
        for label, (method, order) in methods.items():
            run = measure(lambda m=method, x=x: m(t, phi, x, 8192), repeats)
            grid, y = run.value
            error = float(np.nanmax(np.abs(y - np.sin(TWO_PI * f_rel * FS * ripple_time(grid)
                                                      + 0.3))))
            bound = 3 * _SPLINE_CONSTANT[order] * (TWO_PI * f_rel) ** (order + 1) + 1e-8
            rows.append(BenchRow(stage="resampling", case=case, choice=label,
                                 metric="max error / amplitude", unit="1", error=error,
                                 bound=bound, time_s=run.time_s, cpu_s=run.cpu_s, n=t.size))
    rows.extend(_anti_alias_rows(t, phi, seconds, repeats))
    return with_baseline(rows, INTERP_BASELINE)


def _anti_alias_rows(t: FloatArray, phi: FloatArray, seconds: float, repeats: int,
                     ) -> list[BenchRow]:
    """360 points/rev, 5 Hz signal plus a 300 Hz disturbance above the grid's 180 orders."""
    x = np.sin(TWO_PI * 5 * t) + 0.5 * np.sin(TWO_PI * 300 * t)
    case = f"5 Hz + 0.5 at 300 Hz, 360 points/rev, {seconds:g} s at 1 rev/s +-8 % ripple"
    choices: dict[str, tuple[Resampler, float]] = {
        INTERP_BASELINE: (_interp_baseline, 0.6),
        "spline order 5, no anti-alias": (
            lambda t, p, x, n: _rigval_resample(t, p, x, n, 5, "none"), 0.6),
        "spline order 5, Butterworth anti-alias": (
            lambda t, p, x, n: _rigval_resample(t, p, x, n, 5, "butterworth"), 1e-4)}
    rows = []
    for label, (method, bound) in choices.items():
        run = measure(lambda m=method: m(t, phi, x, 360), repeats)
        grid, y = run.value
        # whole cycles but the first and last: the zero-phase filter's start-up is not counted
        error = float(np.nanmax(np.abs(y - np.sin(TWO_PI * 5 * ripple_time(grid)))[1:-1]))
        rows.append(BenchRow(stage="resampling", case=case, choice=label,
                             metric="max error of the 5 Hz part / its amplitude, inner cycles",
                             unit="1", error=error, bound=bound, time_s=run.time_s,
                             cpu_s=run.cpu_s, n=t.size))
    return rows


def _central_differences(raw: FloatArray) -> tuple[FloatArray, FloatArray]:
    velocity = np.gradient(raw, 1 / FS)
    return velocity, np.gradient(velocity, 1 / FS)


def _derivative_bound(label: str, unit: str, limit: float) -> float:
    """Return the stated error bound of a derivative estimator (rad/s or rad/s2)."""
    if label == DIFF_BASELINE:  # plain differences: as noisy as theory says, no more
        return 2 * limit
    if label == SAVGOL:  # biased at the record ends (polynomial fits of 0.2 s)
        return 1e-2 if unit == "rad s-1" else 2.0
    # rigval's estimators: within 4x their own noise estimate plus a small bias allowance
    return 4 * limit + (1e-4 if unit == "rad s-1" else 2e-3)


def derivative_rows(quick: bool = False) -> list[BenchRow]:
    """Drive-angle speed and acceleration: method and order against error and time.

    Parameters
    ----------
    quick : bool, default False
        10 s and four methods instead of 20 s and nine.

    Returns
    -------
    list of BenchRow
        Stage ``"derivatives"``; metrics rms error of speed (rad/s) and acceleration (rad/s2)
        over the whole record; limit: the noise the quantisation alone leaves (the estimate
        :func:`~rigval.processing.excitation.drive_angle` reports; for central differences
        ``sigma_q / (sqrt(2) dt)`` and ``sqrt(6) sigma_q / (4 dt**2)``, ``sigma_q = q / sqrt(12)``).
        Bounds: rigval's estimators within 4 times their own noise estimate plus a small bias
        allowance (1e-4 rad/s, 2e-3 rad/s2), central differences within twice theory,
        Savitzky-Golay 1e-2 rad/s and 2 rad/s2.
    """
    seconds = 10.0 if quick else 20.0
    repeats = 2 if quick else 5
    t = np.arange(round(seconds * FS)) / FS
    theta = TWO_PI * t + sum(a * np.sin(k * TWO_PI * t + p) for k, a, p in HARMONICS)
    omega = TWO_PI + sum(a * k * TWO_PI * np.cos(k * TWO_PI * t + p) for k, a, p in HARMONICS)
    alpha = -sum(a * (k * TWO_PI) ** 2 * np.sin(k * TWO_PI * t + p) for k, a, p in HARMONICS)
    step = TWO_PI / COUNTS_PER_REV
    raw = encoder.counts_to_angle(np.floor(theta / step), COUNTS_PER_REV)
    sigma_q = step / math.sqrt(12)
    case = (f"{COUNTS_PER_REV} counts/rev, {FS:g} Hz, 1 rev/s + harmonics 1-4, {seconds:g} s")
    # choice -> estimator returning speed, acceleration and their predicted noise
    choices: dict[str, Callable[[], tuple[FloatArray, FloatArray, float, float]]] = {
        DIFF_BASELINE: lambda: (*_central_differences(raw), sigma_q * FS / math.sqrt(2),
                                math.sqrt(6) * sigma_q * FS**2 / 4)}

    def rigval_method(**options: float | str) -> Callable[[], tuple[FloatArray, FloatArray,
                                                                     float, float]]:
        def run() -> tuple[FloatArray, FloatArray, float, float]:
            result = excitation.drive_angle(t, raw, fs=FS, step_rad=step,
                                            **options)  # type: ignore[arg-type]
            return (result.velocity, result.acceleration, result.velocity_noise,
                    result.acceleration_noise)
        return run

    settings: list[tuple[str, dict[str, float | str]]] = [
        ("Butterworth 8 Hz, order 8 (default)", {"cutoff_hz": 8.0, "order": 8}),
        ("Fourier series, 8 harmonics", {"method": "fourier", "harmonics": 8})]
    if not quick:
        settings += [("Butterworth 6 Hz, order 8", {"cutoff_hz": 6.0, "order": 8}),
                     ("Butterworth 12 Hz, order 8", {"cutoff_hz": 12.0, "order": 8}),
                     ("Butterworth 8 Hz, order 4", {"cutoff_hz": 8.0, "order": 4}),
                     ("Fourier series, 4 harmonics", {"method": "fourier", "harmonics": 4}),
                     ("Fourier series, 16 harmonics", {"method": "fourier", "harmonics": 16})]
    for label, options in settings:
        choices[label] = rigval_method(**options)
    choices[SAVGOL] = lambda: (savgol_filter(raw, 1001, 3, deriv=1, delta=1 / FS),
                               savgol_filter(raw, 1001, 3, deriv=2, delta=1 / FS),
                               math.nan, math.nan)
    rows = []
    for label, estimator in choices.items():
        run = measure(estimator, repeats)
        velocity, acceleration, velocity_noise, acceleration_noise = run.value
        for metric, unit, value, truth, limit in (
                ("speed: rms error", "rad s-1", velocity, omega, velocity_noise),
                ("acceleration: rms error", "rad s-2", acceleration, alpha, acceleration_noise)):
            bound = _derivative_bound(label, unit, limit)
            error = float(np.sqrt(np.nanmean((value - truth) ** 2)))
            rows.append(BenchRow(stage="derivatives", case=case, choice=label, metric=metric,
                                 unit=unit, error=error, bound=bound, limit=limit,
                                 time_s=run.time_s, cpu_s=run.cpu_s, n=t.size))
    return with_baseline(rows, DIFF_BASELINE)
