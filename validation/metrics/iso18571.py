"""ISO/TS 18571 objective rating of a model signal against a measured one.

The rating combines four scores in [0, 1] (ISO/TS 18571, ed. 2 2024; ed. 1 2014):

* corridor ``Z``: the share of samples inside corridors around the reference, on the unshifted
  signals;
* phase ``E_P``: the shift that maximises the Pearson correlation of the overlapping parts, scored
  against the allowed shift window;
* magnitude ``E_M``: the L1 error of the phase-compensated signals after dynamic time warping (DTW);
* slope ``E_S``: the L1 error of their smoothed derivatives;

``R = 0.4 Z + 0.2 E_P + 0.2 E_M + 0.2 E_S``, graded excellent (R > 0.94), good (> 0.80),
fair (> 0.58) or poor. The computational details (window limits, DTW band, step pattern, tie order,
end treatment of the slope smoothing) follow the TU Graz reference implementation
``objective_rating_metrics`` 1.3, which reproduces the 42 rating cases of the standard's Annex C
within its 0.001 tolerance (see docs/metrics.md and docs/references.md).

:func:`iso18571_periodic` is this package's variant for signals over exactly one revolution, with
no ends: the phase shift is circular (no truncation, all samples kept); the DTW runs on the signals
repeated to three revolutions and scores the middle one, so that the warping path's fixed start and
end lie a revolution away; the slope uses circular differences and a circular 9-point mean. The
corridor and all scoring formulas are the standard's. In the tests, rotating both signals to
start at another angle changes no score beyond rounding.

Cost: the DTW of the magnitude score is O(n^2) in time (a band of 20 % of the cells, swept one
anti-diagonal at a time; three times as long for the periodic variant) and stores eight bytes per
band cell (:mod:`rigval.processing.dtw`). Longer signals are therefore brought down to at
most ``max_samples`` samples before rating (integer decimation with a zero-phase FIR anti-alias
filter for time signals, Fourier resampling for periodic ones); the rated sample count is in the
result. The standard assumes 10 kHz sampling and its slope smoothing and windows are in samples and
fractions of the interval, so ratings of the same signals at different sample counts differ
slightly.
"""

from __future__ import annotations

import dataclasses
import itertools
import logging
import math
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from rigval.acquisition.errors import ConfigError, DataError
from rigval.processing.dtw import dtw_path, dtw_paths, pairs_per_batch, workspace_size
from rigval.processing.scipy_signal import correlate, decimate, resample
from rigval.validation.metrics.core import Scores, paired, revolution_angle, row_dot

__all__ = [
    "DEFAULT_MAX_SAMPLES",
    "GRADES",
    "ROWS_PER_SWEEP",
    "IsoParameters",
    "IsoScores",
    "dtw_path",
    "grade",
    "iso18571",
    "iso18571_periodic",
    "iso18571_periodic_many",
    "iso18571_periodic_sets",
]

logger = logging.getLogger(__name__)

DEFAULT_MAX_SAMPLES = 5000
"""Longest signal rated as it is; longer ones are resampled (see the module docstring)."""

MIN_ISO_SAMPLES = 16
"""Fewest samples ISO rating accepts (the slope smoothing spans 9)."""

GRADES: tuple[tuple[float, str], ...] = ((0.94, "excellent"), (0.80, "good"), (0.58, "fair"))
"""Lower grade limits of ISO/TS 18571 (a rating must exceed the limit); below all: ``"poor"``."""

_TIE_TOLERANCE = 1e-12
"""Correlations closer than this to the best count as ties (rounding of the FFT correlation)."""

_SLOPE_HALF_WIDTH = 4
"""Half-width of the 9-point moving average applied to the derivatives, samples."""

#: Most rows :func:`iso18571_periodic_sets` sweeps together: a sweep's fixed cost (one
#: Python-level step per anti-diagonal) is mostly amortised by then, while its cost band stays
#: small (about 0.65 MB per row for a 360-point revolution, three times repeated). Two sets of
#: a 20 s record (15 to 24 rows: a comparison's model and revolutions) share a sweep (at 32 the
#: nine sets of 22-24 rows of ``run_1p2`` took nine sweeps, five now).
ROWS_PER_SWEEP = 48


