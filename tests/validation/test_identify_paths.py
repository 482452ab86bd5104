"""Identification from one model solve for all revolutions equals the solve per revolution.

The plain route is the per-revolution code that ``revolution_problems`` replaced, kept here: one
``regressor`` (one model solve, one multiplier solve) per revolution at that revolution's own
drive speeds and times. The shipped 0.8 rev/s run is identified both ways; values and standard
errors must agree to 1e-6 relative (the two routes differ by the solver's Newton tolerance,
1e-12, amplified by the fit's condition number of about 80). A second case scales each
revolution's speed by up to +-30 % along the revolution, so the speeds and accelerations differ
far more between passes than on the rig.
"""

from __future__ import annotations

import numpy as np
import pytest

import rigval.validation.identify as validation_identify
from rigval.model import load_mechanism
from rigval.model.identify import path_regressors, regressor
from rigval.model.identify_design import _weighted_columns
from rigval.sample_data import shipped_runs
from rigval.validation.pipeline import run_scene

PARAMETERS = ["A.mass", "A.inertia", "E.mass"]


def plain_revolution_problems(mechanism, curves, design, drives, leading, angle_times, step,
                              cycles):
    """The per-revolution route: one regressor (one model solve) per revolution."""
    lead = drives[leading]
    outputs = [c.output for c in curves]
    columns, data = [], []
    for row, t in enumerate(angle_times):
        slope = np.gradient(t, step)
        omega = 1.0 / slope
        alpha = -np.gradient(slope, step) * omega**3
        own = {}
        for name, (theta, w, a) in drives.items():
            kappa = w / lead[1]
            bend = (a - kappa * lead[2]) / lead[1] ** 2
            own[name] = (theta, kappa * omega, bend * omega**2 + kappa * alpha)
        reg = regressor(mechanism, t - t[0], outputs, drives=own)
        columns.append(_weighted_columns(reg, curves, design.friction))
        data.append(np.concatenate([c[row] * curve.weight
                                    for c, curve in zip(cycles, curves, strict=True)]))
    return np.array(columns), np.array(data)


@pytest.fixture(scope="module")
def nominal():
    return run_scene(shipped_runs()[0])


def test_values_and_standard_errors_equal_the_per_revolution_route(nominal, monkeypatch):
    fast = validation_identify.identify(nominal.scene, PARAMETERS, result=nominal)
    monkeypatch.setattr(validation_identify, "revolution_problems", plain_revolution_problems)
    plain = validation_identify.identify(nominal.scene, PARAMETERS, result=nominal)
    assert fast.names == plain.names == tuple(PARAMETERS)
    np.testing.assert_allclose(fast.value, plain.value, rtol=1e-6, atol=0)
    np.testing.assert_allclose(fast.std, plain.std, rtol=1e-6, atol=0)
    # the random part of the std comes from the revolutions: it must not be zero here
    assert np.all(plain.std > 0)


def test_passes_of_very_different_speeds_equal_their_own_solves(nominal):
    mechanism = load_mechanism(nominal.scene.mechanism)
    model = nominal.tree["/model"].to_dataset()
    drives = {d: tuple(model[f"drive_{d}{s}"].to_numpy() for s in ("", "_dot", "_ddot"))
              for d in nominal.scene.model.drivers}
    lead = drives["theta_F"]  # the main shaft's drive, on the main encoder
    phi = lead[0]
    path = {name: (theta, w / lead[1], (a - w / lead[1] * lead[2]) / lead[1] ** 2)
            for name, (theta, w, a) in drives.items()}
    base = 2 * np.pi * 0.8
    wobble = np.sin(phi - phi[0])
    speeds = np.array([base * (1 + 0.3 * wobble), base * (1 - 0.2 * wobble),
                       np.full_like(phi, 3.0)])
    accelerations = np.array([base * 0.3 * np.cos(phi - phi[0]) * speeds[0],
                              -base * 0.2 * np.cos(phi - phi[0]) * speeds[1], np.zeros_like(phi)])
    outputs = [("driver_torque", "theta_F"), ("driver_torque", "theta_H"),
               ("joint_force", mechanism.joint_names[0], "x")]
    fast = path_regressors(mechanism, outputs, phi, path, speeds, accelerations)
    for r, reg in enumerate(fast):
        times = np.concatenate([[0.0], np.cumsum(np.diff(phi) * 2 / (speeds[r][1:]
                                                                   + speeds[r][:-1]))])
        own = {name: (theta, kappa * speeds[r], bend * speeds[r] ** 2 + kappa * accelerations[r])
               for name, (theta, kappa, bend) in path.items()}
        plain = regressor(mechanism, times, outputs, drives=own)
        peak = np.max(np.abs(plain.matrix), axis=(1, 2), keepdims=True)
        assert np.max(np.abs(reg.matrix - plain.matrix) / peak) < 1e-9
        for name in plain.omega:
            np.testing.assert_allclose(reg.omega[name], plain.omega[name], rtol=1e-12, atol=1e-12)
