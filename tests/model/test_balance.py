"""The model's power balance (rigval.model.balance): a conservation law as the check."""

from __future__ import annotations

import tomllib

import numpy as np

import rigval.model as rm
from rigval.model.balance import energy_residual, periodic_derivative


def test_periodic_derivative_is_exact_for_trigonometric_samples() -> None:
    phi = 2 * np.pi * np.arange(64) / 64
    values = 0.3 + np.sin(3 * phi) - 0.2 * np.cos(7 * phi)
    np.testing.assert_allclose(periodic_derivative(values),
                               3 * np.cos(3 * phi) + 1.4 * np.sin(7 * phi), atol=1e-12)


def test_drive_power_is_the_rate_of_change_of_energy() -> None:
    for name in ("pendulum", "fourbar"):
        checks = energy_residual(rm.load_mechanism(rm.builtin_mechanism(name)), 720)
        assert checks["power balance max |P - dE/dt| / max |P|"] < 1e-8, (name, checks)
        assert checks["Newton tolerance"] == 1e-12


def test_laws_that_do_not_repeat_skip_the_check() -> None:
    data = tomllib.loads(rm.builtin_mechanism("pendulum").read_text())
    data["drivers"][1]["omega"] = 1.5 * data["drivers"][0]["omega"]  # 1.5 turns per revolution
    assert energy_residual(rm.load_mechanism(data), 360) == {}