@dataclasses.dataclass(frozen=True)
class IsoParameters:
    """Parameters of the ISO/TS 18571 rating (defaults: the standard's).

    Parameters
    ----------
    inner_width : float
        Inner corridor half-width ``a_0`` as a fraction of ``max|measured|`` (0.05).
    outer_width : float
        Outer corridor half-width ``b_0`` as a fraction of ``max|measured|`` (0.5).
    corridor_exponent : float
        ``k_Z`` (2).
    phase_window : float
        Largest shift ``eps_P`` considered, as a fraction of the sample count (0.2).
    phase_exponent : float
        ``k_P`` (1).
    magnitude_limit : float
        Relative L1 magnitude error ``eps_M`` that scores 0 (0.5).
    magnitude_exponent : float
        ``k_M`` (1).
    slope_limit : float
        Relative L1 slope error ``eps_S`` that scores 0 (2.0).
    slope_exponent : float
        ``k_S`` (1).
    dtw_band : float
        Sakoe-Chiba band of the DTW as a fraction of the sample count: cells with
        ``|i - j| < ceil(dtw_band * n)`` (0.1).
    weights : tuple of float
        Weights of corridor, phase, magnitude and slope (0.4, 0.2, 0.2, 0.2); they sum to 1.

    Raises
    ------
    ConfigError
        If a parameter is out of range (the key names it).
    """

    inner_width: float = 0.05
    outer_width: float = 0.5
    corridor_exponent: float = 2.0
    phase_window: float = 0.2
    phase_exponent: float = 1.0
    magnitude_limit: float = 0.5
    magnitude_exponent: float = 1.0
    slope_limit: float = 2.0
    slope_exponent: float = 1.0
    dtw_band: float = 0.1
    weights: tuple[float, float, float, float] = (0.4, 0.2, 0.2, 0.2)

    def __post_init__(self) -> None:
        if not 0.0 <= self.inner_width < self.outer_width:
            raise ConfigError(f"corridor widths need 0 <= inner < outer, got inner "
                              f"{self.inner_width}, outer {self.outer_width}",
                              where={"key": "inner_width"}, hint="the standard uses 0.05 and 0.5")
        if not 0.0 < self.phase_window < 0.5:
            raise ConfigError(f"phase_window must lie in (0, 0.5), got {self.phase_window}",
                              where={"key": "phase_window"}, hint="the standard uses 0.2")
        if not 0.0 < self.dtw_band <= 1.0:
            raise ConfigError(f"dtw_band must lie in (0, 1], got {self.dtw_band}",
                              where={"key": "dtw_band"}, hint="the standard uses 0.1")
        for key in ("magnitude_limit", "slope_limit", "corridor_exponent", "phase_exponent",
                    "magnitude_exponent", "slope_exponent"):
            if not getattr(self, key) > 0.0:
                raise ConfigError(f"{key} must be positive, got {getattr(self, key)}",
                                  where={"key": key}, hint="use the standard's default")
        if len(self.weights) != 4 or min(self.weights) < 0 or not math.isclose(sum(self.weights),
                                                                              1.0):
            raise ConfigError(f"weights must be four non-negative numbers summing to 1, got "
                              f"{self.weights}", where={"key": "weights"},
                              hint="the standard uses (0.4, 0.2, 0.2, 0.2)")


@dataclasses.dataclass(frozen=True)
class IsoScores(Scores):
    """Result of an ISO/TS 18571 rating.

    Attributes
    ----------
    rating : float
        Overall rating ``R`` in [0, 1].
    grade : str
        ``"excellent"``, ``"good"``, ``"fair"`` or ``"poor"``.
    corridor, phase, magnitude, slope : float
        The sub-scores ``Z``, ``E_P``, ``E_M``, ``E_S`` in [0, 1].
    shift_samples : int
        Shift found by the phase score, samples; positive when the model lags (is delayed).
    shift : float
        The same shift in s (:func:`iso18571`) or in degrees of shaft angle
        (:func:`iso18571_periodic`).
    n_samples : int
        Samples rated (fewer than given when a long signal was resampled).
    """

    rating: float
    grade: str
    corridor: float
    phase: float
    magnitude: float
    slope: float
    shift_samples: int
    shift: float
    n_samples: int


def grade(rating: float) -> str:
    """Return the ISO/TS 18571 grade of a rating.

    Parameters
    ----------
    rating : float
        Overall rating in [0, 1].

    Returns
    -------
    str
        ``"excellent"`` (R > 0.94), ``"good"`` (R > 0.80), ``"fair"`` (R > 0.58) or ``"poor"``.
    """
    for limit, name in GRADES:
        if rating > limit:
            return name
    return "poor"


