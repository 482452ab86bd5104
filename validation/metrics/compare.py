"""Objective comparison of a measured and a model signal: every metric, by name, in one place.

The metric functions (each returns a frozen record with ``as_dict()``):

=========================  ========================================================================
:func:`iso18571`           ISO/TS 18571 rating of time signals (corridor, phase, magnitude, slope)
:func:`iso18571_periodic`  the same over one revolution (circular shift, no end effects)
:func:`sprague_geers`      Sprague & Geers magnitude, phase, comprehensive
:func:`russell`            Russell magnitude, phase, comprehensive
:func:`nrmse`              RMSE normalised by the measured range, RMS or peak (named in the result)
:func:`pearson_r`          Pearson correlation
:func:`peak_error`         peak value error and the location of the peaks
:func:`circular_lag`       lag of the model over one revolution by circular cross-correlation, deg
:func:`vv20`               ASME V&V 20 comparison error and validation uncertainty, peak and RMS
=========================  ========================================================================

:func:`compare` runs a chosen set of them on one revolution and returns one flat dict of scores;
:func:`baseline` runs the same set on each measured cycle against the cycle mean (the
cycle-to-cycle scatter a model is judged against); :func:`check_thresholds` applies pass/fail
thresholds. Definitions, ranges and grades: ``docs/metrics.md``.
"""

from __future__ import annotations

import dataclasses
import functools
import logging
import typing
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from rigval.acquisition.errors import ConfigError, DataError
from rigval.validation.metrics.core import Scores, as_cycles, as_signal, paired, revolution_angle
from rigval.validation.metrics.iso18571 import (
    IsoParameters,
    IsoScores,
    grade,
    iso18571,
    iso18571_periodic,
    iso18571_periodic_many,
    iso18571_periodic_sets,
)
from rigval.validation.metrics.thresholds import ThresholdCheck, check_thresholds, parse_threshold
from rigval.validation.metrics.vv20 import VV20Curve, VV20Feature, VV20Scores, vv20, vv20_curve
from rigval.validation.metrics.waveform import (
    LagScores,
    NrmseScores,
    PeakScores,
    PearsonScores,
    RussellScores,
    SpragueGeersScores,
    circular_lag,
    circular_lag_many,
    magnitude_phase_many,
    nrmse,
    nrmse_many,
    peak_error,
    peak_error_many,
    pearson_r,
    pearson_r_many,
    russell,
    sprague_geers,
)

__all__ = [
    "DEFAULT_METRICS",
    "METRICS",
    "SCORE_ROWS",
    "SCORE_TYPES",
    "BaselineScores",
    "IsoParameters",
    "IsoScores",
    "LagScores",
    "NrmseScores",
    "PeakScores",
    "PearsonScores",
    "RussellScores",
    "Scores",
    "SpragueGeersScores",
    "ThresholdCheck",
    "VV20Curve",
    "VV20Feature",
    "VV20Scores",
    "baseline",
    "check_thresholds",
    "circular_lag",
    "compare",
    "grade",
    "iso18571",
    "iso18571_periodic",
    "nrmse",
    "orientation",
    "parse_threshold",
    "peak_error",
    "pearson_r",
    "periodic_ratings",
    "russell",
    "score_names",
    "sprague_geers",
    "vv20",
    "vv20_curve",
]

logger = logging.getLogger(__name__)

METRICS: tuple[str, ...] = ("iso18571_periodic", "iso18571", "sprague_geers", "russell", "nrmse",
                            "pearson_r", "peak_error", "circular_lag", "vv20")
"""Metric names :func:`compare` knows."""

DEFAULT_METRICS: tuple[str, ...] = ("iso18571_periodic", "sprague_geers", "russell", "nrmse",
                                    "pearson_r", "peak_error", "circular_lag")
"""Metrics :func:`compare` runs unless told otherwise (V&V 20 needs stated uncertainties)."""

SCORE_TYPES: Mapping[str, type[Scores]] = {
    "iso18571_periodic": IsoScores, "iso18571": IsoScores, "sprague_geers": SpragueGeersScores,
    "russell": RussellScores, "nrmse": NrmseScores, "pearson_r": PearsonScores,
    "peak_error": PeakScores, "circular_lag": LagScores, "vv20": VV20Scores}
"""The score dataclass each metric returns; its fields name the metric's scores."""

