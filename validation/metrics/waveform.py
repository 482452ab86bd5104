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
import scipy.optimize
import xarray as xr

from rigval.acquisition.errors import ConfigError, DataError
from rigval.validation.metrics.core import Scores, as_signal, paired, revolution_angle

__all__ = [
    "LagScores",
    "MagnitudePhaseScores",
    "NrmseScores",
    "PeakScores",
    "PearsonScores",
    "RussellScores",
    "SpragueGeersScores",
    "circular_lag",
    "nrmse",
    "peak_error",
    "pearson_r",
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
    i_mm, i_cc, i_mc = _energy_integrals(measured, model, periodic)
    magnitude = np.sqrt(i_cc / i_mm) - 1.0
    phase = _phase_error(i_mm, i_cc, i_mc)
    return SpragueGeersScores(magnitude=float(magnitude), phase=phase,
                              comprehensive=float(np.hypot(magnitude, phase)))


def russell(measured: Any, model: Any, *, periodic: bool = False) -> RussellScores:
    """Return the Russell magnitude, phase and comprehensive error.

    ``m = (I_cc - I_mm) / sqrt(I_mm I_cc)``, ``RM = sign(m) log10(1 + |m|)``,
    ``RP = arccos(I_mc / sqrt(I_mm I_cc)) / pi``, ``RC = sqrt(pi / 4 (RM^2 + RP^2))`` (Russell 1997,
    "Error measures for comparing transient data", 68th Shock and Vibration Symposium).

    Parameters
    ----------
    measured : array_like or xarray.DataArray
        Reference signal (any units).
    model : array_like or xarray.DataArray
        Model signal on the same grid, same units.
    periodic : bool
        Rectangle rule for one period (True) or trapezoid rule (False); see :func:`sprague_geers`.

    Returns
    -------
    RussellScores
        ``magnitude`` (RM), ``phase`` (RP), ``comprehensive`` (RC), dimensionless.

    Raises
    ------
    DataError
        On bad samples, unequal lengths, or a signal of zero energy.
    """
    i_mm, i_cc, i_mc = _energy_integrals(measured, model, periodic)
    ratio = (i_cc - i_mm) / np.sqrt(i_mm * i_cc)
    magnitude = float(np.sign(ratio) * np.log10(1.0 + abs(ratio)))
    phase = _phase_error(i_mm, i_cc, i_mc)
    comprehensive = float(np.sqrt(np.pi / 4.0 * (magnitude**2 + phase**2)))
    return RussellScores(magnitude=magnitude, phase=phase, comprehensive=comprehensive)


def nrmse(measured: Any, model: Any, normaliser: Normaliser = "range") -> NrmseScores:
    """Return the root-mean-square error normalised by a named property of the measurement.

    Parameters
    ----------
    measured : array_like or xarray.DataArray
        Reference signal (any units).
    model : array_like or xarray.DataArray
        Model signal on the same grid, same units.
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
    rmse = float(np.sqrt(np.mean((c - m) ** 2)))
    return NrmseScores(nrmse=rmse / scale, rmse=rmse, normaliser=normaliser,
                       normaliser_value=scale)


def pearson_r(measured: Any, model: Any) -> PearsonScores:
    """Return the Pearson correlation coefficient of measurement and model.

    Parameters
    ----------
    measured : array_like or xarray.DataArray
        Reference signal (any units).
    model : array_like or xarray.DataArray
        Model signal on the same grid.

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
    dm, dc = m - m.mean(), c - c.mean()
    norm = np.sqrt((dm @ dm) * (dc @ dc))
    if norm == 0.0:
        which = "measured" if not dm.any() else "model"
        raise DataError(f"the {which} signal is constant: Pearson r undefined",
                        where={"signal": which}, hint="compare a signal that varies")
    return PearsonScores(pearson_r=float(np.clip((dm @ dc) / norm, -1.0, 1.0)))


def peak_error(measured: Any, model: Any, x: Any = None, *,
               period: float | None = None) -> PeakScores:
    """Return the error of the model's peak value and the shift of its location.

    The measured peak is the sample of largest absolute value; the model peak is the model's
    extreme of the same sign. Their signed values are compared.

    Parameters
    ----------
    measured : array_like or xarray.DataArray
        Reference signal (any units).
    model : array_like or xarray.DataArray
        Model signal on the same grid, same units.
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
    i_m = int(np.argmax(np.abs(m)))
    i_c = int(np.argmax(c) if m[i_m] > 0.0 else np.argmin(c))
    if m[i_m] == 0.0:
        raise DataError("the measured signal is zero everywhere: relative peak error undefined",
                        where={"signal": "measured"}, hint="compare a signal with a peak")
    shift = float(abscissa[i_c] - abscissa[i_m])
    if period is not None:
        shift = (shift + period / 2.0) % period - period / 2.0
    measured_peak, model_peak = float(m[i_m]), float(c[i_c])
    return PeakScores(measured_peak=measured_peak, model_peak=model_peak,
                      error=model_peak - measured_peak,
                      relative_error=(abs(model_peak) - abs(measured_peak)) / abs(measured_peak),
                      measured_at=float(abscissa[i_m]), model_at=float(abscissa[i_c]),
                      shift=shift)


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
    n = m.size
    revolution_angle(angle, n, measured)
    dm, dc = m - m.mean(), c - c.mean()
    norm = np.sqrt((dm @ dm) * (dc @ dc))
    if norm == 0.0:
        raise DataError("a constant signal has no lag", where={"signal": "measured or model"},
                        hint="compare signals that vary over the revolution")
    spectrum = np.conj(np.fft.rfft(dm)) * np.fft.rfft(dc)
    whole = int(np.argmax(np.fft.irfft(spectrum, n)))
    orders = np.arange(spectrum.size)
    weights = np.where((orders == 0) | ((n % 2 == 0) & (orders == n // 2)), 1.0, 2.0) * spectrum
    rate = 2j * np.pi * orders / n

    def slope(lag: float) -> float:
        return float(np.sum(np.real(rate * weights * np.exp(rate * lag))))

    lag = _interpolated_peak(slope, float(whole))
    correlation = float(np.sum(np.real(weights * np.exp(rate * lag)))) / n / norm
    lag = (lag + n / 2.0) % n - n / 2.0
    return LagScores(lag_deg=float(lag * 360.0 / n), correlation=float(min(correlation, 1.0)))


def _interpolated_peak(slope: Callable[[float], float], whole: float) -> float:
    """Locate the maximum of the Fourier-interpolated correlation near its best whole sample.

    The root of the correlation's derivative within one sample of ``whole``, found by Brent's
    method; where the derivative keeps its sign over that bracket (energy near the Nyquist
    order), the whole-sample lag is returned.
    """
    low, high = whole - 1.0, whole + 1.0
    if slope(low) > 0.0 > slope(high):
        return float(scipy.optimize.brentq(slope, low, high, xtol=1e-12, rtol=1e-14))
    logger.debug("circular lag: no sub-sample refinement around sample %g", whole)
    return whole


def _energy_integrals(measured: Any, model: Any, periodic: bool) -> tuple[float, float, float]:
    """Return ``I_mm``, ``I_cc``, ``I_mc`` by the rectangle or trapezoid rule (unit spacing)."""
    m, c = paired(measured, model)
    weights = np.ones(m.size)
    if not periodic:
        weights[[0, -1]] = 0.5
    i_mm, i_cc, i_mc = float(weights @ (m * m)), float(weights @ (c * c)), float(weights @ (m * c))
    for name, energy in (("measured", i_mm), ("model", i_cc)):
        if energy == 0.0:
            raise DataError(f"the {name} signal is zero everywhere: magnitude and phase errors "
                            f"are undefined", where={"signal": name},
                            hint="check the channel or the model output compared")
    return i_mm, i_cc, i_mc


def _phase_error(i_mm: float, i_cc: float, i_mc: float) -> float:
    """``arccos(I_mc / sqrt(I_mm I_cc)) / pi``, the cosine clipped to [-1, 1] against rounding."""
    cosine = np.clip(i_mc / np.sqrt(i_mm * i_cc), -1.0, 1.0)
    return float(np.arccos(cosine) / np.pi)


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