def iso18571(measured: Any, model: Any, *, dt: float | None = None, fs: float | None = None,
             params: IsoParameters | None = None,
             max_samples: int = DEFAULT_MAX_SAMPLES) -> IsoScores:
    """Rate a model time signal against the measured one by ISO/TS 18571.

    Parameters
    ----------
    measured : array_like or xarray.DataArray
        Reference signal ``T`` (any units), uniformly sampled over the interval of evaluation,
        pre-filtered as the standard expects (ISO 6487 / SAE J211 CFC in crash practice).
    model : array_like or xarray.DataArray
        Comparison signal ``C`` on the same samples and in the same units.
    dt : float, optional
        Sample spacing, s. Give ``dt`` or ``fs``; with neither, a DataArray's single coordinate
        supplies it.
    fs : float, optional
        Sampling rate, Hz.
    params : IsoParameters, optional
        Rating parameters; the standard's by default.
    max_samples : int
        Longer signals are decimated by the smallest integer factor that brings them to at most
        this many samples (zero-phase FIR anti-alias filter) before rating.

    Returns
    -------
    IsoScores
        Rating, grade, sub-scores and the phase shift (``shift`` in s).

    Raises
    ------
    DataError
        On bad samples, unequal lengths, fewer than 16 samples or an all-zero reference.
    ConfigError
        If the sample spacing is missing, ambiguous or not positive.

    Notes
    -----
    Not symmetric: the measured signal is the reference. The standard sets no rule for the interval
    of evaluation; cut both signals to it before calling.
    """
    params = params or IsoParameters()
    step = _sample_spacing(measured, dt, fs)
    reference, comparison = paired(measured, model)
    factor = math.ceil(reference.size / max_samples)
    if factor > 1:
        logger.info("ISO 18571: decimating %d samples by %d (max_samples=%d)", reference.size,
                    factor, max_samples)
        reference = decimate(reference, factor, ftype="fir", zero_phase=True)
        comparison = decimate(comparison, factor, ftype="fir", zero_phase=True)
        step *= factor
    _check_reference(reference)
    n = reference.size
    limit = int(np.floor(n * params.phase_window))
    shifts, rho = _overlap_correlation(reference, comparison, limit)
    shift = int(_best_shifts(shifts, rho[np.newaxis])[0])
    if shift >= 0:
        ref_part, cmp_part = reference[:n - shift], comparison[shift:]
    else:
        ref_part, cmp_part = reference[-shift:], comparison[:n + shift]
    slope_ref, slope_cmp = _smoothed_slope(ref_part), _smoothed_slope(cmp_part)
    magnitude_error = _magnitude_error(ref_part, cmp_part, params)
    return _scores(reference, comparison[np.newaxis], np.array([magnitude_error]), slope_ref,
                   slope_cmp[np.newaxis], np.array([shift]), np.array([shift * step]), params)[0]


def iso18571_periodic(measured: Any, model: Any, angle: Any = None, *,
                      params: IsoParameters | None = None,
                      max_samples: int = DEFAULT_MAX_SAMPLES) -> IsoScores:
    """Rate a model signal over one revolution against the measured one (periodic ISO variant).

    The signals hold one revolution on a uniform angle grid without the repeated end sample
    (``angle[k] = k * 360 / n`` degrees). The corridor and all scoring formulas are those of
    ISO/TS 18571. The phase shift is circular (Pearson correlation of all samples with the model
    rotated by up to ``phase_window`` of a revolution; nothing is truncated); the magnitude is the
    DTW error over the middle of three repeated revolutions (the path's fixed ends lie a
    revolution away); the slope uses circular central differences and a circular 9-point mean.

    Parameters
    ----------
    measured : array_like or xarray.DataArray
        Reference signal over one revolution (any units).
    model : array_like or xarray.DataArray
        Model signal on the same angle grid, same units.
    angle : array_like, optional
        Shaft angle of the samples, rad; checked to be one uniform revolution when given (or when
        ``measured`` is a DataArray with an ``angle`` coordinate).
    params : IsoParameters, optional
        Rating parameters; the standard's by default.
    max_samples : int
        Longer signals are Fourier-resampled to this many samples before rating.

    Returns
    -------
    IsoScores
        Rating, grade, sub-scores and the phase shift (``shift`` in degrees, positive when the
        model lags).

    Raises
    ------
    DataError
        On bad samples, unequal lengths, a bad angle grid, fewer than 16 samples or an all-zero
        reference.
    """
    params = params or IsoParameters()
    reference, comparison = paired(measured, model)
    revolution_angle(angle, reference.size, measured)
    return _rate_periodic(reference, comparison[np.newaxis], params, max_samples)[0]