_UNCERTAINTY_OPTIONS = ("u_num", "u_input", "u_measurement", "u_measurement_rel",
                        "u_measurement_rel_common", "k", "u_time",
                        "speed", "u_drive_angle")

_HIGHER = ("iso18571_periodic.rating", "iso18571_periodic.corridor", "iso18571_periodic.phase",
           "iso18571_periodic.magnitude", "iso18571_periodic.slope", "iso18571.rating",
           "iso18571.corridor", "iso18571.phase", "iso18571.magnitude", "iso18571.slope",
           "pearson_r", "circular_lag.correlation")
_LOWER = ("sprague_geers.phase", "sprague_geers.comprehensive", "russell.phase",
          "russell.comprehensive", "nrmse", "nrmse.rmse", "vv20.curve.error",
          "vv20.curve.normalised_error")
_NEAR_ZERO = ("iso18571_periodic.shift_samples", "iso18571_periodic.shift",
              "iso18571.shift_samples", "iso18571.shift", "sprague_geers.magnitude",
              "russell.magnitude", "peak_error.error", "peak_error.relative_error",
              "peak_error.shift", "circular_lag.lag_deg", "vv20.peak.error",
              "vv20.peak.normalised_error", "vv20.rms.error", "vv20.rms.normalised_error",
              "vv20.curve.gain")
_ORIENTATION = (dict.fromkeys(_HIGHER, "higher") | dict.fromkeys(_LOWER, "lower")
                | dict.fromkeys(_NEAR_ZERO, "near_zero"))


def orientation(score: str) -> str | None:
    """Return which way a score improves.

    Parameters
    ----------
    score : str
        Score name as :func:`compare` gives it.

    Returns
    -------
    str or None
        ``"higher"`` (1 is perfect), ``"lower"`` (0 is perfect), ``"near_zero"`` (signed, 0 is
        perfect) or None for descriptive values (peak values and locations, sample counts,
        uncertainties, names).
    """
    return _ORIENTATION.get(score)


@dataclasses.dataclass(frozen=True, eq=False)
class BaselineScores:
    """Scores of each measured cycle against the measured cycle mean.

    Attributes
    ----------
    n_cycles : int
        Cycles compared.
    per_cycle : dict of str to numpy.ndarray
        Every numeric score of :func:`compare`, one value per cycle.
    median : dict of str to float
        Median over the cycles of every numeric score.
    worst : dict of str to float
        The worst cycle's value of every score with an :func:`orientation` (lowest of "higher",
        highest of "lower", largest magnitude of "near_zero", sign kept).
    worst_cycle : dict of str to int
        Index of that cycle.
    """

    n_cycles: int
    per_cycle: dict[str, np.ndarray]
    median: dict[str, float]
    worst: dict[str, float]
    worst_cycle: dict[str, int]

    def as_dict(self) -> dict[str, Any]:
        """Return the summary by name (per-cycle arrays left out).

        Returns
        -------
        dict
            ``{"n_cycles": int, "median": {...}, "worst": {...}, "worst_cycle": {...}}``, with the
            same score names as :func:`compare`.
        """
        return {"n_cycles": self.n_cycles, "median": dict(self.median),
                "worst": dict(self.worst), "worst_cycle": dict(self.worst_cycle)}


