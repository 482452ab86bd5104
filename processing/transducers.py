"""Volts-to-units transducers: a linear scale, IEPE accelerometers and bridge load cells.

Closed forms (numpy arrays in, numpy arrays out; units in brackets):

- linear: ``y = slope x + offset``, ``slope`` in output units per input unit;
- IEPE accelerometer: ``a [m s-2] = V [V] / (S [mV/g] / 1000) g0`` with ``g0 = 9.80665 m s-2``
  (an IEPE sensor's output is AC-coupled by the DAQ; its mean is the sensor's bias, not motion);
- load cell (strain-gauge bridge with a rated output): ``F [N] = Vr [V/V] / (S [mV/V] / 1000)
  F_rated [N]``, with ``Vr = V_out / V_ex`` the offset-nulled bridge ratio
  (:func:`rigval.processing.conversions.bridge_ratio_values`).
"""

from __future__ import annotations

import logging

import numpy as np
from numpy.typing import ArrayLike

from rigval.acquisition.errors import ConfigError
from rigval.processing.accelerometer import STANDARD_GRAVITY
from rigval.processing.arrays import FloatArray

__all__ = ["iepe_acceleration", "linear_scale", "load_cell_force"]

logger = logging.getLogger(__name__)


def _finite_positive(value: float, name: str) -> None:
    if not (np.isfinite(value) and value > 0):
        raise ConfigError(f"{name} must be a finite positive number, got {value!r}",
                          where={"key": name})


def linear_scale(x: ArrayLike, *, slope: float, offset: float = 0.0) -> FloatArray:
    """Return ``slope x + offset``.

    Parameters
    ----------
    x : array_like
        Input values in the input unit.
    slope : float
        Output units per input unit; finite and non-zero.
    offset : float, default 0
        Output at ``x = 0``, in output units.

    Raises
    ------
    ConfigError
        For a zero or non-finite slope or a non-finite offset.
    """
    if not np.isfinite(slope) or slope == 0:
        raise ConfigError(f"slope must be finite and non-zero, got {slope!r}",
                          where={"key": "slope"})
    if not np.isfinite(offset):
        raise ConfigError(f"offset must be finite, got {offset!r}", where={"key": "offset"})
    return np.asarray(x, dtype=np.float64) * slope + offset


def iepe_acceleration(volts: ArrayLike, *, sensitivity: float) -> FloatArray:
    """Return the acceleration in m s-2 of an IEPE accelerometer's output in V.

    Parameters
    ----------
    volts : array_like
        Sensor output in V (bias already removed by the AC coupling).
    sensitivity : float
        S in mV/g (calibration certificate).
    """
    _finite_positive(sensitivity, "sensitivity")
    return np.asarray(volts, dtype=np.float64) / (sensitivity * 1e-3) * STANDARD_GRAVITY


def load_cell_force(ratio: ArrayLike, *, sensitivity: float, capacity: float) -> FloatArray:
    """Return the force of a bridge load cell from its bridge ratio.

    Parameters
    ----------
    ratio : array_like
        Offset-nulled bridge ratio Vr = V_out / V_ex in V/V.
    sensitivity : float
        Rated output in mV/V at the rated capacity.
    capacity : float
        Rated capacity in N (the force that gives the rated output).
    """
    _finite_positive(sensitivity, "sensitivity")
    _finite_positive(capacity, "capacity")
    return np.asarray(ratio, dtype=np.float64) / (sensitivity * 1e-3) * capacity
