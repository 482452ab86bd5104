"""Wheatstone strain bridges: NI's seven conversion equations and their exact forward model.

Conventions follow NI (white paper 7130, NI-DAQmx "Strain Gage" measurement fundamentals): the
bridge output is ``Vo = Vex (R3/(R3+R4) - R2/(R1+R2))``, the active quarter-bridge gauge sits in
R4, so tension gives a negative ``Vo`` and every NI equation carries a leading minus sign. The
offset-nulled voltage ratio is ``Vr = (Vo - Vo_unstrained) / Vex``.

The forward model (:func:`bridge_arms`, :func:`bridge_ratio`, :func:`balanced_bridge_ratio`) is the
exact resistor divider with gauge arms ``Rg (1 + GF eps)`` and lead resistance in series with the
arms the wiring puts it in. It is the independent truth the NI inverses are tested against and the
source the virtual rig synthesises raw bridge signals from.

Exactness of NI's inverses against this forward model (offset-nulled, nominal bridge):

============  ==========================================================================
bridge type   inverse
============  ==========================================================================
quarter_i     exact, including the 3-wire lead term ``(1 + RL/Rg)``
quarter_ii    exact (the dummy gauge sits in R3 and sees no strain)
half_i        exact, including the lead term
half_ii       exact, including the lead term
full_i        exact
full_ii       exact (NI's arms: R1 ``-nu eps``, R2 ``+nu eps``, R3 ``-eps``, R4 ``+eps``, so
              ``Vr = -GF eps (1 + nu) / 2`` with no higher-order term)
full_iii      exact
============  ==========================================================================

Full bridges carry no lead term: the NI 9237 senses the excitation remotely. The 2-wire lead
attenuation of a quarter bridge is ``Rg / (Rg + 2 RL)`` and is corrected by passing ``2 RL`` as the
lead resistance.
"""

from __future__ import annotations

import logging
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from rigval.acquisition.errors import ConfigError
from rigval.processing.arrays import FloatArray, writable_float64

__all__ = [
    "BRIDGE_TYPES",
    "BridgeType",
    "balanced_bridge_ratio",
    "bridge_arms",
    "bridge_ratio",
    "shunt_gain_adjust",
    "shunt_simulated_strain",
    "strain_from_ratio",
    "voltage_ratio",
    "wheatstone_ratio",
]

logger = logging.getLogger(__name__)

BridgeType = Literal["quarter_i", "quarter_ii", "half_i", "half_ii", "full_i", "full_ii",
                     "full_iii"]
#: NI's seven bridge configurations (DAQmx ``AI.StrainGage.Cfg``, Quarter Bridge I to Full III).
BRIDGE_TYPES: tuple[str, ...] = ("quarter_i", "quarter_ii", "half_i", "half_ii", "full_i",
                                 "full_ii", "full_iii")


def _check_type(bridge_type: str) -> None:
    if bridge_type not in BRIDGE_TYPES:
        raise ConfigError(f"unknown bridge type {bridge_type!r}", where={"key": "bridge_type"},
                          hint=f"use one of {', '.join(BRIDGE_TYPES)}")


def wheatstone_ratio(r1: ArrayLike, r2: ArrayLike, r3: ArrayLike, r4: ArrayLike) -> FloatArray:
    """Return the exact output ratio ``Vo/Vex = R3/(R3+R4) - R2/(R1+R2)`` of a Wheatstone bridge.

    Parameters
    ----------
    r1, r2, r3, r4 : array_like
        Arm resistances in ohm (NI labelling: the active quarter-bridge gauge is R4).

    Returns
    -------
    numpy.ndarray
        Output voltage over excitation voltage, V/V.
    """
    r1, r2, r3, r4 = (np.asarray(r, dtype=np.float64) for r in (r1, r2, r3, r4))
    return r3 / (r3 + r4) - r2 / (r1 + r2)


def balanced_bridge_ratio(base_12: ArrayLike, base_34: ArrayLike, d1: ArrayLike, d2: ArrayLike,
                          d3: ArrayLike, d4: ArrayLike) -> FloatArray:
    """Return the exact ``Vo/Vex`` of a bridge given as nominal arms plus deviations.

    With ``R1 = a + d1``, ``R2 = a + d2``, ``R3 = b + d3``, ``R4 = b + d4`` the output is
    ``(R1 R3 - R2 R4) / ((R1 + R2)(R3 + R4))`` and its numerator ``a (d3 - d4) + b (d1 - d2) +
    d1 d3 - d2 d4`` is formed without subtracting the large nominal products, so small strains keep
    full relative precision (:func:`wheatstone_ratio` loses ``1e-16 / (GF eps)`` to cancellation).

    Parameters
    ----------
    base_12, base_34 : array_like
        Nominal resistance a of arms R1, R2 and b of arms R3, R4 in ohm.
    d1, d2, d3, d4 : array_like
        Deviations of the four arms from their nominal in ohm.

    Returns
    -------
    numpy.ndarray
        Vo/Vex in V/V.
    """
    a, b, d1, d2, d3, d4 = (np.asarray(v, dtype=np.float64) for v in (base_12, base_34, d1, d2,
                                                                      d3, d4))
    numerator = a * (d3 - d4) + b * (d1 - d2) + (d1 * d3 - d2 * d4)
    return numerator / ((2.0 * a + d1 + d2) * (2.0 * b + d3 + d4))