def compare(measured: Any, model: Any, angle: Any = None, *,
            metrics: Sequence[str] = DEFAULT_METRICS, normaliser: str = "range",
            iso_params: IsoParameters | None = None, cycles: Any = None,
            uncertainty: Mapping[str, Any] | None = None,
            iso: IsoScores | None = None) -> dict[str, Any]:
    """Run several metrics on a measured and a model signal over one revolution.

    Parameters
    ----------
    measured : array_like or xarray.DataArray
        Measured signal (usually the cycle mean) over one revolution of the shaft.
    model : array_like or xarray.DataArray
        Model signal on the same angle grid, same units.
    angle : array_like, optional
        Shaft angle of the samples, rad, uniform over one revolution without the repeated end
        sample. Defaults to a DataArray's ``angle`` coordinate, else ``k * 2 pi / n``.
    metrics : sequence of str
        Names from :data:`METRICS`; :data:`DEFAULT_METRICS` by default.
    normaliser : {"range", "rms", "peak"}
        NRMSE normaliser.
    iso_params : IsoParameters, optional
        ISO rating parameters (the standard's by default).
    cycles : array_like, optional
        Measured cycles ``(n_cycles, n)``, for the random part of the V&V 20 data uncertainty.
    uncertainty : mapping, optional
        Keyword arguments of :func:`vv20` (``u_num``, ``u_input``, ``u_measurement``,
        ``u_measurement_rel``, ``k``, ``u_time``, ``speed``, ``u_drive_angle``).
    iso : IsoScores, optional
        This pair's ``iso18571_periodic`` rating, computed beforehand (:func:`periodic_ratings`
        rates a run's comparisons in shared DTW sweeps); default: computed here.

    Returns
    -------
    dict
        Score name to value. A score is named ``"<metric>.<field>"``, or just ``"<metric>"`` for
        the field that carries the metric's name (``"nrmse"``, ``"pearson_r"``). Angles are in
        degrees: ``peak_error.measured_at``, ``peak_error.model_at``, ``peak_error.shift``,
        ``circular_lag.lag_deg``, ``iso18571_periodic.shift``. Sprague-Geers and Russell use the
        rectangle rule of one period.

    Raises
    ------
    ConfigError
        For an unknown metric name or option.
    DataError
        For bad samples, unequal lengths or an angle grid that is not one revolution.
    """
    _check_options(metrics, uncertainty)
    m, c = paired(measured, model)
    angle_deg = np.degrees(revolution_angle(angle, m.size, measured))
    return _score_pair(m, c, angle_deg, metrics=metrics, normaliser=normaliser,
                       iso_params=iso_params, cycles=cycles, uncertainty=uncertainty, iso=iso)


def _score_key(metric: str, field: str) -> str:
    """Return a score's name: ``"<metric>.<field>"``, or the metric's name for its own field."""
    return metric if field == metric else f"{metric}.{field}"


@functools.cache
def _numeric_fields(cls: type[Scores]) -> tuple[str, ...]:
    """Names of the int and float fields of a score dataclass, nested ones as ``a.b``."""
    hints = typing.get_type_hints(cls)
    names: list[str] = []
    for field in dataclasses.fields(cls):
        kind = hints[field.name]
        if isinstance(kind, type) and issubclass(kind, Scores):
            names += [f"{field.name}.{inner}" for inner in _numeric_fields(kind)]
        elif kind in (int, float):
            names.append(field.name)
    return tuple(names)


def score_names(metrics: Sequence[str]) -> tuple[str, ...]:
    """Return the names of the numeric scores :func:`compare` reports for some metrics.

    Read from the fields of the metrics' score dataclasses (:data:`SCORE_TYPES`), so nothing is
    computed.

    Parameters
    ----------
    metrics : sequence of str
        Names from :data:`METRICS`.

    Raises
    ------
    ConfigError
        For an unknown metric name.
    """
    _check_options(metrics, None)
    return tuple(_score_key(metric, field) for metric in metrics
                 for field in _numeric_fields(SCORE_TYPES[metric]))


def _check_options(metrics: Sequence[str], uncertainty: Mapping[str, Any] | None) -> None:
    """Raise ConfigError for an unknown metric name or uncertainty option."""
    unknown = [name for name in metrics if name not in METRICS]
    if unknown:
        raise ConfigError(f"unknown metric {unknown[0]!r}", where={"key": "metrics"},
                          hint=f"use names from: {', '.join(METRICS)}")
    unknown = sorted(set(uncertainty or {}) - set(_UNCERTAINTY_OPTIONS))
    if unknown:
        raise ConfigError(f"unknown uncertainty option {unknown[0]!r}",
                          where={"key": f"uncertainty.{unknown[0]}"},
                          hint=f"use: {', '.join(_UNCERTAINTY_OPTIONS)}")


def _score_pair(m: np.ndarray, c: np.ndarray, angle_deg: np.ndarray, *, metrics: Sequence[str],
                normaliser: str, iso_params: IsoParameters | None, cycles: Any = None,
                uncertainty: Mapping[str, Any] | None = None,
                iso: IsoScores | None = None) -> dict[str, Any]:
    """Return the scores of :func:`compare` for a checked pair."""
    runners = {
        "iso18571_periodic": lambda: iso or iso18571_periodic(m, c, params=iso_params),
        "iso18571": lambda: iso18571(m, c, dt=360.0 / m.size, params=iso_params),
        "sprague_geers": lambda: sprague_geers(m, c, periodic=True),
        "russell": lambda: russell(m, c, periodic=True),
        "nrmse": lambda: nrmse(m, c, normaliser=normaliser),
        "pearson_r": lambda: pearson_r(m, c),
        "peak_error": lambda: peak_error(m, c, angle_deg, period=360.0),
        "circular_lag": lambda: circular_lag(m, c),
        "vv20": lambda: vv20(m, c, cycles=cycles, **dict(uncertainty or {})),
    }
    scores: dict[str, Any] = {}
    for name in metrics:
        for field, value in runners[name]().as_dict().items():
            scores[_score_key(name, field)] = value
    return scores


