"""ASME V&V 20 comparison error against validation uncertainty for peak and RMS features.

For a scalar feature (system response quantity) of simulation ``S`` and data ``D`` the comparison
error is ``E = S - D`` and the validation uncertainty ``u_val = sqrt(u_num^2 + u_input^2 +
u_D^2)``; the model error lies in ``[E - k u_val, E + k u_val]`` (k = 2: about 95 % for roughly
Gaussian errors). ``|E| > k u_val`` resolves a model error of about ``E``; otherwise the model
error cannot be resolved at this uncertainty, which does not prove the model right (ASME V&V
20-2009 (R2016), sections 1-2).

The whole curve over phi_F is compared too (:class:`VV20Curve`): ``E`` is the RMS over the angle
grid of ``S(phi) - D(phi)`` and ``u_val`` the RMS of the pointwise validation uncertainty, built
from named parts (sensor calibration, clock alignment, cycle-to-cycle scatter, angle grid, drive
angle, model inputs). Under the hypothesis "no model error" and independent parts the expected
``E^2`` is ``u_val^2``, so ``|E| > k u_val`` is the curve's statement "model error detected".

A calibration gain error is one number for the whole curve. Each curve also reports its fitted
gain (``S`` against ``D`` about their means) with the gain's standard uncertainty apart from the
part of the calibration that the comparison states as common to its sensor kind
(``u_measurement_rel_common``); :func:`common_gain` compares the gains of several comparisons whose
sensors share that part: a model error whose effect looks like a gain on one channel (a body's
inertia on a drive torque dominated by it) shows as gains that no common calibration error can
explain (ASME V&V 20-2009, section 4: correlated systematic errors).
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from rigval.acquisition.errors import ConfigError
from rigval.validation.metrics.core import Scores, as_cycles, paired

__all__ = ["CURVE_PARTS", "FEATURES", "CommonGain", "VV20Curve", "VV20Feature", "VV20Scores",
           "common_gain", "vv20", "vv20_curve"]

logger = logging.getLogger(__name__)

FEATURES: tuple[str, ...] = ("peak", "rms")
"""Features rated: ``peak`` = max |x| and ``rms`` = sqrt(mean x^2) over the samples given."""

Uncertainty = float | Mapping[str, float]

CURVE_PARTS: tuple[str, ...] = ("u_calibration", "u_alignment", "u_scatter", "u_grid", "u_drive",
                                "u_input")
"""Parts of the curve's validation uncertainty, in the order they are reported."""


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
class VV20Curve(Scores):
    """V&V 20 comparison of the whole curve over phi_F (all values in the signals' units).

    Attributes
    ----------
    error : float
        ``E``: RMS over the grid of ``S(phi) - D(phi)`` (>= 0).
    u_val : float
        RMS over the grid of the pointwise validation uncertainty; ``u_val^2`` is the sum of the
        squared parts below.
    k : float
        Coverage factor.
    u_calibration : float
        Sensor calibration: ``sqrt(u_measurement^2 + (u_measurement_rel D)^2)``, RMS.
    u_alignment : float
        Clock alignment carried through: ``|dD/dphi| omega u_time``, RMS.
    u_scatter : float
        Cycle-to-cycle scatter of the measured mean: ``std_cycles / sqrt(n_cycles)``, RMS.
    u_grid : float
        Angle-grid (numerical) uncertainty of the model, ``u_num``.
    u_drive : float
        Drive-angle uncertainty: ``|dS/dphi| u_drive_angle``, RMS.
    u_input : float
        Model-input uncertainty stated by the caller.
    normalised_error : float
        ``E / u_val`` (+inf when ``u_val`` is 0 and ``E`` is not; 0 when both are).
    detected : bool
        ``E > k u_val``: a model error is detected.
    dominant : str
        Name of the largest part of ``u_val``.
    gain : float
        Fitted gain of the model against the measurement, a fraction: ``S - mean(S) = (1 + gain)
        (D - mean(D))`` in the least-squares sense, with a free offset.
    u_gain_own : float
        Standard uncertainty of ``gain`` without the calibration part common to the sensor kind,
        the quadrature sum of: the own calibration part ``sqrt(u_measurement_rel^2 -
        u_measurement_rel_common^2)``; the cycle scatter's, ``std(per-cycle gain) /
        sqrt(n_cycles)``; and ``sqrt(u_num^2 + u_input^2 + u_measurement^2) / rms(D - mean D)``
        (their effect bounded as if parallel to ``D``). Alignment and drive angle shift the curve
        along phi, an error proportional to its slope, which is orthogonal to ``D`` over a
        revolution: they do not move the gain.
    """

    error: float
    u_val: float
    k: float
    u_calibration: float
    u_alignment: float
    u_scatter: float
    u_grid: float
    u_drive: float
    u_input: float
    normalised_error: float
    detected: bool
    dominant: str
    gain: float
    u_gain_own: float

    def statement(self, units: str = "") -> str:
        """Return the verdict in words with its numbers.

        Parameters
        ----------
        units : str
            Unit of the signal, appended to ``E`` and ``u_val``.

        Returns
        -------
        str
            ``"Model error detected (|E| > k u_val): E = ..., u_val = ..., k = 2"`` or ``"Model
            error not detected (|E| <= k u_val): ..."``.
        """
        unit = f" {units}" if units and units != "1" else ""
        head = ("Model error detected (|E| > k u_val)" if self.detected
                else "Model error not detected (|E| <= k u_val)")
        ratio = error_ratio(self.error, self.k * self.u_val)
        return (f"{head}: E = {self.error:.4g}{unit}, u_val = {self.u_val:.4g}{unit}, "
                f"k = {self.k:g}, |E|/(k u_val) = {ratio:.2f}")