def _arm_strains(eps: FloatArray, bridge_type: str, poisson: float) -> tuple[FloatArray, ...]:
    """Return the strain each arm's gauge sees (0 for completion resistors and dummies)."""
    nu, zero = poisson, np.zeros_like(eps)
    arms = {
        "quarter_i": (zero, zero, zero, eps),
        "quarter_ii": (zero, zero, zero, eps),
        "half_i": (zero, zero, -nu * eps, eps),
        "half_ii": (zero, zero, -eps, eps),
        "full_i": (-eps, eps, -eps, eps),
        "full_ii": (-nu * eps, nu * eps, -eps, eps),
        "full_iii": (-nu * eps, eps, -nu * eps, eps),
    }
    return arms[bridge_type]


def bridge_arms(strain: ArrayLike, bridge_type: BridgeType, *, gauge_factor: float,
                poisson: float = 0.3, gauge_resistance: float = 120.0,
                lead_resistance: float = 0.0) -> tuple[FloatArray, ...]:
    """Return the four arm resistances of an NI bridge configuration under a strain.

    Gauge arms are ``Rg (1 + GF eps_arm)``; completion arms (and the quarter II dummy, which sees
    no strain) are ``Rg``. The lead resistance is put in series with the arms the NI wiring puts
    it in: quarter bridges (3-wire) one lead in R4 and one in R3, half bridges one lead in R3 and
    one in R4 (the middle lead is the sense line and carries no current); full bridges are
    remote-sensed and have none.

    Parameters
    ----------
    strain : array_like
        The strain NI's equation returns for this configuration (1, i.e. m/m): the axial strain
        for quarter, half I and full III bridges, the bending (or +-45 degree shear-grid) strain
        for half II, full I and full II.
    bridge_type : {"quarter_i", "quarter_ii", "half_i", "half_ii", "full_i", "full_ii", "full_iii"}
        NI configuration.
    gauge_factor : float
        Gauge factor GF (1).
    poisson : float, default 0.3
        Poisson ratio of the specimen (1), used by half I, full II and full III.
    gauge_resistance : float, default 120
        Nominal gauge and completion resistance Rg in ohm.
    lead_resistance : float, default 0
        Resistance of one lead wire in ohm (quarter and half bridges).

    Returns
    -------
    tuple of numpy.ndarray
        ``(R1, R2, R3, R4)`` in ohm.
    """
    _check_type(bridge_type)
    eps = np.asarray(strain, dtype=np.float64)
    lead = 0.0 if bridge_type.startswith("full") else lead_resistance
    r1, r2, r3, r4 = (gauge_resistance * (1.0 + gauge_factor * e)
                      for e in _arm_strains(eps, bridge_type, poisson))
    return r1, r2, r3 + lead, r4 + lead


def bridge_ratio(strain: ArrayLike, bridge_type: BridgeType, *, gauge_factor: float,
                 poisson: float = 0.3, gauge_resistance: float = 120.0,
                 lead_resistance: float = 0.0) -> FloatArray:
    """Return the exact offset-free bridge output ``Vo/Vex`` (V/V) for a strain (forward model).

    Parameters are those of :func:`bridge_arms`; the arithmetic is that of
    :func:`balanced_bridge_ratio`. The unstrained nominal bridge is balanced, so the result is
    also the offset-nulled voltage ratio ``Vr``.
    """
    _check_type(bridge_type)
    eps = np.asarray(strain, dtype=np.float64)
    lead = 0.0 if bridge_type.startswith("full") else lead_resistance
    deviations = (gauge_resistance * gauge_factor * e
                  for e in _arm_strains(eps, bridge_type, poisson))
    return balanced_bridge_ratio(gauge_resistance, gauge_resistance + lead, *deviations)


def voltage_ratio(output_voltage: ArrayLike, excitation_voltage: ArrayLike,
                  unstrained_output_voltage: ArrayLike = 0.0) -> FloatArray:
    """Return the offset-nulled voltage ratio ``Vr = (Vo - Vo_unstrained) / Vex`` (V/V).

    Parameters
    ----------
    output_voltage : array_like
        Bridge output Vo in V.
    excitation_voltage : array_like
        Excitation Vex in V (the measured value when the module reports it).
    unstrained_output_voltage : array_like, default 0
        Vo of the unloaded bridge in V (software offset null; mean over a quiet, unloaded period or
        over whole cycles).

    Returns
    -------
    numpy.ndarray
        Vr in V/V.
    """
    vo = np.asarray(output_voltage, dtype=np.float64)
    return (vo - np.asarray(unstrained_output_voltage, dtype=np.float64)) / np.asarray(
        excitation_voltage, dtype=np.float64)