def iso18571_periodic_many(measured: Any, models: Any, angle: Any = None, *,
                           params: IsoParameters | None = None,
                           max_samples: int = DEFAULT_MAX_SAMPLES) -> list[IsoScores]:
    """Rate several model signals over one revolution against one measured signal.

    The result equals ``[iso18571_periodic(measured, model, angle, ...) for model in models]``
    (each row sees the same operations as alone; the tests check the scores to 1e-12) but every
    step runs on all rows at once: the phase shifts by one batched FFT, the DTW swept and
    backtracked for all pairs together (:func:`rigval.processing.dtw.dtw_paths`, whose
    Python-level loops over anti-diagonals and path steps hardly grow with the number of signals).
    :func:`rigval.validation.metrics.compare.baseline` rates every measured cycle against the
    cycle mean with it.

    Parameters
    ----------
    measured : array_like or xarray.DataArray
        Reference signal over one revolution (any units).
    models : array_like
        Signals to rate, shape ``(m, n)``, on the reference's angle grid and in its units.
    angle, params, max_samples
        As for :func:`iso18571_periodic` (shaft angle in rad, rating parameters, resampling
        limit).

    Returns
    -------
    list of IsoScores
        One result per row of ``models``, in order.

    Raises
    ------
    DataError
        If ``models`` is not 2-D or holds no signal, or as :func:`iso18571_periodic`.
    """
    params = params or IsoParameters()
    reference, stack = _checked_many(measured, models, angle)
    return _rate_periodic(reference, stack, params, max_samples)


def iso18571_periodic_sets(sets: Sequence[tuple[Any, Any]], *,
                           params: IsoParameters | None = None,
                           max_samples: int = DEFAULT_MAX_SAMPLES) -> list[list[IsoScores]]:
    """Rate several sets of model signals, each set against its own measured signal.

    The result equals ``[iso18571_periodic_many(measured, models, ...) for measured, models in
    sets]``, but sets of one sample count share their DTW sweeps (up to
    :data:`ROWS_PER_SWEEP` rows a sweep): a sweep's Python-level loop runs once per
    anti-diagonal whatever the number of rows, so one sweep of a few dozen rows costs about as
    much as one of a single row. A run's comparisons (each its model and its revolutions
    against its measured mean) are rated this way.

    Parameters
    ----------
    sets : sequence of (measured, models)
        Per set, the reference signal over one revolution and the signals rated against it,
        shape ``(m, n)``, as for :func:`iso18571_periodic_many`.
    params, max_samples
        As for :func:`iso18571_periodic`.

    Returns
    -------
    list of list of IsoScores
        Per set, one result per row of its ``models``, in order.

    Raises
    ------
    DataError
        As :func:`iso18571_periodic_many`, for the first set that fails.
    """
    params = params or IsoParameters()
    prepared = [_prepared(*_checked_many(measured, models), params, max_samples)
                for measured, models in sets]
    errors = _magnitude_errors_circular(prepared, params)
    return [_rated(p, e, params) for p, e in zip(prepared, errors, strict=True)]


def _checked_many(measured: Any, models: Any, angle: Any = None) -> tuple[np.ndarray, np.ndarray]:
    """Return the checked reference and model stack of :func:`iso18571_periodic_many`.

    The stack is the models' values themselves (float64, C order: a copy only where they are
    not), never written to; its rows are checked as :func:`paired` checks a pair, at once, and
    one by one only where one is not finite, so that the error is the first bad row's.
    """
    stack = np.ascontiguousarray(getattr(models, "values", models), dtype=np.float64)
    if stack.ndim != 2 or stack.shape[0] == 0:
        raise DataError(f"models must have shape (m >= 1, n_samples), got {stack.shape}",
                        where={"signal": "model"}, hint="stack the model signals row by row")
    reference, _ = paired(measured, stack[0])
    if not np.isfinite(stack).all():
        for row in stack:
            paired(measured, row)
    revolution_angle(angle, reference.size, measured)
    return reference, stack


@dataclasses.dataclass(frozen=True)
class _Prepared:
    """A set of signals rated against one reference, up to the DTW (checked, resampled)."""

    reference: np.ndarray
    comparisons: np.ndarray
    shifts: np.ndarray

    def rotated(self, rows: slice = slice(None)) -> np.ndarray:
        """Return the rows rotated back by their shifts: ``comparisons[p, (i + shift_p) % n]``.

        Made when asked for, not held: a run's sets each hold as many rows as it has
        revolutions, and their DTW sweeps take them a batch at a time (memory). ``rows``: those
        rows alone.
        """
        n = self.reference.size
        return np.take_along_axis(self.comparisons[rows],
                                  (np.arange(n) + self.shifts[rows, np.newaxis]) % n, axis=1)


