"""Axial stress from strain, and axial/bending separation from two opposite gauges.

Uniaxial Hooke's law ``sigma = E eps``; force ``F = sigma A``. Two gauges on opposite faces of a
member (0 and 180 degrees) see ``eps_a + eps_b`` and ``eps_a - eps_b``: ``eps_axial = (eps_top +
eps_bottom) / 2``, ``eps_bending = (eps_top - eps_bottom) / 2``; bending moment ``M = E eps_bending
W`` with the section modulus W (``pi (D^4 - d^4) / (32 D)`` for a round tube).
"""

from __future__ import annotations

import logging

import numpy as np
from numpy.typing import ArrayLike

from rigval.processing.arrays import FloatArray

__all__ = ["axial_and_bending", "axial_force", "axial_stress", "bending_moment",
           "tube_section_modulus"]

logger = logging.getLogger(__name__)


def axial_stress(strain: ArrayLike, youngs_modulus: float) -> FloatArray:
    """Return axial stress ``sigma = E eps`` in Pa from strain (1) and Young's modulus (Pa)."""
    return np.asarray(strain, dtype=np.float64) * youngs_modulus


def axial_force(strain: ArrayLike, youngs_modulus: float, area: float) -> FloatArray:
    """Return axial force ``F = E eps A`` in N from strain (1), E (Pa) and cross-section A (m^2)."""
    return axial_stress(strain, youngs_modulus) * area


def axial_and_bending(strain_top: ArrayLike, strain_bottom: ArrayLike,
                      ) -> tuple[FloatArray, FloatArray]:
    """Split the strains of two gauges on opposite faces into axial and bending parts.

    Parameters
    ----------
    strain_top, strain_bottom : array_like
        Axial-direction strains (1) at 0 and 180 degrees round the member.

    Returns
    -------
    axial, bending : numpy.ndarray
        ``(top + bottom) / 2`` and ``(top - bottom) / 2`` (1); bending is positive when the top
        face is stretched.
    """
    top = np.asarray(strain_top, dtype=np.float64)
    bottom = np.asarray(strain_bottom, dtype=np.float64)
    return (top + bottom) / 2.0, (top - bottom) / 2.0


def tube_section_modulus(outer_diameter: float, inner_diameter: float = 0.0) -> float:
    """Return the bending section modulus ``W = pi (D^4 - d^4) / (32 D)`` of a round tube in m^3."""
    return float(np.pi * (outer_diameter**4 - inner_diameter**4) / (32.0 * outer_diameter))


def bending_moment(bending_strain: ArrayLike, youngs_modulus: float,
                   section_modulus: float) -> FloatArray:
    """Return the bending moment ``M = E eps_bending W`` in N m (E in Pa, W in m^3)."""
    return np.asarray(bending_strain, dtype=np.float64) * youngs_modulus * section_modulus
