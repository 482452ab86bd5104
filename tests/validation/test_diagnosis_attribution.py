"""Attribution on synthetic residuals of known cause (closed forms, seeded noise)."""

from __future__ import annotations

import numpy as np
import pytest

from rigval.validation.diagnosis.attribution import (
    Block,
    Cause,
    Nuisance,
    _stack_effects,
    attribute,
    order_coefficients,
)
from tests.validation.revolution_grid import PHI, N

#: A model curve of a few orders, like a drive torque (signal units).
MODEL = 100.0 * np.sin(PHI) + 40.0 * np.cos(2.0 * PHI + 0.3) + 15.0 * np.sin(3.0 * PHI - 1.0)
SLOPE = (100.0 * np.cos(PHI) - 80.0 * np.sin(2.0 * PHI + 0.3)
         + 45.0 * np.cos(3.0 * PHI - 1.0))
#: A parameter's signature that is not a gain: orders 1 and 4, another phase.
PARAM = 30.0 * np.cos(PHI + 0.8) + 10.0 * np.sin(4.0 * PHI)
OMEGA = 2.0 * np.pi


def _cycles(residual: np.ndarray, seed: int, noise: float = 0.5, n_cycles: int = 20
            ) -> np.ndarray:
    rng = np.random.default_rng(seed)
    # smooth noise per revolution: a few random orders, as a low-passed gauge sees
    k = np.arange(1, 9)[:, None]
    amp = rng.normal(0.0, noise, (n_cycles, 8, 2))
    wiggle = (amp[..., 0, None] * np.cos(k * PHI) + amp[..., 1, None] * np.sin(k * PHI)).sum(1)
    return residual + wiggle


def _causes() -> list[Cause]:
    return [Cause("gain c", "gain", "1", {"c": MODEL}),
            Cause("lag c", "lag", "s", {"c": -OMEGA * SLOPE}),
            Cause("P.mass", "parameter", "kg", {"c": PARAM, "d": 2.0 * PARAM}, nominal=50.0)]


def test_order_coefficients_are_the_amplitudes() -> None:
    x = 3.0 + 2.0 * np.cos(PHI) - 5.0 * np.sin(4.0 * PHI)
    c = order_coefficients(x, 5, with_offset=True)
    expect = np.zeros(11)
    expect[0], expect[1], expect[8] = 3.0, 2.0, 5.0   # Re c1 = 2; Im c4 = +5 (-5 sin = Re(5i e))
    np.testing.assert_allclose(c, expect, atol=1e-12)


def test_stacked_effects_are_each_effects_own_coefficients() -> None:
    # the effects on a block are transformed together; each column must be what the effect's
    # own transform gives, block by block, to the bit (zeros where it does not touch a block)
    blocks = [Block("c", _cycles(np.zeros(N), 1), 8, with_offset=True),
              Block("d", _cycles(np.zeros(N), 2), 5), Block("e", _cycles(np.zeros(N), 3), 3)]
    effects = [c.effect for c in _causes()] + [{"e": 1e-3 * MODEL**2}, {}]
    expected = np.column_stack([np.concatenate([
        order_coefficients(effect[b.name], b.orders, b.with_offset) if b.name in effect
        else np.zeros(2 * b.orders + int(b.with_offset)) for b in blocks])
        for effect in effects])
    found = _stack_effects(effects, blocks)
    assert found.shape == expected.shape
    assert np.array_equal(found, expected)
    assert _stack_effects([], blocks).shape == (expected.shape[0], 0)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_gain_is_named_and_recovered(seed: int) -> None:
    gain = 0.03
    blocks = [Block("c", _cycles(gain * MODEL, seed), 8),
              Block("d", _cycles(np.zeros(N), seed + 100), 8)]
    out = attribute(blocks, _causes())
    assert out.found[0].name == "gain c"
    f = out.found[0]
    assert abs(f.value - gain) < 3.0 * f.std
    assert out.by_comparison["c"] == "gain c"
    assert out.candidates[0].name == "gain c"