def _prepared(reference: np.ndarray, comparisons: np.ndarray, params: IsoParameters,
              max_samples: int) -> _Prepared:
    """Resample, check, and find each row's circular phase shift (checked inputs)."""
    if reference.size > max_samples:
        logger.info("ISO 18571 periodic: resampling %d samples to %d", reference.size,
                    max_samples)
        reference = resample(reference, max_samples)
        comparisons = np.array([resample(row, max_samples) for row in comparisons])
    _check_reference(reference)
    n = reference.size
    limit = int(np.floor(n * params.phase_window))
    shifts = _best_shifts(*_circular_correlation(reference, comparisons, limit))
    return _Prepared(reference, comparisons, shifts)


def _rated(prepared: _Prepared, magnitude_errors: list[float],
           params: IsoParameters) -> list[IsoScores]:
    """Return the scores of a prepared set, given its rows' DTW magnitude errors."""
    n = prepared.reference.size
    return _scores(prepared.reference, prepared.comparisons, np.asarray(magnitude_errors),
                   _smoothed_slope_circular(prepared.reference),
                   _smoothed_slope_circular(prepared.rotated()), prepared.shifts,
                   prepared.shifts * 360.0 / n, params)


def _rate_periodic(reference: np.ndarray, comparisons: np.ndarray, params: IsoParameters,
                   max_samples: int) -> list[IsoScores]:
    """Periodic ISO rating of each row of ``comparisons`` against ``reference`` (checked inputs)."""
    prepared = _prepared(reference, comparisons, params, max_samples)
    return _rated(prepared, _magnitude_errors_circular([prepared], params)[0], params)


def _sample_spacing(measured: Any, dt: float | None, fs: float | None) -> float:
    """Return the sample spacing from ``dt``, ``fs`` or a DataArray coordinate, s."""
    if dt is not None and fs is not None:
        raise ConfigError("give the sample spacing once: dt or fs, not both",
                          where={"key": "dt"}, hint="drop one of them")
    if fs is not None:
        if not (np.isfinite(fs) and fs > 0):
            raise ConfigError(f"the sampling rate must be positive, got fs = {fs}",
                              where={"key": "fs"}, hint="pass fs in Hz or dt in s")
        dt = 1.0 / fs
    if dt is None:
        coords = getattr(measured, "coords", {})
        dims = getattr(measured, "dims", ())
        if len(dims) == 1 and dims[0] in coords and coords[dims[0]].size > 1:
            axis = np.asarray(coords[dims[0]].values, dtype=np.float64)
            dt = float(np.mean(np.diff(axis)))
        else:
            raise ConfigError("the sample spacing is missing", where={"key": "dt"},
                              hint="pass dt (s) or fs (Hz), or a DataArray with a time coordinate")
    if not (np.isfinite(dt) and dt > 0):
        raise ConfigError(f"the sample spacing must be positive, got dt = {dt}",
                          where={"key": "dt"}, hint="pass dt in s or fs in Hz")
    return float(dt)


def _check_reference(reference: np.ndarray) -> None:
    """Raise DataError if the reference is too short or zero everywhere."""
    if reference.size < MIN_ISO_SAMPLES:
        raise DataError(f"ISO 18571 needs at least {MIN_ISO_SAMPLES} samples, got "
                        f"{reference.size}", where={"signal": "measured"},
                        hint="rate a longer interval or sample it more finely")
    if not np.any(reference):
        raise DataError("the measured signal is zero everywhere: its corridors have zero width",
                        where={"signal": "measured"},
                        hint="ISO rating needs a reference with a non-zero peak")


