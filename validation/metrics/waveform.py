"""Waveform comparison metrics beside ISO/TS 18571: Sprague-Geers, Russell and plain measures.

Every function takes the measured (reference) signal first and the model signal second, sampled on
the same grid, and returns a frozen :class:`~rigval.validation.metrics.core.Scores` record. Sources
of the formulas are cited per function; docs/metrics.md and docs/references.md collects them.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable
from typing import Any, Literal

import numpy as np
import xarray as xr

from rigval.acquisition.errors import ConfigError, DataError
from rigval.validation.metrics.core import Scores, as_signal, paired, revolution_angle, row_dot

__all__ = [
    "LagScores",
    "MagnitudePhaseScores",
    "NrmseScores",
    "PeakScores",
    "PearsonScores",
    "RussellScores",
    "SpragueGeersScores",
    "circular_lag",
    "circular_lag_many",
    "magnitude_phase_many",
    "nrmse",
    "nrmse_many",
    "peak_error",
    "peak_error_many",
    "pearson_r",
    "pearson_r_many",
    "russell",
    "sprague_geers",
]

logger = logging.getLogger(__name__)

Normaliser = Literal["range", "rms", "peak"]
NORMALISERS: tuple[str, ...] = ("range", "rms", "peak")


@dataclasses.dataclass(frozen=True)
class MagnitudePhaseScores(Scores):
    """Magnitude, phase and comprehensive error (the scores of Sprague-Geers and of Russell).

    Attributes
    ----------
    magnitude : float
        Magnitude error: 0 is perfect, positive for a model larger than the measurement.
    phase : float
        ``P = arccos(I_mc / sqrt(I_mm I_cc)) / pi`` in [0, 1]; a sinusoid shifted by ``phi`` rad
        gives ``phi / pi``; 1 means inverted.
    comprehensive : float
        Magnitude and phase combined; 0 is perfect.
    """

    magnitude: float
    phase: float
    comprehensive: float


@dataclasses.dataclass(frozen=True)
class SpragueGeersScores(MagnitudePhaseScores):
    """Sprague & Geers (2004) magnitude, phase and comprehensive error.

    ``magnitude`` is ``M = sqrt(I_cc / I_mm) - 1`` in [-1, inf) (``k - 1`` for a model ``k`` times
    the measurement); ``comprehensive`` is ``C = sqrt(M^2 + P^2)``.
    """


@dataclasses.dataclass(frozen=True)
class RussellScores(MagnitudePhaseScores):
    """Russell (1997) magnitude, phase and comprehensive error.

    ``magnitude`` is ``RM = sign(m) log10(1 + |m|)`` with ``m = (I_cc - I_mm) / sqrt(I_mm I_cc)``,
    antisymmetric in over- and under-prediction (a factor 2 or 1/2 gives +-0.398); ``phase`` is
    the Sprague-Geers phase; ``comprehensive`` is ``RC = sqrt(pi / 4 (RM^2 + RP^2))``, commonly
    graded excellent <= 0.15, acceptable <= 0.28.
    """


@dataclasses.dataclass(frozen=True)
class NrmseScores(Scores):
    """Root-mean-square error, normalised.

    Attributes
    ----------
    nrmse : float
        ``rmse / normaliser_value`` (dimensionless).
    rmse : float
        ``sqrt(mean((model - measured)^2))``, in the signals' units.
    normaliser : str
        Which property of the measured signal divides: ``"range"`` (max - min), ``"rms"`` (then
        nrmse is the relative L2 error) or ``"peak"`` (max |measured|).
    normaliser_value : float
        Its value, in the signals' units.
    """

    nrmse: float
    rmse: float
    normaliser: str
    normaliser_value: float


@dataclasses.dataclass(frozen=True)
class PearsonScores(Scores):
    """Pearson correlation coefficient.

    Attributes
    ----------
    pearson_r : float
        In [-1, 1]; blind to offset and scale, sensitive to phase.
    """

    pearson_r: float


@dataclasses.dataclass(frozen=True)
class PeakScores(Scores):
    """Peak value error and where the peaks lie.

    The measured peak is the measured sample of largest absolute value; the model peak is the
    model's extreme of the same sign (its maximum for a positive measured peak, else its
    minimum), so that a signal with nearly equal positive and negative peaks is not compared
    across polarities.

    Attributes
    ----------
    measured_peak, model_peak : float
        Peak values, in the signals' units.
    error : float
        ``model_peak - measured_peak``, in the signals' units.
    relative_error : float
        ``(|model_peak| - |measured_peak|) / |measured_peak|``: positive when the model
        over-predicts the peak's size, whatever its sign.
    measured_at, model_at : float
        Abscissa of each peak (units of the abscissa given: s, rad or degrees).
    shift : float
        ``model_at - measured_at``, wrapped into [-period/2, period/2) when a period is given.
    """

    measured_peak: float
    model_peak: float
    error: float
    relative_error: float
    measured_at: float
    model_at: float
    shift: float


@dataclasses.dataclass(frozen=True)
class LagScores(Scores):
    """Lag of the model behind the measurement over one revolution.

    Attributes
    ----------
    lag_deg : float
        Lag in degrees in [-180, 180); positive when the model is delayed (lags).
    correlation : float
        Circular Pearson correlation of the measurement with the model advanced by the lag.
    """

    lag_deg: float
    correlation: float


def sprague_geers(measured: Any, model: Any, *, periodic: bool = False) -> SpragueGeersScores:
    """Return the Sprague & Geers magnitude, phase and comprehensive error.

    With ``I_mm = int m^2``, ``I_cc = int c^2``, ``I_mc = int m c``: ``M = sqrt(I_cc / I_mm) - 1``,
    ``P = arccos(I_mc / sqrt(I_mm I_cc)) / pi``, ``C = sqrt(M^2 + P^2)`` (Sprague & Geers 2004,
    Commun. Numer. Meth. Engng 20:1101).

    Parameters
    ----------
    measured : array_like or xarray.DataArray
        Reference signal (any units).
    model : array_like or xarray.DataArray
        Model signal on the same grid, same units.
    periodic : bool
        True for one period without its repeated end sample (rectangle rule, exact for a
        trigonometric polynomial); False for an interval whose ends are both samples (trapezoid
        rule). The grid spacing cancels.

    Returns
    -------
    SpragueGeersScores
        ``magnitude`` (M), ``phase`` (P), ``comprehensive`` (C), dimensionless.

    Raises
    ------
    DataError
        On bad samples, unequal lengths, or a signal of zero energy (phase undefined).
    """
    m, c = paired(measured, model)
    return SpragueGeersScores(**_first(magnitude_phase_many(m, c[np.newaxis], kind="sprague_geers",
                                                            periodic=periodic)))


def magnitude_phase_many(measured: np.ndarray, models: np.ndarray, *,
                         kind: Literal["sprague_geers", "russell"],
                         periodic: bool = False) -> dict[str, np.ndarray]:
    """Sprague & Geers or Russell scores of each row of ``models`` against ``measured``.

    Both metrics are built from the same energy integrals ``I_mm``, ``I_cc``, ``I_mc`` and the
    same phase error; they differ in the magnitude error and in how it combines with the phase
    error (the formulas: :func:`sprague_geers`, :func:`russell`).

    Parameters
    ----------
    measured : numpy.ndarray
        Reference signal, shape ``(n,)``, finite (checked arrays).
    models : numpy.ndarray
        Model signals, shape ``(m, n)``, finite, in the reference's units.
    kind : {"sprague_geers", "russell"}
        The metric.
    periodic : bool
        As for :func:`sprague_geers`.

    Returns
    -------
    dict of str to numpy.ndarray
        ``magnitude``, ``phase``, ``comprehensive``: one value per row.

    Raises
    ------
    DataError
        For a signal of zero energy (the row is named).
    """
    i_mm, i_cc, i_mc = _energy_integrals(measured, models, periodic)
    phase = _phase_error(i_mm, i_cc, i_mc)
    if kind == "sprague_geers":
        magnitude = np.sqrt(i_cc / i_mm) - 1.0
        return {"magnitude": magnitude, "phase": phase,
                "comprehensive": np.hypot(magnitude, phase)}
    ratio = (i_cc - i_mm) / np.sqrt(i_mm * i_cc)
    magnitude = np.sign(ratio) * np.log10(1.0 + np.abs(ratio))
    return {"magnitude": magnitude, "phase": phase,
            "comprehensive": np.sqrt(np.pi / 4.0 * (magnitude**2 + phase**2))}


def russell(measured: Any, model: Any, *, periodic: bool = False) -> RussellScores:
    """Return the Russell magnitude, phase and comprehensive error.

    ``m = (I_cc - I_mm) / sqrt(I_mm I_cc)``, ``RM = sign(m) log10(1 + |m|)``,
    ``RP = arccos(I_mc / sqrt(I_mm I_cc)) / pi``, ``RC = sqrt(pi / 4 (RM^2 + RP^2))`` (Russell 1997,
    "Error measures for comparing transient data", 68th Shock and Vibration Symposium).

    Parameters
    ----------
    measured, model, periodic
        As for :func:`sprague_geers`: the reference and the model signal on the same grid, and
        the rectangle (True) or trapezoid rule (False).

    Returns
    -------
    RussellScores
        ``magnitude`` (RM), ``phase`` (RP), ``comprehensive`` (RC), dimensionless.

    Raises
    ------
    DataError
        On bad samples, unequal lengths, or a signal of zero energy.
    """
    m, c = paired(measured, model)
    return RussellScores(**_first(magnitude_phase_many(m, c[np.newaxis], kind="russell",
                                                       periodic=periodic)))


def nrmse(measured: Any, model: Any, normaliser: Normaliser = "range") -> NrmseScores:
    """Return the root-mean-square error normalised by a named property of the measurement.

    Parameters
    ----------
    measured, model
        As for :func:`sprague_geers`.
    normaliser : {"range", "rms", "peak"}
        ``max - min``, ``sqrt(mean(m^2))`` or ``max |m|`` of the measured signal.

    Returns
    -------
    NrmseScores
        ``nrmse`` (dimensionless), ``rmse`` (signal units), the normaliser's name and value.

    Raises
    ------
    ConfigError
        For an unknown normaliser.
    DataError
        On bad samples, unequal lengths, or a normaliser of zero.
    """
    m, c = paired(measured, model)
    return NrmseScores(**_first(nrmse_many(m, c[np.newaxis], normaliser)))


def nrmse_many(measured: np.ndarray, models: np.ndarray,
               normaliser: Normaliser = "range") -> dict[str, Any]:
    """NRMSE of each row of ``models`` against ``measured`` (checked arrays).

    Parameters
    ----------
    measured, models
        As for :func:`magnitude_phase_many`.
    normaliser : {"range", "rms", "peak"}
        As for :func:`nrmse`.

    Returns
    -------
    dict
        ``nrmse`` and ``rmse`` (one value per row), ``normaliser`` (its name) and
        ``normaliser_value`` (one value per row, all equal).

    Raises
    ------
    ConfigError
        For an unknown normaliser.
    DataError
        For a normaliser of zero.
    """
    m = measured
    if normaliser == "range":
        scale = float(np.ptp(m))
    elif normaliser == "rms":
        scale = float(np.sqrt(np.mean(m * m)))
    elif normaliser == "peak":
        scale = float(np.max(np.abs(m)))
    else:
        raise ConfigError(f"unknown NRMSE normaliser {normaliser!r}", where={"key": "normaliser"},
                          hint=f"use one of {', '.join(NORMALISERS)}")
    if scale == 0.0:
        raise DataError(f"the measured signal's {normaliser} is zero: NRMSE undefined",
                        where={"signal": "measured"}, hint="use another normaliser or the RMSE")
    rmse = np.sqrt(np.mean((models - m) ** 2, axis=1))
    return {"nrmse": rmse / scale, "rmse": rmse, "normaliser": normaliser,
            "normaliser_value": np.full(rmse.size, scale)}


def pearson_r(measured: Any, model: Any) -> PearsonScores:
    """Return the Pearson correlation coefficient of measurement and model.

    Parameters
    ----------
    measured, model
        As for :func:`sprague_geers` (the units may differ).

    Returns
    -------
    PearsonScores
        ``pearson_r`` in [-1, 1].

    Raises
    ------
    DataError
        On bad samples, unequal lengths, or a constant signal (r undefined).
    """
    m, c = paired(measured, model)
    return PearsonScores(**_first(pearson_r_many(m, c[np.newaxis])))


def pearson_r_many(measured: np.ndarray, models: np.ndarray) -> dict[str, np.ndarray]:
    """Pearson r of each row of ``models`` with ``measured`` (checked arrays).

    Parameters
    ----------
    measured, models
        As for :func:`magnitude_phase_many` (the units may differ).

    Returns
    -------
    dict of str to numpy.ndarray
        ``pearson_r``: one value per row.

    Raises
    ------
    DataError
        For a constant signal (the row is named).
    """
    dm, dc, norm = _demeaned(measured, models, "the {} signal is constant: Pearson r undefined",
                             "compare a signal that varies")
    return {"pearson_r": np.clip(row_dot(dc, dm) / norm, -1.0, 1.0)}


def peak_error(measured: Any, model: Any, x: Any = None, *,
               period: float | None = None) -> PeakScores:
    """Return the error of the model's peak value and the shift of its location.

    The measured peak is the sample of largest absolute value; the model peak is the model's
    extreme of the same sign. Their signed values are compared.

    Parameters
    ----------
    measured, model
        As for :func:`sprague_geers`.
    x : array_like, optional
        Abscissa of the samples (time in s or angle in rad or degrees). Defaults to a DataArray's
        coordinate, else the sample index.
    period : float, optional
        Period of the abscissa (2 pi or 360 for an angle) to wrap the shift into
        [-period/2, period/2).

    Returns
    -------
    PeakScores
        Peak values, absolute and relative error, locations and shift (units of ``x``).

    Raises
    ------
    DataError
        On bad samples, unequal lengths, an abscissa of another length, or a zero measured peak.
    """
    m, c = paired(measured, model)
    abscissa = _abscissa(measured, x, m.size)
    return PeakScores(**_first(peak_error_many(m, c[np.newaxis], abscissa, period=period)))


def peak_error_many(measured: np.ndarray, models: np.ndarray, abscissa: np.ndarray, *,
                    period: float | None = None) -> dict[str, np.ndarray]:
    """Peak errors of each row of ``models`` against ``measured`` (checked arrays).

    Parameters
    ----------
    measured, models
        As for :func:`magnitude_phase_many`.
    abscissa : numpy.ndarray
        Abscissa of the samples, shape ``(n,)``.
    period : float, optional
        As for :func:`peak_error`.

    Returns
    -------
    dict of str to numpy.ndarray
        The fields of :class:`PeakScores`, one value per row.

    Raises
    ------
    DataError
        For a zero measured peak.
    """
    i_m = int(np.argmax(np.abs(measured)))
    if measured[i_m] == 0.0:
        raise DataError("the measured signal is zero everywhere: relative peak error undefined",
                        where={"signal": "measured"}, hint="compare a signal with a peak")
    i_c = np.argmax(models, axis=1) if measured[i_m] > 0.0 else np.argmin(models, axis=1)
    shift = abscissa[i_c] - abscissa[i_m]
    if period is not None:
        shift = (shift + period / 2.0) % period - period / 2.0
    measured_peak = float(measured[i_m])
    model_peak = models[np.arange(models.shape[0]), i_c]
    rows = np.ones(models.shape[0])
    return {"measured_peak": measured_peak * rows, "model_peak": model_peak,
            "error": model_peak - measured_peak,
            "relative_error": (np.abs(model_peak) - abs(measured_peak)) / abs(measured_peak),
            "measured_at": abscissa[i_m] * rows, "model_at": abscissa[i_c], "shift": shift}


def circular_lag(measured: Any, model: Any, angle: Any = None) -> LagScores:
    """Return the lag of the model behind the measurement over one revolution, degrees.

    The circular cross-correlation ``R(k) = sum_i m_i c_(i+k)`` of the demeaned signals is
    maximised over whole samples, then refined to a fraction of a sample at the zero of the
    derivative of its trigonometric (Fourier) interpolant, which is exact for band-limited
    signals. Circular correlation over whole revolutions has no end effects and no bias toward
    zero lag.

    Parameters
    ----------
    measured : array_like or xarray.DataArray
        Reference signal over one revolution.
    model : array_like or xarray.DataArray
        Model signal on the same angle grid.
    angle : array_like, optional
        Shaft angle of the samples, rad, uniform over one revolution without the repeated end
        sample; checked when given (or when ``measured`` is a DataArray with an ``angle``
        coordinate). Only its step matters.

    Returns
    -------
    LagScores
        ``lag_deg`` in [-180, 180) (positive: model delayed) and the correlation at that lag.

    Raises
    ------
    DataError
        On bad samples, unequal lengths, a bad angle grid, or a constant signal.
    """
    m, c = paired(measured, model)
    revolution_angle(angle, m.size, measured)
    return LagScores(**_first(circular_lag_many(m, c[np.newaxis])))


def circular_lag_many(measured: np.ndarray, models: np.ndarray) -> dict[str, np.ndarray]:
    """Circular lag of each row of ``models`` behind ``measured`` (checked arrays).

    All rows at once: the cross-correlations by one batched FFT, the sub-sample refinement by
    Brent's method run on all rows in lock-step (:func:`_brentq_many`, the iteration of
    :func:`scipy.optimize.brentq`).

    Parameters
    ----------
    measured : numpy.ndarray
        Reference signal over one revolution, shape ``(n,)``, finite.
    models : numpy.ndarray
        Model signals on the same grid, shape ``(m, n)``, finite.

    Returns
    -------
    dict of str to numpy.ndarray
        ``lag_deg`` and ``correlation``, one value per row.

    Raises
    ------
    DataError
        For a constant signal (the row is named).
    """
    n = measured.size
    dm, dc, norm = _demeaned(measured, models, "a constant signal has no lag ({} signal)",
                             "compare signals that vary over the revolution")
    spectrum = np.conj(np.fft.rfft(dm)) * np.fft.rfft(dc, axis=1)
    whole = np.argmax(np.fft.irfft(spectrum, n, axis=1), axis=1).astype(np.float64)
    orders = np.arange(spectrum.shape[1])
    weights = np.where((orders == 0) | ((n % 2 == 0) & (orders == n // 2)), 1.0, 2.0) * spectrum
    rate = 2j * np.pi * orders / n

    def slope(lag: np.ndarray, rows: np.ndarray) -> np.ndarray:
        return np.sum(np.real(rate * weights[rows] * np.exp(rate * lag[:, np.newaxis])), axis=1)

    lag = _interpolated_peaks(slope, whole)
    correlation = np.sum(np.real(weights * np.exp(rate * lag[:, np.newaxis])), axis=1) / n / norm
    lag = (lag + n / 2.0) % n - n / 2.0
    return {"lag_deg": lag * 360.0 / n, "correlation": np.minimum(correlation, 1.0)}


def _interpolated_peaks(slope: Callable[[np.ndarray, np.ndarray], np.ndarray],
                        whole: np.ndarray) -> np.ndarray:
    """Locate each row's maximum of the Fourier-interpolated correlation near its best sample.

    The root of the correlation's derivative within one sample of ``whole``, found by Brent's
    method; where the derivative keeps its sign over that bracket (energy near the Nyquist
    order), the whole-sample lag is returned. ``slope(lag, rows)`` gives the derivative of the
    given rows at their lags.
    """
    rows = np.arange(whole.size)
    low, high = whole - 1.0, whole + 1.0
    bracketed = (slope(low, rows) > 0.0) & (slope(high, rows) < 0.0)
    if not bracketed.all():
        logger.debug("circular lag: no sub-sample refinement for %d of %d signals",
                     int((~bracketed).sum()), whole.size)
    lag = whole.copy()
    if bracketed.any():
        which = rows[bracketed]
        lag[which] = _brentq_many(lambda x, part: slope(x, which[part]), low[which],
                                  high[which], xtol=1e-12, rtol=1e-14)
    return lag


def _brentq_many(f: Callable[[np.ndarray, np.ndarray], np.ndarray], a: np.ndarray,
                 b: np.ndarray, *, xtol: float, rtol: float, maxiter: int = 100) -> np.ndarray:
    """Brent's root search on many brackets at once, step for step as :func:`scipy.optimize.brentq`.

    ``f(x, rows)`` evaluates the functions of the given rows (indices into ``a``) at ``x``.
    Every row follows the iteration of SciPy's ``brentq.c`` (inverse quadratic extrapolation,
    bisection fall-back, the same tolerance test ``|step| < (xtol + rtol |x|) / 2``), so each
    root is the one ``scipy.optimize.brentq`` returns for that row; the tests check this to the
    last bit. Rows still open after ``maxiter`` iterations keep their last estimate (logged).
    """
    everything = np.arange(a.size)
    xpre, xcur = a.astype(np.float64), b.astype(np.float64)
    fpre, fcur = f(xpre, everything), f(xcur, everything)
    root = np.where(fpre == 0.0, xpre, xcur)
    open_ = (fpre != 0.0) & (fcur != 0.0)
    xblk, fblk = np.zeros_like(xcur), np.zeros_like(xcur)
    spre, scur = np.zeros_like(xcur), np.zeros_like(xcur)
    for _ in range(maxiter):
        if not open_.any():
            return root
        rows = everything[open_]
        xp, xc, xb, fp, fc, fb = (v[rows] for v in (xpre, xcur, xblk, fpre, fcur, fblk))
        sp, sc = spre[rows], scur[rows]
        bracket = (fp != 0.0) & (fc != 0.0) & (np.signbit(fp) != np.signbit(fc))
        xb, fb = np.where(bracket, xp, xb), np.where(bracket, fp, fb)
        sp = np.where(bracket, xc - xp, sp)
        sc = np.where(bracket, xc - xp, sc)
        swap = np.abs(fb) < np.abs(fc)
        xp, xc, xb = np.where(swap, xc, xp), np.where(swap, xb, xc), np.where(swap, xc, xb)
        fp, fc, fb = np.where(swap, fc, fp), np.where(swap, fb, fc), np.where(swap, fc, fb)
        delta = (xtol + rtol * np.abs(xc)) / 2
        sbis = (xb - xc) / 2
        converged = (fc == 0.0) | (np.abs(sbis) < delta)
        root[rows[converged]] = xc[converged]
        open_[rows[converged]] = False
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            interpolate = -fc * (xc - xp) / (fc - fp)
            dpre = (fp - fc) / (xp - xc)
            dblk = (fb - fc) / (xb - xc)
            extrapolate = -fc * (fb * dblk - fp * dpre) / (dblk * dpre * (fb - fp))
        trial = np.where(xp == xb, interpolate, extrapolate)
        good = ((np.abs(sp) > delta) & (np.abs(fc) < np.abs(fp))
                & (2 * np.abs(trial) < np.minimum(np.abs(sp), 3 * np.abs(sbis) - delta)))
        sp, sc = np.where(good, sc, sbis), np.where(good, trial, sbis)
        xp, fp = xc, fc
        xc = np.where(np.abs(sc) > delta, xc + sc, xc + np.where(sbis > 0, delta, -delta))
        go = ~converged
        live = rows[go]
        for target, value in ((xpre, xp), (xcur, xc), (xblk, xb), (fpre, fp), (fblk, fb),
                              (spre, sp), (scur, sc)):
            target[live] = value[go]
        if live.size:
            fcur[live] = f(xc[go], live)
    if open_.any():
        logger.warning("Brent's method: %d roots not converged after %d iterations",
                       int(open_.sum()), maxiter)
        root[open_] = xcur[open_]
    return root


def _energy_integrals(measured: np.ndarray, models: np.ndarray,
                      periodic: bool) -> tuple[float, np.ndarray, np.ndarray]:
    """Return ``I_mm`` and, per row, ``I_cc``, ``I_mc`` by the rectangle or trapezoid rule."""
    weights = np.ones(measured.size)
    if not periodic:
        weights[[0, -1]] = 0.5
    i_mm = float(weights @ (measured * measured))
    i_cc, i_mc = row_dot(models * models, weights), row_dot(models * measured, weights)
    if i_mm == 0.0:
        raise DataError("the measured signal is zero everywhere: magnitude and phase errors are "
                        "undefined", where={"signal": "measured"},
                        hint="check the channel or the model output compared")
    _require_nonzero(i_cc, "the {} signal is zero everywhere: magnitude and phase errors are "
                     "undefined", "check the channel or the model output compared")
    return i_mm, i_cc, i_mc


def _phase_error(i_mm: float, i_cc: np.ndarray, i_mc: np.ndarray) -> np.ndarray:
    """``arccos(I_mc / sqrt(I_mm I_cc)) / pi``, the cosine clipped to [-1, 1] against rounding."""
    cosine = np.clip(i_mc / np.sqrt(i_mm * i_cc), -1.0, 1.0)
    return np.arccos(cosine) / np.pi


def _demeaned(measured: np.ndarray, models: np.ndarray, message: str,
              hint: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return the demeaned signals and, per row, the product of their L2 norms.

    Parameters
    ----------
    measured : numpy.ndarray
        Reference signal, shape ``(n,)``, finite (signal units).
    models : numpy.ndarray
        Model signals, shape ``(m, n)``, finite, in the reference's units.
    message, hint : str
        Of the DataError raised for a constant signal (as for :func:`_require_nonzero`).

    Returns
    -------
    demeaned_measured : numpy.ndarray
        ``measured`` minus its mean, shape ``(n,)``.
    demeaned_models : numpy.ndarray
        Each row minus its own mean, shape ``(m, n)``.
    norm : numpy.ndarray
        ``|demeaned_measured| |demeaned_model|`` per row, shape ``(m,)`` (signal units squared).
    """
    demeaned_measured = measured - measured.mean()
    demeaned_models = models - models.mean(axis=1, keepdims=True)
    norm = np.sqrt((demeaned_measured @ demeaned_measured)
                   * row_dot(demeaned_models, demeaned_models))
    _require_nonzero(norm, message, hint, measured_zero=not demeaned_measured.any())
    return demeaned_measured, demeaned_models, norm