def periodic_ratings(comparisons: Sequence[tuple[Any, Any, Any]], *,
                     iso_params: IsoParameters | None = None
                     ) -> list[tuple[IsoScores, list[IsoScores]]]:
    """Rate each comparison's model and cycles against its measured mean, in shared DTW sweeps.

    The ``iso18571_periodic`` ratings :func:`compare` and :func:`baseline` compute, for several
    comparisons at once (:func:`~rigval.validation.metrics.iso18571.iso18571_periodic_sets`): a
    sweep costs about as much for one row as for a few dozen, and a run has two small ones per
    comparison otherwise. Pass them on as ``compare(..., iso=model)`` and
    ``baseline(..., iso=cycles)``.

    Parameters
    ----------
    comparisons : sequence of (mean, model, cycles)
        Per comparison, the measured mean over one revolution, the model on its grid and the
        measured cycles ``(n_cycles, n)``, one unit.
    iso_params : IsoParameters, optional
        As for :func:`compare`.

    Returns
    -------
    list of (IsoScores, list of IsoScores)
        Per comparison, the model's rating and each cycle's.
    """
    # the model and the cycles as two sets, one after the other (their rows are rated one by
    # one, so as one stack would rate them): the cycles are rated as given, not copied below
    # the model's row (memory: a long record's revolutions)
    sets = [one for mean, model, cycles in comparisons
            for one in ((mean, np.asarray(model, dtype=np.float64)[np.newaxis]),
                        (mean, as_cycles(cycles)))]
    rated = iso18571_periodic_sets(sets, params=iso_params)
    return [(model[0], cycles) for model, cycles in zip(rated[::2], rated[1::2], strict=True)]


def baseline(cycles: Any, mean: Any = None, *, angle: Any = None,
             metrics: Sequence[str] = DEFAULT_METRICS, normaliser: str = "range",
             iso_params: IsoParameters | None = None,
             iso: Sequence[IsoScores] | None = None) -> BaselineScores:
    """Score each measured cycle against the measured cycle mean with the metrics of a comparison.

    Each cycle takes the model's place in :func:`compare`. The result is the cycle-to-cycle
    scatter expressed in the comparison's own scores: a model whose scores are no worse than the
    median cycle's agrees with the mean as well as a single measured revolution does.

    Parameters
    ----------
    cycles : array_like or xarray.DataArray
        Measured cycles, shape ``(n_cycles, n)`` over one revolution each (a DataArray with dims
        ``cycle`` and ``angle`` in any order).
    mean : array_like, optional
        The reference the cycles are compared with; their mean by default. Pass the same signal
        the model is compared with.
    angle : array_like, optional
        Shaft angle of the samples, rad (see :func:`compare`).
    metrics, normaliser, iso_params
        As for :func:`compare` (``vv20`` is not a per-cycle metric and is refused).
    iso : sequence of IsoScores, optional
        Each cycle's ``iso18571_periodic`` rating against ``mean``, computed beforehand
        (:func:`periodic_ratings`); default: computed here.

    Returns
    -------
    BaselineScores
        Per-cycle scores, their median and the worst cycle per score.

    Raises
    ------
    ConfigError
        For ``vv20`` or an unknown metric among ``metrics``.
    DataError
        For fewer than 2 cycles, NaN samples, shapes that do not match, or ``iso`` ratings of
        another number of cycles.

    Notes
    -----
    The mean contains each cycle with weight 1/n, so for n cycles the cycle-to-mean scatter is
    ``sqrt(1 - 1/n)`` of the cycle-to-cycle scatter: slightly optimistic for few cycles.
    """
    if "vv20" in metrics:
        raise ConfigError("vv20 compares features with uncertainties, not single cycles",
                          where={"key": "metrics"}, hint="leave vv20 out of the baseline")
    _check_options(metrics, None)
    array = as_cycles(cycles)
    if iso is not None and len(iso) != array.shape[0]:
        raise DataError(f"{len(iso)} ISO ratings given for {array.shape[0]} cycles",
                        where={"key": "iso"}, hint="rate the same cycles (periodic_ratings)")
    angle_deg = np.degrees(revolution_angle(angle, array.shape[1], cycles))
    reference = array.mean(axis=0) if mean is None else as_signal(mean, "mean")
    reference, _ = paired(reference, array[0])
    per_cycle = _score_cycles(reference, array, angle_deg, metrics=metrics,
                              normaliser=normaliser, iso_params=iso_params, iso=iso)
    median = {key: float(np.median(values)) for key, values in per_cycle.items()}
    worst, worst_cycle = {}, {}
    for key, values in per_cycle.items():
        direction = orientation(key)
        if direction is None:
            continue
        index = int({"higher": np.argmin(values), "lower": np.argmax(values),
                     "near_zero": np.argmax(np.abs(values))}[direction])
        worst[key], worst_cycle[key] = float(values[index]), index
    logger.debug("baseline over %d cycles: %d scores", array.shape[0], len(per_cycle))
    return BaselineScores(n_cycles=array.shape[0], per_cycle=per_cycle, median=median,
                          worst=worst, worst_cycle=worst_cycle)