@dataclasses.dataclass(frozen=True)
class CommonGain(Scores):
    """V&V 20 statement on one comparison's gain against the common gain of its group.

    Attributes
    ----------
    gain : float
        The comparison's fitted gain (:attr:`VV20Curve.gain`), fraction.
    group_gain : float
        The group's common gain: the mean of its comparisons' gains weighted by ``1 /
        u_gain_own^2``, fraction.
    error : float
        ``gain - group_gain``.
    u_val : float
        Standard uncertainty of ``error`` under "no model error": ``sqrt(u_own^2 - s^2)`` with
        ``s^2 = 1 / sum(1 / u_own_j^2)`` over the group (the comparison is part of the mean).
    k : float
        Coverage factor.
    normalised_error : float
        ``error / u_val``.
    detected : bool
        ``|error| > k u_val``: no calibration error common to the group explains the gains.
    group : str
        The group's comparisons, comma-separated.
    """

    gain: float
    group_gain: float
    error: float
    u_val: float
    k: float
    normalised_error: float
    detected: bool
    group: str


@dataclasses.dataclass(frozen=True)
class VV20Scores(Scores):
    """V&V 20 comparisons of the peak and the RMS feature and of the whole curve.

    Attributes
    ----------
    peak, rms : VV20Feature
        One comparison per feature.
    curve : VV20Curve
        The whole curve over phi_F.
    """

    peak: VV20Feature
    rms: VV20Feature
    curve: VV20Curve

    def as_dict(self) -> dict[str, Any]:
        """Return the scores by name, flattened as ``"<feature>.<field>"``.

        Returns
        -------
        dict
            For example ``{"peak.error": ..., "peak.u_val": ..., "curve.detected": ...}``.
        """
        return {f"{feature}.{name}": value for feature in (*FEATURES, "curve")
                for name, value in getattr(self, feature).as_dict().items()}


def vv20(measured: Any, model: Any, *, u_num: Uncertainty = 0.0, u_input: Uncertainty = 0.0,
         u_measurement: Uncertainty = 0.0, u_measurement_rel: Uncertainty = 0.0,
         u_measurement_rel_common: float = 0.0, cycles: Any = None, k: float = 2.0,
         u_time: float = 0.0, speed: float = 0.0, u_drive_angle: float = 0.0) -> VV20Scores:
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
    u_measurement_rel_common : float, optional
        For the curve only (see :func:`vv20_curve`): the part of the RMS feature's
        ``u_measurement_rel`` common to every comparison of the same sensor kind that states it.
    cycles : array_like or xarray.DataArray, optional
        The measured cycles, shape ``(n_cycles, n_samples)``: adds the random part of the data
        uncertainty, ``std(per-cycle feature) / sqrt(n_cycles)``.
    k : float
        Coverage factor (2: about 95 %).
    u_time, speed, u_drive_angle : float
        For the curve only (see :func:`vv20_curve`): clock-alignment standard uncertainty (s),
        main-shaft speed (rad/s) and drive-angle standard uncertainty (rad).

    Returns
    -------
    VV20Scores
        One :class:`VV20Feature` per feature and the :class:`VV20Curve`.

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
    curve = vv20_curve(m, c, cycles=cycles, u_num=_component(u_num, "rms", "u_num"),
                       u_input=_component(u_input, "rms", "u_input"),
                       u_measurement=_component(u_measurement, "rms", "u_measurement"),
                       u_measurement_rel=_component(u_measurement_rel, "rms",
                                                    "u_measurement_rel"),
                       u_measurement_rel_common=u_measurement_rel_common, u_time=u_time,
                       speed=speed, u_drive_angle=u_drive_angle, k=k)
    return VV20Scores(**features, curve=curve)


