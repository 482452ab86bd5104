"""Shaft torsion from +-45 degree shear rosettes: forward bridge model, shear strain and torque.

Strain transformation on the shaft surface (x axial, uniaxial normal stress so ``eps_y = -nu
eps_x``): ``eps(+-45) = (1 - nu) eps_x / 2 +- gamma / 2``, hence ``gamma = eps(+45) - eps(-45)``.
Torque of a hollow shaft ``T = G gamma pi (D^4 - d^4) / (16 D)`` (``d = 0``: solid).

Bridges (NI labelling, see :mod:`rigval.processing.bridge`):

- half bridge: one rosette, grids in R4 (+45) and R3 (-45) = NI Half Bridge II,
  ``gamma = 2 eps_NI = -4 Vr / GF (1 + RL/Rg)``; cancels axial strain and bending at that spot, not
  transverse shear;
- full bridge: two rosettes 180 degrees apart = NI Full Bridge I (R4, R2: +45 grids; R3, R1: -45
  grids), ``gamma = -2 Vr / GF``; also cancels transverse shear.

With pure torsion both inverses are exact. Axial, bending and transverse-shear strains enter the
full bridge only at second order (about -9e-5 relative for 100/300/50 microstrain against a
500 microstrain shear), the half bridge at first order (transverse shear adds directly).
"""

from __future__ import annotations

import logging
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from rigval.acquisition.errors import ConfigError
from rigval.processing.arrays import FloatArray, writable_float64
from rigval.processing.bridge import balanced_bridge_ratio, strain_from_ratio

#: Torsion rosette bridge forms: two gauges at +-45 degrees (half) or four (full).
Rosette = Literal["half", "full"]

__all__ = [
    "polar_moment",
    "rosette_bridge_ratio",
    "shear_strain_from_ratio",
    "shear_strain_from_torque",
    "torque_from_ratio",
    "torque_from_shear_strain",
]

logger = logging.getLogger(__name__)


def _check_shaft(outer_diameter: float, inner_diameter: float) -> None:
    if not 0 <= inner_diameter < outer_diameter:
        raise ConfigError(
            f"shaft diameters must satisfy 0 <= d < D, got D={outer_diameter} m, "
            f"d={inner_diameter} m", where={"key": "inner_diameter"},
            hint="give diameters in m; d = 0 for a solid shaft")


def polar_moment(outer_diameter: float, inner_diameter: float = 0.0) -> float:
    """Return the polar second moment of area ``J = pi (D^4 - d^4) / 32`` in m^4.

    Parameters
    ----------
    outer_diameter : float
        Outer diameter D in m.
    inner_diameter : float, default 0
        Bore diameter d in m (0 for a solid shaft).
    """
    _check_shaft(outer_diameter, inner_diameter)
    return float(np.pi * (outer_diameter**4 - inner_diameter**4) / 32.0)


def torque_from_shear_strain(shear_strain: ArrayLike, *, shear_modulus: float,
                             outer_diameter: float, inner_diameter: float = 0.0,
                             overwrite: bool = False) -> FloatArray:
    """Return shaft torque ``T = G gamma J / (D/2)`` in N m from surface shear strain.

    Parameters
    ----------
    shear_strain : array_like
        Engineering shear strain gamma at the outer surface (1, rad).
    shear_modulus : float
        Shear modulus G in Pa.
    outer_diameter, inner_diameter : float
        Shaft diameters in m (inner 0 for a solid shaft).
    overwrite : bool, default False
        A float64 ``shear_strain`` array of the caller's own becomes the torque (memory: no
        whole-record temporaries; the same operations in the same order, identical values;
        ``shear_strain`` must not be used afterwards).
    """
    j = polar_moment(outer_diameter, inner_diameter)
    gamma = np.asarray(shear_strain, dtype=np.float64)
    if not (overwrite and writable_float64(gamma)):
        return gamma * shear_modulus * j / (outer_diameter / 2.0)
    gamma *= shear_modulus
    gamma *= j
    gamma /= outer_diameter / 2.0
    return gamma


def shear_strain_from_torque(torque: ArrayLike, *, shear_modulus: float, outer_diameter: float,
                             inner_diameter: float = 0.0) -> FloatArray:
    """Return surface shear strain gamma (1) of a shaft under torque (N m); inverse of the above."""
    j = polar_moment(outer_diameter, inner_diameter)
    return np.asarray(torque, dtype=np.float64) * (outer_diameter / 2.0) / (shear_modulus * j)


