"""Torque from a rosette bridge computed in the ratio's memory equals the plain formulas' bits.

``overwrite`` only saves whole-record temporaries: the expectation is the textbook chain written
out with new arrays (``T = G (2 eps) J / (D/2)``, NI's Half Bridge II / Full Bridge I strain).
"""

from __future__ import annotations

import numpy as np
import pytest

from rigval.processing import bridge, torsion

G, D, DI = 80e9, 0.12, 0.03


def _plain(ratio: np.ndarray, rosette: str, sign: float) -> np.ndarray:
    kind = "half_ii" if rosette == "half" else "full_i"
    eps = bridge.strain_from_ratio(ratio, kind, gauge_factor=2.05, gauge_resistance=350.0,
                                   lead_resistance=0.4)
    gamma = sign * 2.0 * eps
    return gamma * G * (np.pi * (D**4 - DI**4) / 32.0) / (D / 2.0)


@pytest.mark.parametrize("rosette", ["half", "full"])
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_torque_in_the_ratios_memory_equals_the_plain_chain(rosette, sign):
    rng = np.random.default_rng(3)
    ratio = rng.normal(scale=4e-4, size=10_001)
    expected = _plain(ratio.copy(), rosette, sign)
    kept = ratio.copy()
    plain = torsion.torque_from_ratio(ratio, rosette, gauge_factor=2.05, shear_modulus=G,
                                      outer_diameter=D, inner_diameter=DI,
                                      gauge_resistance=350.0, lead_resistance=0.4, sign=sign)
    assert np.array_equal(ratio, kept)  # without overwrite the caller's array is left alone
    mine = ratio.copy()
    own = torsion.torque_from_ratio(mine, rosette, gauge_factor=2.05, shear_modulus=G,
                                    outer_diameter=D, inner_diameter=DI,
                                    gauge_resistance=350.0, lead_resistance=0.4, sign=sign,
                                    overwrite=True)
    assert np.array_equal(plain, expected) and np.array_equal(own, expected)
    assert np.shares_memory(own, mine)  # the torque took the ratio's memory


def test_a_scalar_and_a_read_only_ratio_are_never_written():
    frozen = np.full(5, -0.5e-3)
    frozen.flags.writeable = False
    for ratio in (-0.5e-3, frozen):
        torque = torsion.torque_from_ratio(ratio, "full", gauge_factor=2.05, shear_modulus=G,
                                           outer_diameter=D, inner_diameter=DI,
                                           gauge_resistance=350.0, lead_resistance=0.4,
                                           overwrite=True)
        assert np.array_equal(torque, _plain(np.asarray(ratio), "full", 1.0))
    assert np.all(frozen == -0.5e-3)


def test_torque_from_shear_strain_leaves_the_callers_strain_alone():
    gamma = np.linspace(-1e-4, 1e-4, 7)
    kept = gamma.copy()
    torque = torsion.torque_from_shear_strain(gamma, shear_modulus=G, outer_diameter=D)
    assert np.array_equal(gamma, kept) and not np.shares_memory(torque, gamma)