def vv20_curve(measured: Any, model: Any, *, cycles: Any = None, u_num: float = 0.0,
               u_input: float = 0.0, u_measurement: float = 0.0,
               u_measurement_rel: float = 0.0, u_measurement_rel_common: float = 0.0,
               u_time: float = 0.0, speed: float = 0.0, u_drive_angle: float = 0.0,
               k: float = 2.0) -> VV20Curve:
    """Compare the whole model curve over one revolution with the measured mean.

    Parameters
    ----------
    measured : array_like
        Measured mean over one revolution, uniform angle grid without the repeated end sample.
    model : array_like
        Model on the same grid, same units.
    cycles : array_like, optional
        Measured cycles ``(n_cycles, n)``: the scatter part ``std / sqrt(n_cycles)`` per angle.
    u_num : float
        Angle-grid (numerical) standard uncertainty of the model, signal units.
    u_input : float
        Model-input standard uncertainty, signal units.
    u_measurement : float
        Absolute calibration standard uncertainty of the sensor, signal units.
    u_measurement_rel : float
        Relative calibration standard uncertainty (a gain known to 1 % gives 0.01).
    u_measurement_rel_common : float
        The part of ``u_measurement_rel`` common to the sensors of the same kind (same gauge lot,
        material, drawing), at most ``u_measurement_rel``; only ``u_gain_own`` uses it.
    u_time : float
        Standard uncertainty of the channel's time on the reference clock after alignment, s.
    speed : float
        Main-shaft speed, rad/s (turns ``u_time`` into an angle).
    u_drive_angle : float
        Standard uncertainty of the drive angles the model runs on, rad.
    k : float
        Coverage factor.

    Returns
    -------
    VV20Curve
        ``E``, ``u_val``, its parts and the verdict.

    Raises
    ------
    ConfigError
        For a negative or non-finite uncertainty, a common part above ``u_measurement_rel`` or
        ``k <= 0``.
    DataError
        On bad samples or cycles that do not match the signal's length.

    Notes
    -----
    Slopes are periodic central differences over the grid. The parts are taken as independent
    and combined in quadrature at every angle; each reported part is its RMS over the grid, so
    ``u_val^2`` is the sum of the squared parts.
    """
    m, c = paired(measured, model)
    if not k > 0:
        raise ConfigError(f"coverage factor k must be positive, got {k}", where={"key": "k"},
                          hint="use k = 2 for about 95 %")
    for name, value in (("u_num", u_num), ("u_input", u_input), ("u_measurement", u_measurement),
                        ("u_measurement_rel", u_measurement_rel),
                        ("u_measurement_rel_common", u_measurement_rel_common),
                        ("u_time", u_time), ("speed", speed), ("u_drive_angle", u_drive_angle)):
        _component(value, "curve", name)
    if u_measurement_rel_common > u_measurement_rel:
        raise ConfigError(f"u_measurement_rel_common ({u_measurement_rel_common}) exceeds "
                          f"u_measurement_rel ({u_measurement_rel})",
                          where={"key": "u_measurement_rel_common"},
                          hint="state the common part of the calibration uncertainty, at most "
                               "the whole (docs/metrics.md)")
    step = 2.0 * np.pi / m.size
    scatter = (np.zeros(m.size) if cycles is None
               else np.std(as_cycles(cycles, m.size), axis=0, ddof=1)
               / np.sqrt(as_cycles(cycles, m.size).shape[0]))
    pointwise = {
        "u_calibration": np.hypot(u_measurement, u_measurement_rel * np.abs(m)),
        "u_alignment": np.abs(_slope(m, step)) * abs(speed) * u_time,
        "u_scatter": scatter,
        "u_grid": np.full(m.size, float(u_num)),
        "u_drive": np.abs(_slope(c, step)) * u_drive_angle,
        "u_input": np.full(m.size, float(u_input)),
    }
    parts = {name: float(np.sqrt(np.mean(values**2))) for name, values in pointwise.items()}
    u_val = math.sqrt(sum(value**2 for value in parts.values()))
    error = float(np.sqrt(np.mean((c - m) ** 2)))
    dominant = max(parts, key=parts.__getitem__)
    gain, size = _gain(m, c)
    own = (u_measurement_rel - u_measurement_rel_common) * (u_measurement_rel
                                                            + u_measurement_rel_common)
    scatter_gain = 0.0
    if cycles is not None and size > 0.0:
        array = as_cycles(cycles, m.size)
        centred = m - m.mean()
        per_cycle = (array - m) @ centred / (centred @ centred)
        scatter_gain = float(np.std(per_cycle, ddof=1) / np.sqrt(array.shape[0]))
    rest = math.hypot(u_num, u_input, u_measurement)
    u_gain_own = (math.sqrt(own + scatter_gain**2 + (rest / size) ** 2) if size > 0.0
                  else math.inf)
    logger.debug("V&V 20 curve: E %.4g, u_val %.4g (%s), gain %.4g +- %.3g", error, u_val,
                 parts, gain, u_gain_own)
    return VV20Curve(error=error, u_val=u_val, k=float(k), **parts,
                     normalised_error=_normalised(error, u_val),
                     detected=bool(error > k * u_val), dominant=dominant, gain=gain,
                     u_gain_own=u_gain_own)


