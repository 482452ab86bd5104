"""ASME V&V 20 comparison error against validation uncertainty for peak and RMS features.

For a scalar feature (system response quantity) of simulation ``S`` and data ``D`` the comparison
error is ``E = S - D`` and the validation uncertainty ``u_val = sqrt(u_num^2 + u_input^2 +
u_D^2)``; the model error lies in ``[E - k u_val, E + k u_val]`` (k = 2: about 95 % for roughly
Gaussian errors). ``|E| > k u_val`` resolves a model error of about ``E``; otherwise the model
error cannot be resolved at this uncertainty, which does not prove the model right (ASME V&V
20-2009 (R2016), sections 1-2).
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from rigval.acquisition.errors import ConfigError
from rigval.validation.metric_core import Scores, as_cycles, paired

__all__ = ["FEATURES", "VV20Feature", "VV20Scores", "vv20"]

logger = logging.getLogger(__name__)

FEATURES: tuple[str, ...] = ("peak", "rms")
"""Features rated: ``peak`` = max |x| and ``rms`` = sqrt(mean x^2) over the samples given."""

Uncertainty = float | Mapping[str, float]


@dataclasses.dataclass(frozen=True)
class VV20Feature(Scores):
    """V&V 20 comparison of one scalar feature (all values in the signals' units).

    Attributes
    ----------
    simulation, data : float
        Feature of the model (``S``) and of the measurement (``D``).
    error : float
        Comparison error ``E = S - D``.
    u_num, u_input, u_data : float
        Standard uncertainties: numerical, from model inputs, of the data.
    u_val : float
        Validation uncertainty ``sqrt(u_num^2 + u_input^2 + u_data^2)``.
    k : float
        Coverage factor.
    lower, upper : float
        Bounds of the model error, ``E -+ k u_val``.
    normalised_error : float
        ``E / u_val`` (+-inf when ``u_val`` is 0 and ``E`` is not; 0 when both are).
    resolved : bool
        ``|E| > k u_val``: the model error is resolved by the comparison.
    """

    simulation: float
    data: float
    error: float
    u_num: float
    u_input: float
    u_data: float
    u_val: float
    k: float
    lower: float
    upper: float
    normalised_error: float
    resolved: bool


@dataclasses.dataclass(frozen=True)
class VV20Scores(Scores):
    """V&V 20 comparisons of the peak and the RMS feature.

    Attributes
    ----------
    peak, rms : VV20Feature
        One comparison per feature.
    """

    peak: VV20Feature
    rms: VV20Feature

    def as_dict(self) -> dict[str, Any]:
        """Return the scores by name, flattened as ``"<feature>.<field>"``.

        Returns
        -------
        dict
            For example ``{"peak.error": ..., "peak.u_val": ..., "rms.error": ...}``.
        """
        return {f"{feature}.{name}": value for feature in FEATURES
                for name, value in getattr(self, feature).as_dict().items()}


def vv20(measured: Any, model: Any, *, u_num: Uncertainty = 0.0, u_input: Uncertainty = 0.0,
         u_measurement: Uncertainty = 0.0, u_measurement_rel: Uncertainty = 0.0,
         cycles: Any = None, k: float = 2.0) -> VV20Scores:
    """Compare the model's peak and RMS with the measured ones against validation uncertainty.

    Parameters
    ----------
    measured : array_like or xarray.DataArray
        Measured signal (for cyclic data the cycle mean), any units.
    model : array_like or xarray.DataArray
        Model signal on the same grid, same units.
    u_num : float or mapping, optional
        Numerical standard uncertainty of the model feature (integrator, angle grid), signal
        units. A float applies to both features; a mapping gives ``{"peak": ..., "rms": ...}``.
    u_input : float or mapping, optional
        Standard uncertainty of the model feature from uncertain inputs (masses, inertias, drive
        law), propagated by the caller, signal units.
    u_measurement : float or mapping, optional
        Systematic standard uncertainty of the measured feature, signal units (calibration,
        DAQ, mounting).
    u_measurement_rel : float or mapping, optional
        Systematic standard uncertainty of the measured feature as a fraction of it (a sensor
        sensitivity known to 2 % gives 0.02).
    cycles : array_like or xarray.DataArray, optional
        The measured cycles, shape ``(n_cycles, n_samples)``: adds the random part of the data
        uncertainty, ``std(per-cycle feature) / sqrt(n_cycles)``.
    k : float
        Coverage factor (2: about 95 %).

    Returns
    -------
    VV20Scores
        One :class:`VV20Feature` per feature.

    Raises
    ------
    ConfigError
        For a negative uncertainty, an unknown feature name in a mapping or ``k <= 0``.
    DataError
        On bad samples or cycles that do not match the signal's length.

    Notes
    -----
    Uncertainties are assumed independent (combined in quadrature). The default zeros mean "not
    stated", and with all of them zero any non-zero error counts as resolved.
    """
    m, c = paired(measured, model)
    if not k > 0:
        raise ConfigError(f"coverage factor k must be positive, got {k}", where={"key": "k"},
                          hint="use k = 2 for about 95 %")
    random = _random_uncertainty(cycles, m.size)
    features = {}
    for feature in FEATURES:
        simulation, data = float(_feature(c, feature)), float(_feature(m, feature))
        parts = {name: _component(value, feature, name) for name, value in (
            ("u_num", u_num), ("u_input", u_input), ("u_measurement", u_measurement),
            ("u_measurement_rel", u_measurement_rel))}
        u_data = math.sqrt(parts["u_measurement"] ** 2
                           + (parts["u_measurement_rel"] * abs(data)) ** 2
                           + random[feature] ** 2)
        u_val = math.sqrt(parts["u_num"] ** 2 + parts["u_input"] ** 2 + u_data**2)
        error = simulation - data
        features[feature] = VV20Feature(
            simulation=simulation, data=data, error=error, u_num=parts["u_num"],
            u_input=parts["u_input"], u_data=u_data, u_val=u_val, k=float(k),
            lower=error - k * u_val, upper=error + k * u_val,
            normalised_error=_normalised(error, u_val), resolved=bool(abs(error) > k * u_val))
    return VV20Scores(**features)


def _feature(values: np.ndarray, feature: str) -> np.ndarray:
    """Peak (max |x|) or RMS of a signal or, along the last axis, of each cycle."""
    if feature == "peak":
        return np.max(np.abs(values), axis=-1)
    return np.sqrt(np.mean(values * values, axis=-1))


def _random_uncertainty(cycles: Any, n: int) -> dict[str, float]:
    """Return the mean feature's uncertainty from cycle-to-cycle scatter (0 without cycles)."""
    if cycles is None:
        return dict.fromkeys(FEATURES, 0.0)
    array = as_cycles(cycles, n)
    return {feature: float(np.std(_feature(array, feature), ddof=1) / np.sqrt(array.shape[0]))
            for feature in FEATURES}


def _component(value: Uncertainty, feature: str, name: str) -> float:
    """One feature's value of an uncertainty given as a float or a per-feature mapping."""
    if isinstance(value, Mapping):
        unknown = set(value) - set(FEATURES)
        if unknown:
            raise ConfigError(f"unknown feature {sorted(unknown)} in {name}", where={"key": name},
                              hint=f"use the features {', '.join(FEATURES)}")
        value = value.get(feature, 0.0)
    number = float(value)
    if not (np.isfinite(number) and number >= 0.0):
        raise ConfigError(f"{name} must be a finite standard uncertainty >= 0, got {value}",
                          where={"key": f"{name}.{feature}"}, hint="give a standard uncertainty")
    return number


def _normalised(error: float, u_val: float) -> float:
    """``error / u_val`` with the limits for ``u_val == 0``."""
    if u_val > 0.0:
        return error / u_val
    return 0.0 if error == 0.0 else math.copysign(math.inf, error)
