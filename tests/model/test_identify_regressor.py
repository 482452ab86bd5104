"""The identification regressor against the solver (independent: the solver's own multipliers)."""

import dataclasses

import numpy as np
import pytest

import rigval.model as model
from rigval.acquisition.errors import ConfigError
from rigval.model.identify import nominal_parameters, parameter_names, regressor

OUTPUTS = [("driver_torque", "theta_F"), ("driver_torque", "theta_H"),
           ("joint_force", "P5", "x"), ("joint_force", "P8", "y"), ("joint_force", "P3", "x")]


@pytest.fixture(scope="module")
def pendulum():
    return model.load_mechanism(model.builtin_mechanism("pendulum"))


def _solved(mech, t):
    ds = model.solve(mech, t, outputs=["driver_torque", "joint_force"])
    return np.stack([ds["driver_torque"].sel(driver=o[1]).to_numpy() if len(o) == 2
                     else ds["joint_force"].sel(joint=o[1], axis=o[2]).to_numpy()
                     for o in OUTPUTS])


def test_nominal_parameters_reproduce_the_solver(pendulum):
    t = np.linspace(0.0, 1.25, 300)
    reg = regressor(pendulum, t, OUTPUTS)
    p = np.array([nominal_parameters(pendulum)[n] for n in reg.names])
    expected = _solved(pendulum, t)
    for row, want in zip(reg.matrix @ p, expected, strict=True):
        # both are the same linear algebra in another order: rounding only
        assert np.max(np.abs(row - want)) <= 1e-9 * np.ptp(want)


def test_changed_masses_are_linear(pendulum):
    t = np.linspace(0.0, 1.25, 200)
    bodies = tuple(dataclasses.replace(b, mass=b.mass * (1.0 + 0.1 * i),
                                       inertia=b.inertia * (1.0 - 0.05 * i))
                   for i, b in enumerate(pendulum.bodies))
    changed = dataclasses.replace(pendulum, bodies=bodies)
    reg = regressor(pendulum, t, OUTPUTS)          # geometry only: nominal file is enough
    p = np.array([nominal_parameters(changed)[n] for n in reg.names])
    for row, want in zip(reg.matrix @ p, _solved(changed, t), strict=True):
        assert np.max(np.abs(row - want)) <= 1e-9 * np.ptp(want)


def test_first_moments_equal_a_moved_centre_of_gravity(pendulum):
    """Moving A's CG by c in its frame (points shifted, parallel-axis inertia) is mx, my."""
    t = np.linspace(0.0, 1.25, 200)
    c = np.array([0.03, -0.05])
    a = pendulum.bodies[0]
    x, y, theta = a.guess
    shift = complex(*c) * np.exp(1j * theta)
    moved = dataclasses.replace(
        a, points={k: (v[0] - c[0], v[1] - c[1]) for k, v in a.points.items()},
        guess=(x + shift.real, y + shift.imag, theta))
    changed = dataclasses.replace(pendulum, bodies=(moved, *pendulum.bodies[1:]))
    reg = regressor(pendulum, t, OUTPUTS)
    values = nominal_parameters(pendulum)
    values["A.mx"], values["A.my"] = a.mass * c[0], a.mass * c[1]
    values["A.inertia"] = a.inertia + a.mass * float(c @ c)   # about the nominal frame origin
    p = np.array([values[n] for n in reg.names])
    for row, want in zip(reg.matrix @ p, _solved(changed, t), strict=True):
        assert np.max(np.abs(row - want)) <= 1e-8 * np.ptp(want)


def test_least_squares_recovers_a_heavier_arm(pendulum):
    t = np.linspace(0.0, 1.25, 360, endpoint=False)
    heavy = dataclasses.replace(pendulum, bodies=(
        dataclasses.replace(pendulum.bodies[0], mass=432.0), *pendulum.bodies[1:]))
    measured = _solved(heavy, t)[:2]
    reg = regressor(pendulum, t, OUTPUTS[:2])
    names = list(reg.names)
    free = [names.index("A.mass"), names.index("A.inertia")]
    p0 = np.array([nominal_parameters(pendulum)[n] for n in names])
    fixed = [i for i in range(len(names)) if i not in free]
    x = reg.matrix[:, :, free].reshape(-1, 2)
    y = (measured - reg.matrix[:, :, fixed] @ p0[fixed]).reshape(-1)
    solution = np.linalg.lstsq(x, y, rcond=None)[0]
    np.testing.assert_allclose(solution, [432.0, pendulum.bodies[0].inertia], rtol=1e-9)


def test_bad_outputs(pendulum):
    t = np.linspace(0.0, 0.1, 5)
    for bad, match in ((("driver_torque", "nope"), "unknown driver"),
                       (("joint_force", "P99", "x"), "unknown joint"),
                       (("joint_force", "P5", "z"), "unknown axis"),
                       (("point_position", "P1"), "cannot identify")):
        with pytest.raises(ConfigError, match=match):
            regressor(pendulum, t, [bad])
    assert len(parameter_names(pendulum)) == 4 * len(pendulum.bodies)