def strain_from_ratio(ratio: ArrayLike, bridge_type: BridgeType, *, gauge_factor: float,
                      poisson: float = 0.3, gauge_resistance: float = 120.0,
                      lead_resistance: float = 0.0, gain_adjust: float = 1.0,
                      overwrite: bool = False) -> FloatArray:
    """Convert an offset-nulled voltage ratio to strain with NI's equation for the bridge type.

    Parameters
    ----------
    ratio : array_like
        Offset-nulled voltage ratio Vr in V/V (see :func:`voltage_ratio`).
    bridge_type : {"quarter_i", "quarter_ii", "half_i", "half_ii", "full_i", "full_ii", "full_iii"}
        NI configuration (module docstring lists which inverses are exact).
    gauge_factor : float
        Gauge factor GF (1).
    poisson : float, default 0.3
        Poisson ratio (1) for half I, full II and full III.
    gauge_resistance : float, default 120
        Gauge resistance Rg in ohm (lead correction of quarter and half bridges).
    lead_resistance : float, default 0
        Lead resistance RL in ohm in series with the gauge (quarter and half bridges; pass twice the
        lead resistance for a 2-wire quarter bridge).
    gain_adjust : float, default 1
        Shunt-calibration gain factor (see :func:`shunt_gain_adjust`), multiplied into the result.
    overwrite : bool, default False
        A float64 ``ratio`` array of the caller's own becomes the strain (memory: one
        whole-record array less; ``ratio`` must not be used afterwards).

    Returns
    -------
    numpy.ndarray
        Strain in 1 (m/m).
    """
    _check_type(bridge_type)
    if gauge_factor <= 0:
        raise ConfigError(f"gauge factor must be positive, got {gauge_factor}",
                          where={"key": "gauge_factor"})
    vr = np.asarray(ratio, dtype=np.float64)
    gf, nu = gauge_factor, poisson
    lead = 1.0 + lead_resistance / gauge_resistance
    # The formulas below, evaluated in place: two whole-record arrays instead of up to five
    # (memory), the same operations in the same order (identical values); with ``overwrite``
    # the strain is made in the ratio's memory, after the denominator has taken the ratio.
    own = overwrite and writable_float64(ratio)

    def scaled(factor: float) -> FloatArray:  # factor * vr (a product: either order)
        return np.multiply(vr, factor, out=vr) if own else factor * vr

    if bridge_type in ("quarter_i", "quarter_ii"):  # -4 vr / (gf (1 + 2 vr)) lead
        den = 2.0 * vr
        eps = scaled(-4.0)
        den += 1.0
        den *= gf
        eps /= den
        eps *= lead
    elif bridge_type == "half_i":  # -4 vr / (gf ((1 + nu) - 2 vr (nu - 1))) lead
        den = 2.0 * vr
        eps = scaled(-4.0)
        den *= nu - 1.0
        den = np.subtract(1.0 + nu, den, out=den if den.ndim else None)
        den *= gf
        eps /= den
        eps *= lead
    elif bridge_type == "half_ii":  # -2 vr / gf lead
        eps = scaled(-2.0)
        eps /= gf
        eps *= lead
    elif bridge_type == "full_i":
        eps = np.negative(vr, out=vr if own else None)
        eps /= gf
    elif bridge_type == "full_ii":
        eps = scaled(-2.0)
        eps /= gf * (nu + 1.0)
    else:  # full_iii: -2 vr / (gf ((nu + 1) - vr (nu - 1)))
        den = vr * (nu - 1.0)
        eps = scaled(-2.0)
        den = np.subtract(nu + 1.0, den, out=den if den.ndim else None)
        den *= gf
        eps /= den
    eps *= gain_adjust
    return eps


def shunt_simulated_strain(gauge_resistance: float, shunt_resistance: float,
                           gauge_factor: float) -> float:
    """Return the exact strain simulated by shunting a quarter-bridge gauge (Vishay TN-514).

    Parameters
    ----------
    gauge_resistance : float
        Gauge resistance Rg in ohm.
    shunt_resistance : float
        Shunt resistor Rs in ohm (NI 9237 internal: 100 kOhm).
    gauge_factor : float
        Gauge factor (1).

    Returns
    -------
    float
        ``-Rg / (GF (Rg + Rs))`` in 1 (negative: shunting lowers the arm resistance).
    """
    return -gauge_resistance / (gauge_factor * (gauge_resistance + shunt_resistance))


def shunt_gain_adjust(simulated_strain: float, measured_strain: float) -> float:
    """Return NI's shunt-calibration gain factor ``simulated / measured`` (1).

    Measure with the offset already nulled; multiply the factor into every later reading
    (``gain_adjust`` of :func:`strain_from_ratio`).
    """
    if measured_strain == 0 or not np.isfinite(measured_strain):
        raise ConfigError(f"shunt calibration measured a strain of {measured_strain}",
                          where={"key": "shunt_calibration"},
                          hint="check that the shunt was engaged while the reading was taken")
    return simulated_strain / measured_strain