#: Revolutions :func:`baseline` scores at once.
SCORE_ROWS = 1024


def _score_cycles(m: np.ndarray, cycles: np.ndarray, angle_deg: np.ndarray, *,
                  metrics: Sequence[str], normaliser: str, iso_params: IsoParameters | None,
                  iso: Sequence[IsoScores] | None = None) -> dict[str, np.ndarray]:
    """Every numeric score of :func:`compare` for each row of ``cycles`` against ``m``.

    The metrics run on :data:`SCORE_ROWS` rows at once (their ``*_many`` forms, each row's
    score its own, whatever rows beside it), so the scores are those of :func:`compare` on
    each row, computed by the same functions; a long record's revolutions are scored a block
    at a time (memory: the metrics' temporaries of a block of rows, not of every revolution).
    """
    blocks = [_score_block(m, cycles[lo:lo + SCORE_ROWS], angle_deg, metrics=metrics,
                           normaliser=normaliser, iso_params=iso_params,
                           iso=None if iso is None else iso[lo:lo + SCORE_ROWS])
              for lo in range(0, cycles.shape[0], SCORE_ROWS)]
    return {key: np.concatenate([block[key] for block in blocks]) for key in blocks[0]}


def _score_block(m: np.ndarray, cycles: np.ndarray, angle_deg: np.ndarray, *,
                 metrics: Sequence[str], normaliser: str, iso_params: IsoParameters | None,
                 iso: Sequence[IsoScores] | None = None) -> dict[str, np.ndarray]:
    """:func:`_score_cycles` of one block of rows."""
    def records(scores: Sequence[Scores]) -> dict[str, np.ndarray]:
        names = [field.name for field in dataclasses.fields(scores[0])]
        return {name: np.array([getattr(row, name) for row in scores]) for name in names}

    dt = 360.0 / m.size
    runners = {
        "iso18571_periodic": lambda: records(iso or iso18571_periodic_many(m, cycles,
                                                                           params=iso_params)),
        "iso18571": lambda: records([iso18571(m, c, dt=dt, params=iso_params) for c in cycles]),
        "sprague_geers": lambda: magnitude_phase_many(m, cycles, kind="sprague_geers",
                                                      periodic=True),
        "russell": lambda: magnitude_phase_many(m, cycles, kind="russell", periodic=True),
        "nrmse": lambda: nrmse_many(m, cycles, normaliser=normaliser),
        "pearson_r": lambda: pearson_r_many(m, cycles),
        "peak_error": lambda: peak_error_many(m, cycles, angle_deg, period=360.0),
        "circular_lag": lambda: circular_lag_many(m, cycles),
    }
    per_cycle: dict[str, np.ndarray] = {}
    for name in metrics:
        fields = runners[name]()
        for field in _numeric_fields(SCORE_TYPES[name]):
            per_cycle[_score_key(name, field)] = np.asarray(fields[field], dtype=np.float64)
    return per_cycle