def common_gain(gains: Mapping[str, tuple[float, float]], k: float = 2.0
                ) -> dict[str, CommonGain]:
    """Compare the gains of comparisons whose sensors share one calibration error.

    Parameters
    ----------
    gains : mapping of str to (float, float)
        Per comparison its fitted gain and that gain's standard uncertainty apart from the common
        calibration part (:attr:`VV20Curve.gain`, :attr:`VV20Curve.u_gain_own`), fractions. At
        least two, every uncertainty finite and positive.
    k : float
        Coverage factor.

    Returns
    -------
    dict of str to CommonGain
        Per comparison: its gain against the group's weighted mean gain.

    Raises
    ------
    ConfigError
        For fewer than two comparisons, an uncertainty that is not finite and positive or
        ``k <= 0``.

    Notes
    -----
    Under "no model error" the gain of comparison ``c`` is ``g + e_c``: ``g`` the common
    calibration error and ``e_c`` the comparison's own, independent, of standard uncertainty
    ``u_c``. The weighted mean ``g_bar = sum(w_j g_j)``, ``w_j = s^2 / u_j^2``, ``s^2 = 1 /
    sum(1 / u_j^2)``, removes ``g``; ``g_c - g_bar`` has the variance ``u_c^2 - s^2``.
    """
    if len(gains) < 2:
        raise ConfigError(f"a common gain needs two comparisons or more, got {len(gains)}",
                          where={"key": "u_measurement_rel_common"},
                          hint="state u_measurement_rel_common on every comparison of that "
                               "sensor kind that shares the calibration")
    if not k > 0:
        raise ConfigError(f"coverage factor k must be positive, got {k}", where={"key": "k"},
                          hint="use k = 2 for about 95 %")
    for name, (_, u_own) in gains.items():
        if not (math.isfinite(u_own) and u_own > 0.0):
            raise ConfigError(f"{name}: the gain's own uncertainty must be finite and positive, "
                              f"got {u_own}", where={"key": "u_measurement_rel_common"},
                              hint="a common gain needs a measured curve that is not constant")
    s2 = 1.0 / sum(1.0 / u**2 for _, u in gains.values())
    group_gain = s2 * sum(g / u**2 for g, u in gains.values())
    group = ", ".join(gains)
    out = {}
    for name, (gain, u_own) in gains.items():
        error = gain - group_gain
        u_val = math.sqrt(max(u_own**2 - s2, 0.0))
        out[name] = CommonGain(gain=gain, group_gain=group_gain, error=error, u_val=u_val,
                               k=float(k), normalised_error=_normalised(error, u_val),
                               detected=bool(abs(error) > k * u_val), group=group)
    return out


def _gain(measured: np.ndarray, model: np.ndarray) -> tuple[float, float]:
    """Least-squares gain of ``model - measured`` on the demeaned measurement, and its RMS."""
    centred = measured - measured.mean()
    power = float(centred @ centred)
    if power == 0.0:
        return 0.0, 0.0
    error = model - measured
    return float(error @ centred) / power, math.sqrt(power / measured.size)


def _slope(values: np.ndarray, step: float) -> np.ndarray:
    """d/dphi of one revolution's samples by periodic central differences."""
    return (np.roll(values, -1) - np.roll(values, 1)) / (2.0 * step)


def error_ratio(error: float, limit: float) -> float:
    """``error / limit`` (for example ``|E| / (k u_val)``), 0 or inf when ``limit == 0``."""
    if limit > 0.0:
        return error / limit
    return 0.0 if error == 0.0 else math.inf


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