def _overlap_correlation(reference: np.ndarray, comparison: np.ndarray,
                         limit: int) -> tuple[np.ndarray, np.ndarray]:
    """Pearson correlation of the overlapping parts for shifts -limit..limit.

    Shift ``m > 0`` pairs ``reference[i]`` with ``comparison[i + m]`` (the model lags). All shifts
    at once: the cross products from one FFT correlation, the partial sums from cumulative sums.
    Shifts whose overlap is constant get correlation -inf.
    """
    n = reference.size
    t = (reference - reference.mean()) / (reference.std() or 1.0)
    c = (comparison - comparison.mean()) / (comparison.std() or 1.0)
    shifts = np.arange(-limit, limit + 1)
    cross = correlate(c, t, mode="full")[n - 1 + shifts]
    ct, ct2 = _cumulative(t), _cumulative(t * t)
    cc, cc2 = _cumulative(c), _cumulative(c * c)
    lag = np.maximum(shifts, 0)
    lead = np.maximum(-shifts, 0)
    t_lo, t_hi = lead, n - lag
    c_lo, c_hi = lag, n - lead
    count = n - np.abs(shifts)
    sum_t, sum_t2 = ct[t_hi] - ct[t_lo], ct2[t_hi] - ct2[t_lo]
    sum_c, sum_c2 = cc[c_hi] - cc[c_lo], cc2[c_hi] - cc2[c_lo]
    covariance = cross - sum_t * sum_c / count
    variance_t = sum_t2 - sum_t**2 / count
    variance_c = sum_c2 - sum_c**2 / count
    return shifts, _ratio(covariance, variance_t, variance_c, count)


def _circular_correlation(reference: np.ndarray, comparisons: np.ndarray,
                          limit: int) -> tuple[np.ndarray, np.ndarray]:
    """Pearson correlation of the reference with each model rotated by -limit..limit samples.

    ``comparisons`` has shape ``(..., n)``; the correlations have shape ``(..., 2 limit + 1)``.
    """
    n = reference.size
    t = (reference - reference.mean()) / (reference.std() or 1.0)
    spread = comparisons.std(axis=-1, keepdims=True)
    c = (comparisons - comparisons.mean(axis=-1, keepdims=True)) / np.where(spread == 0.0, 1.0,
                                                                            spread)
    cross = np.fft.irfft(np.conj(np.fft.rfft(t)) * np.fft.rfft(c, axis=-1), n, axis=-1)
    shifts = np.arange(-limit, limit + 1)
    return shifts, _ratio(cross[..., shifts % n], t @ t,
                          row_dot(c.reshape(-1, n), c.reshape(-1, n)).reshape(
                              (*c.shape[:-1], 1)), n)


def _ratio(covariance: np.ndarray, variance_t: Any, variance_c: Any, count: Any) -> np.ndarray:
    """Correlation coefficient of unit-variance signals; -inf where a part is (nearly) constant.

    The arguments broadcast against each other.
    """
    tiny = 1e-12 * np.asarray(count)
    valid = (variance_t > tiny) & (variance_c > tiny)
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = covariance / np.sqrt(variance_t * variance_c)
    return np.where(valid, rho, -np.inf)


def _cumulative(values: np.ndarray) -> np.ndarray:
    """Cumulative sum with a leading zero, so that ``s[b] - s[a]`` sums ``values[a:b]``."""
    return np.concatenate(([0.0], np.cumsum(values)))


def _best_shifts(shifts: np.ndarray, rho: np.ndarray) -> np.ndarray:
    """Shift of the highest correlation of each row of ``rho`` (one column per shift).

    Correlations within :data:`_TIE_TOLERANCE` of a row's best tie; ties go to the smaller
    shift, then to the model lagging. A row without a finite correlation gets shift 0.
    """
    order = np.array(sorted(range(shifts.size), key=lambda k: (abs(shifts[k]), shifts[k] < 0)))
    best = np.max(rho, axis=-1, keepdims=True)
    tied = rho[..., order] >= best - _TIE_TOLERANCE
    chosen = shifts[order][np.argmax(tied, axis=-1)]
    return np.where(np.isfinite(rho).any(axis=-1), chosen, 0)


def _smoothed_slope(values: np.ndarray) -> np.ndarray:
    """Central-difference derivative (one-sided at the ends) smoothed by a centred 9-point mean.

    The window shrinks to 1, 3, 5, 7 points at the ends so that it stays centred (ISO/TS 18571).
    The derivative is per sample: the scores use ratios of slopes, so the spacing cancels.
    """
    derivative = np.gradient(values)
    n = derivative.size
    index = np.arange(n)
    half = np.minimum(np.minimum(index, n - 1 - index), _SLOPE_HALF_WIDTH)
    sums = _cumulative(derivative)
    return (sums[index + half + 1] - sums[index - half]) / (2 * half + 1)