@pytest.mark.parametrize("seed", [4, 5])
def test_lag_is_named_with_its_seconds(seed: int) -> None:
    lag = 0.002
    # measured = model delayed by lag: M(phi - omega lag), exactly
    delayed = (100.0 * np.sin(PHI - OMEGA * lag) + 40.0 * np.cos(2.0 * (PHI - OMEGA * lag) + 0.3)
               + 15.0 * np.sin(3.0 * (PHI - OMEGA * lag) - 1.0))
    blocks = [Block("c", _cycles(delayed - MODEL, seed, noise=0.05), 8)]
    out = attribute(blocks, _causes())
    f = out.found[0]
    assert f.name == "lag c"
    # first-order lag regressor: the truncation is (omega lag)^2 / 2 of the signal, 8e-5 here
    assert abs(f.value - lag) < 3.0 * f.std + 3e-4 * lag


def test_parameter_seen_on_two_comparisons_beats_a_gain() -> None:
    delta = 4.0   # kg
    blocks = [Block("c", _cycles(delta * PARAM, 7), 8),
              Block("d", _cycles(2.0 * delta * PARAM, 8), 8)]
    out = attribute(blocks, _causes())
    f = out.found[0]
    assert f.name == "P.mass"
    assert abs(f.value - delta) < 3.0 * f.std
    assert abs(f.relative - delta / 50.0) < 3.0 * f.relative_std
    assert out.by_comparison == {"c": "P.mass", "d": "P.mass"}


def test_no_cause_within_the_noise() -> None:
    false = 0
    for seed in range(20):
        blocks = [Block("c", _cycles(np.zeros(N), seed), 8)]
        false += bool(attribute(blocks, _causes()).found)
    # the Bonferroni bound of attribute.ALPHA = 5 % over the three candidates (3 % measured over
    # 200 seeds); the scatter's own estimate makes the tails heavier: at most 3 of 20
    assert false <= 3


def test_stated_calibration_widens_the_gain_not_the_lag() -> None:
    gain = 0.03
    cycles = _cycles(gain * MODEL, 11)
    plain = attribute([Block("c", cycles, 8)], _causes())
    stated = attribute([Block("c", cycles, 8)], _causes(),
                       [Nuisance("calibration c", {"c": 0.01 * MODEL})])
    assert stated.found[0].name == "gain c"
    # the gain beyond the stated calibration: its variance gains the calibration's 1 %^2
    np.testing.assert_allclose(stated.found[0].std**2,
                               plain.found[0].std**2 + 0.01**2 * stated.birge**2, rtol=0.05)


def test_a_gain_inside_the_stated_calibration_is_not_blamed() -> None:
    cycles = _cycles(0.005 * MODEL, 12, noise=0.05)
    out = attribute([Block("c", cycles, 8)], _causes()[:1],
                    [Nuisance("calibration c", {"c": 0.01 * MODEL})])
    assert not out.found


def test_collinear_causes_are_reported_as_confusable() -> None:
    causes = [*_causes(), Cause("B.inertia", "parameter", "kg m2", {"c": 1.001 * MODEL})]
    out = attribute([Block("c", _cycles(0.03 * MODEL, 13), 8)], causes)
    assert out.confusable
    assert {out.confusable[0][0], out.confusable[0][1]} == {"gain c", "B.inertia"}


def test_mode_effect_is_the_amplification_minus_one_per_order() -> None:
    from rigval.validation.diagnosis.causes import mode_effect

    speed, fn, zeta = 2.0, 17.0, 0.03
    load = 5.0 * np.cos(3.0 * PHI + 0.2)   # order 3 at 6 Hz
    r = 3.0 * speed / fn
    h = 1.0 / (1.0 - r**2 + 2j * zeta * r)
    expect = np.real(5.0 * np.exp(0.2j) * (h - 1.0) * np.exp(3j * PHI))
    np.testing.assert_allclose(mode_effect(load, speed, fn, zeta), expect, atol=1e-12)
