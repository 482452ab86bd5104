"""Drive laws (rigval.model.laws): evaluation, inversion, the steady-turning test, main drive."""

from __future__ import annotations

import math

import numpy as np
import pytest

import rigval.model as rm
from rigval.acquisition.errors import ConfigError
from rigval.model.errors import ModelError
from rigval.model.laws import DriveLaw, Excitation, Harmonic

TWO_PI = 2.0 * math.pi


def _true_slowest(law: DriveLaw, n: int = 2_000_001) -> float:
    """The slowest |d theta / d tau| on a very fine grid (an independent estimate)."""
    _, slope, _ = law.at_phase(np.linspace(0.0, TWO_PI, n))
    return float(np.min(math.copysign(1.0, law.ratio) * slope))


@pytest.mark.parametrize(("amplitude", "order"), [(0.2, 3.0), (0.0099, 101.0), (0.5, 1.0)])
def test_slowest_rate_of_one_harmonic_is_its_closed_form(amplitude: float, order: float) -> None:
    law = DriveLaw(0.3, ratio=1.0, harmonics=(Harmonic(amplitude, order, 0.7),))
    exact = 1.0 - amplitude * order  # the cosine reaches -1 within every cycle
    bound = law.slowest_rate()
    assert bound <= exact + 1e-12
    # The bound lies below the grid's minimum by at most half a step times the slope's bound,
    # on a grid of at least 256 steps per cycle.
    assert bound >= exact - math.pi / 256 * amplitude * order**2


def test_slowest_rate_accepts_harmonics_that_never_peak_together() -> None:
    # sum |a k| = 1.2 > ratio 1: the bound from the harmonics alone would refuse this law, but
    # the two cosines never reach -1 together.
    law = DriveLaw(0.0, ratio=1.0, harmonics=(Harmonic(0.6, 1.0, 0.0), Harmonic(0.3, 2.0, 0.0)))
    truth = _true_slowest(law)
    assert truth > 0.1
    bound = law.slowest_rate()
    assert 0.0 < bound <= truth + 1e-12
    excitation = Excitation(1.0, (("main", law),), "main")
    assert excitation.turns_steadily()


def test_slowest_rate_finds_a_narrow_reversal() -> None:
    # A high harmonic whose slope swing exceeds the ratio by 1e-4: reverses in short spells.
    law = DriveLaw(0.0, ratio=1.0, harmonics=(Harmonic(1.0001 / 997.0, 997.0, 0.2),))
    assert law.slowest_rate() <= 0.0
    assert not Excitation(1.0, (("main", law),), "main").turns_steadily()
    with pytest.raises(ConfigError, match="without stopping"):
        Excitation(1.0, (("main", law),), "main").cycle_times(36)


@pytest.mark.parametrize("ratio", [1.0, -1.0, 2.0])
def test_phase_at_inverts_the_law(ratio: float) -> None:
    law = DriveLaw(0.4, ratio=ratio, phase=0.1,
                   harmonics=(Harmonic(0.05, 1.0, 0.3), Harmonic(0.01, 3.0, 2.0)))
    tau = np.linspace(-3.0, 40.0, 257)
    angles = law.at_phase(tau)[0]
    np.testing.assert_allclose(law.phase_at(angles), tau, rtol=0, atol=1e-12)


def test_phase_at_refuses_a_law_without_speed() -> None:
    with pytest.raises(ModelError, match="ratio 0"):
        DriveLaw(0.0, ratio=0.0, harmonics=(Harmonic(0.1, 1.0),)).phase_at([0.0])


def test_evaluate_is_the_chain_rule_of_at_phase() -> None:
    law = DriveLaw(0.2, ratio=2.0, harmonics=(Harmonic(0.1, 1.0, 0.5),))
    omega, t = 3.0, np.linspace(0.0, 2.0, 11)
    theta, speed, accel = law.evaluate(t, omega)
    np.testing.assert_allclose(theta, 0.2 + 2 * omega * t + 0.1 * np.sin(omega * t + 0.5),
                               atol=1e-14)
    np.testing.assert_allclose(speed, 2 * omega + 0.1 * omega * np.cos(omega * t + 0.5),
                               atol=1e-13)
    np.testing.assert_allclose(accel, -0.1 * omega**2 * np.sin(omega * t + 0.5), atol=1e-12)


def test_mechanism_drivers_are_the_file_law() -> None:
    pendulum = rm.load_mechanism(rm.builtin_mechanism("pendulum"))
    t = np.linspace(0.0, 3.0, 31)
    lift = pendulum.drivers[1]  # theta_H = theta0 + 4 pi t + 0.1 sin(2 pi t), the file's law
    np.testing.assert_allclose(lift.motion(t)[0],
                               lift.theta0 + 2 * TWO_PI * t + 0.1 * np.sin(TWO_PI * t),
                               atol=1e-12)
    np.testing.assert_allclose(lift.times_at(lift.motion(t)[0]), t, atol=1e-13)


def test_with_main_keeps_every_angle() -> None:
    pendulum = rm.load_mechanism(rm.builtin_mechanism("pendulum"))
    by_f, by_h = pendulum.excitation(), pendulum.excitation("theta_H")
    assert by_h.main == "theta_H" and by_h.frequency == pytest.approx(2.0 * by_f.frequency)
    t = np.linspace(0.0, 2.0, 41)
    for name in ("theta_F", "theta_H"):
        for a, b in zip(by_f.evaluate(t)[name], by_h.evaluate(t)[name], strict=True):
            np.testing.assert_allclose(a, b, rtol=1e-13, atol=1e-12)