def _smoothed_slope_circular(values: np.ndarray) -> np.ndarray:
    """Circular central-difference derivative smoothed by a circular 9-point mean (last axis)."""
    derivative = 0.5 * (np.roll(values, -1, axis=-1) - np.roll(values, 1, axis=-1))
    h = _SLOPE_HALF_WIDTH
    n = values.shape[-1]
    wrapped = np.concatenate((derivative[..., -h:], derivative, derivative[..., :h]), axis=-1)
    weight = 1.0 / (2 * h + 1)
    smoothed = wrapped[..., :n] * weight
    for offset in range(1, 2 * h + 1):
        smoothed += wrapped[..., offset:offset + n] * weight
    return smoothed


def _scores(reference: np.ndarray, comparisons: np.ndarray, magnitude_errors: np.ndarray,
            slope_ref: np.ndarray, slope_cmp: np.ndarray, shifts: np.ndarray,
            shift_values: np.ndarray, params: IsoParameters) -> list[IsoScores]:
    """Combine the four ISO sub-scores of each row of ``comparisons`` into its result."""
    n = reference.size
    corridor = _corridor_scores(reference, comparisons, params)
    phase = _limited_scores(np.abs(shifts), params.phase_window * n, params.phase_exponent)
    magnitude = _limited_scores(np.asarray(magnitude_errors), params.magnitude_limit,
                                params.magnitude_exponent)
    slope_error = _relative_l1(slope_cmp, slope_ref, "slope")
    slope = _limited_scores(slope_error, params.slope_limit, params.slope_exponent)
    w_z, w_p, w_m, w_s = params.weights
    rating = w_z * corridor + w_p * phase + w_m * magnitude + w_s * slope
    return [IsoScores(rating=float(rating[p]), grade=grade(rating[p]),
                      corridor=float(corridor[p]), phase=float(phase[p]),
                      magnitude=float(magnitude[p]), slope=float(slope[p]),
                      shift_samples=int(shifts[p]), shift=float(shift_values[p]), n_samples=n)
            for p in range(comparisons.shape[0])]


def _band_radius(n: int, params: IsoParameters) -> int:
    """DTW band half-width: cells with ``|i - j| < ceil(dtw_band n)``."""
    return max(math.ceil(params.dtw_band * n) - 1, 0)


def _magnitude_error(reference: np.ndarray, comparison: np.ndarray,
                     params: IsoParameters) -> float:
    """Relative L1 error of the DTW-warped pair (ISO/TS 18571 magnitude)."""
    ix, iy = dtw_path(comparison, reference, _band_radius(reference.size, params))
    return _relative_l1(comparison[ix], reference[iy], "magnitude")


def _magnitude_errors_circular(sets: Sequence[_Prepared],
                               params: IsoParameters) -> list[list[float]]:
    """Relative L1 error of each DTW-warped pair over one revolution, free of the path's anchors.

    Per set, each rotated row against the set's reference. Both signals are repeated to three
    revolutions, so that the path's fixed start and end lie a revolution away from the middle
    one; the path cells whose measured sample lies in the middle revolution are scored. (Two
    band widths of margin were not enough: on dissimilar signals the anchors still moved E_M by
    up to 0.3; half a revolution moved it by up to 0.14.) One DTW sweep serves the rows of
    several sets (:func:`_sweeps`).
    """
    errors: list[list[float]] = [[] for _ in sets]
    sweeps = _sweeps(sets)
    # one work space for all sweeps (the largest's): its pages are faulted in once
    workspace = np.empty(max((workspace_size(sum(sets[i].comparisons.shape[0] for i in sweep),
                                             3 * sets[sweep[0]].reference.size,
                                             _band_radius(sets[sweep[0]].reference.size, params))
                              for sweep in sweeps), default=0), dtype=np.uint8)
    for sweep in sweeps:
        for i, errors_of_set in zip(sweep, _sweep_errors([sets[i] for i in sweep], params,
                                                         workspace), strict=True):
            errors[i] = errors_of_set
    return errors


def _sweep_errors(sets: Sequence[_Prepared], params: IsoParameters,
                  workspace: np.ndarray) -> list[list[float]]:
    """:func:`_magnitude_errors_circular` of the sets of one DTW sweep (one sample count).

    A function of its own, so that a sweep's rows, three revolutions long, are let go before
    the next sweep's are made (memory); a set swept alone is swept a DTW batch of rows at a
    time (:func:`_set_errors`).
    """
    n = sets[0].reference.size
    radius = _band_radius(n, params)
    if len(sets) == 1:
        return [_set_errors(sets[0], radius, workspace)]
    rotated = [prepared.rotated() for prepared in sets]
    rows = np.concatenate([np.tile(one, 3) for one in rotated])
    # one reference per row
    references = np.concatenate([np.broadcast_to(np.tile(prepared.reference, 3),
                                                 (one.shape[0], 3 * n))
                                 for prepared, one in zip(sets, rotated, strict=True)])
    paths = dtw_paths(rows, references, radius, y_from=n, workspace=workspace)
    return [_path_errors(prepared.reference, one, itertools.islice(paths, one.shape[0]))
            for prepared, one in zip(sets, rotated, strict=True)]


