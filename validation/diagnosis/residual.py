"""The residual of one comparison in time: measured minus model at every aligned sample.

The angle domain of a run (cycles x phi_F) is low-passed for its metrics (a comparison's
``lowpass_hz``, the grid's anti-alias filter), which hides a structural mode above the corner.
The diagnosis therefore works on the aligned signal before that low-pass (the run's
``/diagnosis/<comparison>``, :mod:`~rigval.processing.stretch_decimation`): each sample's
main-shaft angle phi_F comes from the run's grid times (``/angle/time_at_angle``), the model
curve (scaled, with the comparison's offset) is evaluated there, and the residual is the
measured value minus it.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import xarray as xr
from scipy.interpolate import CubicSpline

from rigval.acquisition.errors import DataError
from rigval.processing.arrays import FloatArray
from rigval.validation.results import ComparisonResult, ValidationResult

__all__ = ["ResidualSeries", "residual_series"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class ResidualSeries:
    """One comparison's measured signal and model at the aligned samples of whole revolutions.

    Parameters
    ----------
    name : str
        Comparison name.
    units : str
        Unit of the signal.
    time : numpy.ndarray
        Reference time of each sample's input (module delay removed), s.
    measured : numpy.ndarray
        Measured value (summed channels for a summed comparison), signal units.
    model : numpy.ndarray
        Model (times the comparison's scale, plus its offset) at each sample's phi_F.
    phi : numpy.ndarray
        Unwrapped main-shaft angle phi_F at each sample, rad (0 at the first whole revolution).
    run : numpy.ndarray
        Index of the gap-free stretch each sample belongs to (int).
    fs : float
        Sample rate in Hz.
    speed_rev_s : float
        Mean main-shaft speed in rev/s.
    angle : numpy.ndarray
        The run's phi_F grid over one revolution (rad), for the synchronous part.
    model_curve : numpy.ndarray
        The model on that grid (scaled, offset), signal units.
    """

    name: str
    units: str
    time: FloatArray
    measured: FloatArray
    model: FloatArray
    phi: FloatArray
    run: np.ndarray
    fs: float
    speed_rev_s: float
    angle: FloatArray
    model_curve: FloatArray

    @property
    def residual(self) -> FloatArray:
        """Measured minus model, signal units."""
        return self.measured - self.model

    def same_samples(self, other: ResidualSeries) -> bool:
        """Whether ``other`` has this series' samples to the bit: another comparison or model.

        The same times, phi_F and stretches, rate, speed and grid (a comparison of the same
        stream with the same gaps, or this comparison against another mechanism); the measured
        values and the model may differ.
        """
        return (self.fs == other.fs and self.speed_rev_s == other.speed_rev_s
                and all(np.array_equal(getattr(self, f), getattr(other, f))
                        for f in ("time", "phi", "run", "angle")))

    def same_measurement(self, other: ResidualSeries) -> bool:
        """Whether ``other`` is this comparison's measured signal, to the bit, at its samples.

        The two series differ at most in their model (one measurement validated against two
        mechanisms, as ``rigval identify`` does).
        """
        return (self.name == other.name and self.units == other.units
                and self.same_samples(other) and np.array_equal(self.measured, other.measured))

    def same(self, other: ResidualSeries) -> bool:
        """Whether ``other`` is the same series to the bit: its measurement and its model."""
        return (self.same_measurement(other) and np.array_equal(self.model, other.model)
                and np.array_equal(self.model_curve, other.model_curve))


def periodic_curve(angle: FloatArray, values: FloatArray) -> CubicSpline:
    """Return a periodic cubic spline through one revolution's values on a uniform grid."""
    return CubicSpline(np.append(angle, angle[0] + 2.0 * np.pi), np.append(values, values[0]),
                       bc_type="periodic")


def _measured(comparison: ComparisonResult, stream: xr.Dataset) -> tuple[FloatArray, FloatArray]:
    """Return the input times (s) and measured values of a comparison's channels in a stream."""
    spec = comparison.spec
    first = spec.measured.channel
    delay = float(stream[first].attrs.get("input_delay_s", 0.0))
    values = np.asarray(stream[first].to_numpy(), dtype=np.float64).copy()
    for sign, ref in spec.terms[1:]:
        values += sign * np.asarray(stream[ref.channel].to_numpy(), dtype=np.float64)
    valid = stream["valid"].to_numpy() if "valid" in stream else np.ones(values.size, bool)
    values[~valid] = np.nan
    return np.asarray(stream["time"].to_numpy(), dtype=np.float64) - delay, values


def residual_series(result: ValidationResult, name: str) -> ResidualSeries:
    """Build one comparison's residual in time from a validated run.

    The measured signal is the run's ``/diagnosis/<comparison>`` (kept by the pipeline before
    any low-pass, decimated), or else the aligned stream (scene ``[output] aligned = true``).

    Parameters
    ----------
    result : ValidationResult
        A validated run.
    name : str
        Comparison name.

    Returns
    -------
    ResidualSeries
        The samples within the run's whole revolutions; NaN samples (gaps, invalid) dropped,
        the stretches between them numbered in ``run``.

    Raises
    ------
    DataError
        If the comparison is unknown or the run did not keep its aligned stream.
    """
    comparison = next((c for c in result.comparisons if c.name == name), None)
    if comparison is None:
        raise DataError(f"no comparison {name!r} in the run", where={"key": name},
                        hint=f"use one of {[c.name for c in result.comparisons]}")
    kept = f"/diagnosis/{name}"
    stream_name = comparison.spec.measured.stream
    path = f"/aligned/{stream_name}"
    if kept in result.tree.groups:
        signal = result.tree[kept].to_dataset()
        time = np.asarray(signal["time"].to_numpy(), dtype=np.float64)
        measured = np.asarray(signal["measured"].to_numpy(), dtype=np.float64)
        stretch = signal["stretch"].to_numpy()
    elif path in result.tree.groups:
        time, measured = _measured(comparison, result.tree[path].to_dataset())
        stretch = None
    else:
        raise DataError(f"{name}: the run kept neither its signal for the diagnosis nor the "
                        f"aligned stream {stream_name!r}", where={"key": name},
                        hint="validate with this version of rigval, or set aligned = true "
                             "under [output] in the scene")
    if time.size < 2:
        raise DataError(f"{name}: no gap-free stretch long enough for the residual spectra",
                        where={"key": name}, hint="record longer or with fewer gaps")
    grid = result.tree["/angle"].to_dataset()
    grid_times = np.asarray(grid["time_at_angle"].to_numpy(), dtype=np.float64)
    angle = np.asarray(grid["angle"].to_numpy(), dtype=np.float64)
    turns = 2.0 * np.pi * np.arange(grid_times.shape[0])[:, None] + angle[None, :]
    flat_t, flat_phi = grid_times.ravel(), turns.ravel()
    end_t = flat_t[-1] + (flat_t[-1] - flat_t[-2])  # the end of the last whole revolution
    keep = (time >= flat_t[0]) & (time < end_t) & np.isfinite(measured)
    phi = np.interp(time, np.append(flat_t, end_t), np.append(flat_phi, 2.0 * np.pi
                                                              * grid_times.shape[0]))
    curve = periodic_curve(angle, comparison.model)
    model = curve(np.mod(phi, 2.0 * np.pi))
    dt = np.diff(time)
    step = float(np.median(dt))
    breaks = np.concatenate([[0], np.cumsum((dt > 1.5 * step) | ~keep[1:] | ~keep[:-1])])
    if stretch is not None:
        breaks = breaks + stretch * time.size  # a new stretch also starts at a filter break
    idx = np.flatnonzero(keep)
    return ResidualSeries(name, comparison.units, time[idx], measured[idx], model[idx],
                          phi[idx], np.unique(breaks[idx], return_inverse=True)[1], 1.0 / step,
                          result.speed_rev_s, angle,
                          np.asarray(comparison.model, dtype=np.float64))