def _require_nonzero(values: np.ndarray, message: str, hint: str, *,
                     measured_zero: bool = False) -> None:
    """Raise DataError naming the measured signal or the first model row where ``values`` is 0.

    ``message`` has one ``{}`` for the signal's name.
    """
    zero = values == 0.0
    if measured_zero or zero.any():
        which = "measured" if measured_zero else "model"
        where: dict[str, Any] = {"signal": which}
        if not measured_zero and zero.size > 1:
            where["row"] = int(np.argmax(zero))
        raise DataError(message.format(which), where=where, hint=hint)


def _first(scores: dict[str, Any]) -> dict[str, Any]:
    """Return the first row of batched scores as Python scalars (strings pass through)."""
    return {key: value if isinstance(value, str) else float(value[0])
            for key, value in scores.items()}


def _abscissa(measured: Any, x: Any, n: int) -> np.ndarray:
    """Abscissa of the samples: ``x``, else a DataArray's coordinate, else the sample index."""
    if x is None and isinstance(measured, xr.DataArray) and measured.dims[0] in measured.coords:
        x = measured[measured.dims[0]]
    if x is None:
        return np.arange(n, dtype=np.float64)
    abscissa = as_signal(x, "abscissa")
    if abscissa.size != n:
        raise DataError(f"the abscissa has {abscissa.size} samples, the signals have {n}",
                        where={"signal": "abscissa"}, hint="pass the signals' own time or angle")
    return abscissa