def _set_errors(prepared: _Prepared, radius: int, workspace: np.ndarray) -> list[float]:
    """:func:`_sweep_errors` of a set swept alone, a DTW batch of its rows at a time.

    The rows are handed to :func:`~rigval.processing.dtw.dtw_paths` in its own batches
    (:func:`~rigval.processing.dtw.pairs_per_batch`), so the paths are those of all rows at
    once, and only a batch's rows, rotated and tiled to three revolutions, are held (a long
    record's set holds one row per revolution: memory).
    """
    n, count = prepared.reference.size, prepared.comparisons.shape[0]
    reference = np.tile(prepared.reference, 3)[np.newaxis]  # spread over the rows by dtw_paths
    step = pairs_per_batch(count, 3 * n, radius)
    errors: list[float] = []
    for lo in range(0, count, step):
        rows = prepared.rotated(slice(lo, lo + step))
        errors += _path_errors(prepared.reference, rows,
                               dtw_paths(np.tile(rows, 3), reference, radius, y_from=n,
                                         workspace=workspace))
    return errors


def _path_errors(reference: np.ndarray, rows: np.ndarray,
                 paths: Iterable[tuple[np.ndarray, np.ndarray]]) -> list[float]:
    """Relative L1 error of each rotated row along its DTW path, within the middle revolution.

    ``paths`` are the rows' paths over three revolutions, one per row in order.
    """
    n = reference.size
    errors = []
    for comparison, (ix, iy) in zip(rows, paths, strict=True):
        inside = (iy >= n) & (iy < 2 * n)
        errors.append(_relative_l1(comparison[ix[inside] % n], reference[iy[inside] % n],
                                   "magnitude"))
    return errors


def _sweeps(sets: Sequence[_Prepared]) -> list[list[int]]:
    """Group the sets into DTW sweeps: one sample count each, filled to :data:`ROWS_PER_SWEEP`.

    A set of more rows than that is a sweep of its own (:func:`rigval.processing.dtw.dtw_paths`
    bounds its memory batch by batch).
    """
    sweeps: list[list[int]] = []
    filling: dict[int, tuple[list[int], int]] = {}
    for i, prepared in enumerate(sets):
        n, count = prepared.reference.size, prepared.comparisons.shape[0]
        members, rows = filling.get(n, ([], 0))
        if not members or rows + count > ROWS_PER_SWEEP:
            members, rows = [], 0
            sweeps.append(members)
        members.append(i)
        filling[n] = members, rows + count
    return sweeps


def _corridor_scores(reference: np.ndarray, comparisons: np.ndarray,
                     params: IsoParameters) -> np.ndarray:
    """Mean corridor score of each row (1 inside the inner corridor, 0 outside the outer)."""
    peak = np.max(np.abs(reference))
    inner, outer = params.inner_width * peak, params.outer_width * peak
    distance = np.abs(comparisons - reference)
    between = np.clip((outer - distance) / (outer - inner), 0.0, 1.0)
    return np.mean(between ** params.corridor_exponent, axis=-1)


def _limited_scores(error: np.ndarray, limit: float, exponent: float) -> np.ndarray:
    """``((limit - error) / limit) ** exponent`` for ``0 <= error < limit``; 1 at 0, 0 beyond."""
    inside = np.clip(error, 0.0, limit)
    return np.where(error <= 0.0, 1.0,
                    np.where(error >= limit, 0.0, ((limit - inside) / limit) ** exponent))


def _relative_l1(comparison: np.ndarray, reference: np.ndarray, what: str) -> Any:
    """``||comparison - reference||_1 / ||reference||_1`` over the last axis.

    A float for 1-D ``comparison``, one value per row for 2-D; DataError if the reference is
    zero.
    """
    norm = np.sum(np.abs(reference))
    if norm == 0.0:
        raise DataError(f"the measured signal's {what} is zero over the rated interval",
                        where={"signal": "measured"},
                        hint="ISO rating needs a reference that varies over the interval")
    error = np.sum(np.abs(comparison - reference), axis=-1) / norm
    return float(error) if error.ndim == 0 else error