def rosette_bridge_ratio(shear_strain: ArrayLike, rosette: Rosette, *, gauge_factor: float,
                         poisson: float = 0.3, axial_strain: ArrayLike = 0.0,
                         bending_strain: ArrayLike = 0.0, transverse_shear: ArrayLike = 0.0,
                         gauge_resistance: float = 120.0,
                         lead_resistance: float = 0.0) -> FloatArray:
    """Return the exact bridge output ``Vo/Vex`` of a torsion rosette bridge (forward model).

    Each grid is a resistor ``Rg (1 + GF eps_grid)`` with ``eps(+-45) = (1 - nu) eps_x / 2 +-
    gamma_local / 2``. Rosette A carries ``eps_x = axial + bending`` and ``gamma_local = gamma +
    transverse``; rosette B (180 degrees round the shaft) ``axial - bending`` and ``gamma -
    transverse``.

    Parameters
    ----------
    shear_strain : array_like
        Torsional shear strain gamma at the surface (1).
    rosette : {"half", "full"}
        One rosette (NI Half Bridge II) or two rosettes 180 degrees apart (NI Full Bridge I).
    gauge_factor : float
        Gauge factor (1).
    poisson : float, default 0.3
        Poisson ratio (1).
    axial_strain, bending_strain, transverse_shear : array_like, default 0
        Disturbing strains (1): axial, bending at rosette A, shear from transverse force at A.
    gauge_resistance : float, default 120
        Grid resistance in ohm.
    lead_resistance : float, default 0
        One lead's resistance in ohm (half bridge only; the full bridge is remote-sensed).

    Returns
    -------
    numpy.ndarray
        Vo/Vex in V/V (the unloaded bridge is balanced, so this is also Vr).
    """
    if rosette not in ("half", "full"):
        raise ConfigError(f"rosette must be 'half' or 'full', got {rosette!r}",
                          where={"key": "rosette"})
    gamma = np.asarray(shear_strain, dtype=np.float64)
    axial = np.asarray(axial_strain, dtype=np.float64)
    bending = np.asarray(bending_strain, dtype=np.float64)
    transverse = np.asarray(transverse_shear, dtype=np.float64)

    def grid(eps_x: FloatArray, gamma_local: FloatArray, sign: float) -> FloatArray:
        """Resistance change of one grid in ohm."""
        eps = (1.0 - poisson) * eps_x / 2.0 + sign * gamma_local / 2.0
        return gauge_resistance * gauge_factor * eps

    a_plus = grid(axial + bending, gamma + transverse, 1.0)
    a_minus = grid(axial + bending, gamma + transverse, -1.0)
    if rosette == "half":
        zero = np.zeros_like(a_plus)
        return balanced_bridge_ratio(gauge_resistance, gauge_resistance + lead_resistance,
                                     zero, zero, a_minus, a_plus)
    b_plus = grid(axial - bending, gamma - transverse, 1.0)
    b_minus = grid(axial - bending, gamma - transverse, -1.0)
    return balanced_bridge_ratio(gauge_resistance, gauge_resistance, b_minus, b_plus, a_minus,
                                 a_plus)


def shear_strain_from_ratio(ratio: ArrayLike, rosette: Rosette, *, gauge_factor: float,
                            gauge_resistance: float = 120.0, lead_resistance: float = 0.0,
                            sign: float = 1.0, overwrite: bool = False) -> FloatArray:
    """Return torsional shear strain gamma (1) from an offset-nulled rosette bridge ratio.

    ``gamma = 2 eps_NI`` with NI Half Bridge II (``rosette="half"``) or Full Bridge I
    (``"full"``).

    Parameters
    ----------
    ratio : array_like
        Offset-nulled voltage ratio Vr (V/V).
    rosette : {"half", "full"}
        Bridge form.
    gauge_factor : float
        Gauge factor (1).
    gauge_resistance, lead_resistance : float
        Rg and one lead's resistance in ohm (half bridge lead correction).
    sign : float, default 1
        +1 or -1: which grid sits in R4 decides the sign of the torque (calibration constant,
        check with a known load direction).
    overwrite : bool, default False
        A float64 ``ratio`` array of the caller's own becomes the shear strain (as
        :func:`rigval.processing.bridge.strain_from_ratio`'s ``overwrite``).
    """
    if rosette not in ("half", "full"):
        raise ConfigError(f"rosette must be 'half' or 'full', got {rosette!r}",
                          where={"key": "rosette"})
    bridge_type = "half_ii" if rosette == "half" else "full_i"
    strain = strain_from_ratio(ratio, bridge_type, gauge_factor=gauge_factor,
                               gauge_resistance=gauge_resistance,
                               lead_resistance=lead_resistance, overwrite=overwrite)
    if not (overwrite and writable_float64(strain)):
        return sign * 2.0 * strain
    # the strain is a new array or the ratio's own memory: scaled in place (a product)
    return np.multiply(strain, sign * 2.0, out=strain)


def torque_from_ratio(ratio: ArrayLike, rosette: Rosette, *, gauge_factor: float,
                      shear_modulus: float, outer_diameter: float, inner_diameter: float = 0.0,
                      gauge_resistance: float = 120.0, lead_resistance: float = 0.0,
                      sign: float = 1.0, overwrite: bool = False) -> FloatArray:
    """Return shaft torque in N m from an offset-nulled rosette bridge ratio (V/V).

    Combines :func:`shear_strain_from_ratio` and :func:`torque_from_shear_strain`; parameters as
    there (G in Pa, diameters in m). ``overwrite``: a float64 ``ratio`` array of the caller's
    own becomes the torque (memory; identical values; ``ratio`` must not be used afterwards).
    """
    gamma = shear_strain_from_ratio(ratio, rosette, gauge_factor=gauge_factor,
                                    gauge_resistance=gauge_resistance,
                                    lead_resistance=lead_resistance, sign=sign,
                                    overwrite=overwrite)
    # gamma is a new array unless it is the ratio's own memory, which overwrite allows
    return torque_from_shear_strain(gamma, shear_modulus=shear_modulus,
                                    outer_diameter=outer_diameter, inner_diameter=inner_diameter,
                                    overwrite=True)
