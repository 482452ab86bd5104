"""Accuracy against independent results: closed forms, conservation of energy, finite differences,
the full-coordinate step-by-step solve, and Newton's law for the whole mechanism."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import rigval.model as rm

T_PEND = np.linspace(0.0, 1.0, 401)


@pytest.fixture(scope="module")
def pendulum_run(pendulum: rm.Mechanism):
    return rm.solve(pendulum, T_PEND, outputs=rm.OUTPUTS + rm.EXTRA_OUTPUTS)


def test_single_pendulum_torque_matches_closed_form(single: rm.Mechanism) -> None:
    t = np.linspace(0.0, 2.0, 801)
    ds = rm.solve(single, t, outputs=["driver_torque", "position"])
    body = single.bodies[0]
    length = body.points["O"][1]  # pivot above the centre of gravity
    theta, _omega, alpha = single.drivers[0].motion(t)
    expected = body.mass * 9.81 * length * np.sin(theta) \
        + (body.inertia + body.mass * length**2) * alpha
    torque = ds["driver_torque"].sel(driver="theta_P").to_numpy()
    np.testing.assert_allclose(torque, expected, rtol=0, atol=1e-12 * np.max(np.abs(expected)))
    np.testing.assert_allclose(ds["position"].sel(coord="theta").to_numpy()[:, 0], theta,
                               rtol=0, atol=1e-15)


def _freudenstein_rocker(theta2: np.ndarray, a: float, b: float, c: float, d: float
                         ) -> tuple[np.ndarray, np.ndarray]:
    """Both closed-form rocker angles of K1 cos t4 - K2 cos t2 + K3 = cos(t2 - t4)."""
    k1, k2, k3 = d / a, d / c, (a * a - b * b + c * c + d * d) / (2 * a * c)
    p, q, r = k1 - np.cos(theta2), -np.sin(theta2), k3 - k2 * np.cos(theta2)
    root = np.sqrt(q * q - (r - p) * (r + p))
    return 2 * np.arctan((-q + root) / (r - p)), 2 * np.arctan((-q - root) / (r - p))


def test_fourbar_angles_match_freudenstein(fourbar: rm.Mechanism) -> None:
    t = np.linspace(0.0, 0.5, 301)  # one crank revolution
    ds = rm.solve(fourbar, t, outputs=["position", "point_position"])
    theta = ds["position"].sel(coord="theta")
    crank = theta.sel(body="crank").to_numpy()
    coupler = theta.sel(body="coupler").to_numpy()
    rocker = theta.sel(body="rocker").to_numpy()
    a, b, c, d = 0.1, 0.35, 0.3, 0.4  # O2-A, A-B, O4-B, O2-O4 (fourbar.toml)
    first, second = _freudenstein_rocker(crank, a, b, c, d)
    wrap = lambda x: np.angle(np.exp(1j * x))  # noqa: E731
    branch = first if abs(wrap(first[0] - rocker[0])) < abs(wrap(second[0] - rocker[0])) \
        else second
    np.testing.assert_allclose(wrap(rocker - branch), 0.0, atol=1e-11)
    # coupler angle from the closed-form joint positions A and B
    pin_a = a * np.exp(1j * crank)
    pin_b = d + c * np.exp(1j * branch)
    np.testing.assert_allclose(wrap(coupler - np.angle(pin_b - pin_a)), 0.0, atol=1e-11)
    point_b = ds["point_position"].sel(point="B").to_numpy()
    np.testing.assert_allclose(point_b[:, 0] + 1j * point_b[:, 1], pin_b, atol=1e-12)


def _energy_rate(mechanism: rm.Mechanism, ds) -> np.ndarray:
    """d(kinetic + potential)/dt from velocities and accelerations, W."""
    mass = np.array([b.mass for b in mechanism.bodies])
    inertia = np.array([b.inertia for b in mechanism.bodies])
    v, a = ds["velocity"].to_numpy(), ds["acceleration"].to_numpy()
    gravity = np.array(mechanism.gravity)
    linear = np.einsum("tbk,tbk->tb", v[..., :2], a[..., :2] - gravity)
    return linear @ mass + (v[..., 2] * a[..., 2]) @ inertia


def test_pendulum_drive_power_equals_energy_rate(pendulum: rm.Mechanism, pendulum_run) -> None:
    power = pendulum_run["drive_power"].sum("driver").to_numpy()
    rate = _energy_rate(pendulum, pendulum_run)
    assert np.max(np.abs(power - rate)) <= 1e-9 * np.max(np.abs(power))
    # and the energy itself integrates the power (trapezoid, coarse check of the energy output)
    energy = (pendulum_run["kinetic_energy"] + pendulum_run["potential_energy"]).to_numpy()
    work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(T_PEND))])
    assert np.max(np.abs(energy - energy[0] - work)) < 1e-3 * np.ptp(energy)


def test_pendulum_velocity_acceleration_match_finite_differences(pendulum: rm.Mechanism) -> None:
    h = 1e-3
    t0 = np.array([0.1, 0.37, 0.81])
    stencil = np.concatenate([t0 - 2 * h, t0 - h, t0, t0 + h, t0 + 2 * h])
    order = np.argsort(stencil)
    ds = rm.solve(pendulum, stencil[order], outputs=["position", "velocity", "acceleration",
                                                      "point_position", "point_acceleration"])
    ds = ds.isel(time=np.argsort(order))
    for pos, vel, acc in (("position", "velocity", "acceleration"),
                          ("point_position", None, "point_acceleration")):
        x = ds[pos].to_numpy().reshape(5, 3, -1)
        first = (x[0] - 8 * x[1] + 8 * x[3] - x[4]) / (12 * h)
        second = (-x[0] + 16 * x[1] - 30 * x[2] + 16 * x[3] - x[4]) / (12 * h * h)
        if vel:
            v = ds[vel].to_numpy().reshape(5, 3, -1)[2]
            np.testing.assert_allclose(first, v, atol=1e-7 * np.max(np.abs(v)))
        a = ds[acc].to_numpy().reshape(5, 3, -1)[2]
        np.testing.assert_allclose(second, a, atol=1e-5 * np.max(np.abs(a)))


def test_batched_solver_matches_full_coordinate_stepwise_solve(pendulum: rm.Mechanism,
                                                              pendulum_run) -> None:
    reference = rm.solve_stepwise(pendulum, T_PEND[:120])
    fast = pendulum_run.isel(time=slice(0, 120))
    for name in rm.OUTPUTS:
        expected = reference[name].to_numpy()
        np.testing.assert_allclose(fast[name].to_numpy(), expected, rtol=0,
                                   atol=1e-10 * np.max(np.abs(expected)), err_msg=name)


def test_ground_forces_balance_the_whole_mechanism(pendulum: rm.Mechanism, pendulum_run) -> None:
    """Newton for all bodies together: the ground's forces equal sum m (a - g)."""
    mass = np.array([b.mass for b in pendulum.bodies])
    acc = pendulum_run["acceleration"].to_numpy()[..., :2]
    needed = np.einsum("b,tbk->tk", mass, acc - np.array(pendulum.gravity))
    on_ground = pendulum_run["support_force"].sum("support").to_numpy()
    np.testing.assert_allclose(-on_ground, needed, atol=1e-9 * np.max(np.abs(needed)))
    ground_joints = list(pendulum_run["support"].to_numpy())
    np.testing.assert_array_equal(
        pendulum_run["support_force"].to_numpy(),
        -pendulum_run["joint_force"].sel(joint=ground_joints).to_numpy())


def test_joint_points_coincide_on_both_bodies(pendulum: rm.Mechanism, pendulum_run) -> None:
    pos = pendulum_run["position"].to_numpy()
    for joint in pendulum.joints:
        ends = []
        for name in joint.bodies:
            i = pendulum.body_names.index(name)
            local = complex(*pendulum.bodies[i].points[joint.name])
            ends.append(pos[:, i, 0] + 1j * pos[:, i, 1] + local * np.exp(1j * pos[:, i, 2]))
        other = ends[1] if len(ends) == 2 else complex(*joint.at)
        np.testing.assert_allclose(ends[0], other, atol=1e-12, err_msg=joint.name)


def test_joint_force_sign_on_first_body(single: rm.Mechanism) -> None:
    """A pendulum held still at theta = 0 hangs from its pin: the pin pushes it up by m g."""
    data = {"schema": "rigval-mechanism/1", "gravity": [0.0, -9.81],
            "bodies": [{"name": "P", "mass": 5.0, "inertia": 0.2, "guess": [0.0, -0.5, 0.0],
                        "points": {"O": [0.0, 0.5]}}],
            "joints": [{"point": "O", "type": "ground", "body": "P", "at": [0.0, 0.0]}],
            "drivers": [{"name": "hold", "body": "P", "law": "harmonic", "theta0": 0.0,
                         "omega": 0.0}]}
    ds = rm.solve(rm.load_mechanism(data), np.zeros(1), outputs=["joint_force", "driver_torque",
                                                                 "support_force"])
    np.testing.assert_allclose(ds["joint_force"].to_numpy()[0, 0], [0.0, 5.0 * 9.81], atol=1e-12)
    np.testing.assert_allclose(ds["support_force"].to_numpy()[0, 0], [0.0, -5.0 * 9.81],
                               atol=1e-12)
    np.testing.assert_allclose(ds["driver_torque"].to_numpy(), 0.0, atol=1e-12)


def test_structure_without_drivers_carries_its_weight() -> None:
    """Two equal bars pinned to the ground and to each other: each pin carries half the weight."""
    half = 0.5 * math.sqrt(0.5)
    bar = {"mass": 1.0, "inertia": 0.1}
    data = {"schema": "rigval-mechanism/1", "bodies": [
        dict(bar, name="A", guess=[0.25, 0.25, 0.8],
             points={"O1": [-half, 0.0], "C": [half, 0.0]}),
        dict(bar, name="B", guess=[0.75, 0.25, 2.3],
             points={"O2": [-half, 0.0], "C": [half, 0.0]})],
        "joints": [{"point": "O1", "type": "ground", "body": "A", "at": [0.0, 0.0]},
                   {"point": "O2", "type": "ground", "body": "B", "at": [1.0, 0.0]},
                   {"point": "C", "type": "revolute", "bodies": ["A", "B"]}]}
    ds = rm.solve(rm.load_mechanism(data), np.linspace(0.0, 1.0, 3),
                  outputs=["joint_force", "position"])
    force = ds["joint_force"].to_numpy()
    np.testing.assert_allclose(force[:, :2, 1], 9.81, rtol=1e-12)
    np.testing.assert_allclose(force[:, 0, 0], -force[:, 1, 0], rtol=1e-12)
    np.testing.assert_allclose(ds["position"].sel(coord="theta").to_numpy()[:, 0], math.pi / 4,
                               atol=1e-3)


@settings(max_examples=15, deadline=None)
@given(crank=st.floats(0.05, 0.15), coupler=st.floats(0.5, 0.8), rocker=st.floats(0.3, 0.5),
       ground=st.floats(0.45, 0.7), start=st.floats(0.0, 6.28))
def test_random_crank_rockers_match_freudenstein(crank: float, coupler: float, rocker: float,
                                                 ground: float, start: float) -> None:
    """Any Grashof crank-rocker built from scratch: angles equal the closed form."""
    lengths = sorted([crank, coupler, rocker, ground])
    assume(lengths[0] == crank and lengths[0] + lengths[3] < lengths[1] + lengths[2] - 0.02)
    first, _second = _freudenstein_rocker(np.array([start]), crank, coupler, rocker, ground)
    rocker_angle = float(first[0])
    pin_a = crank * np.exp(1j * start)
    pin_b = ground + rocker * np.exp(1j * rocker_angle)
    coupler_angle = float(np.angle(pin_b - pin_a))

    def bar(name: str, length: float, angle: float, centre: complex, ends: tuple[str, str]):
        return {"name": name, "mass": 1.0, "inertia": 0.01,
                "guess": [centre.real, centre.imag, angle],
                "points": {ends[0]: [-length / 2, 0.0], ends[1]: [length / 2, 0.0]}}

    data = {"schema": "rigval-mechanism/1", "bodies": [
        bar("crank", crank, start, pin_a / 2, ("O2", "A")),
        bar("coupler", coupler, coupler_angle, (pin_a + pin_b) / 2, ("A", "B")),
        bar("rocker", rocker, rocker_angle, (ground + pin_b) / 2, ("O4", "B"))],
        "joints": [{"point": "O2", "type": "ground", "body": "crank", "at": [0.0, 0.0]},
                   {"point": "A", "type": "revolute", "bodies": ["crank", "coupler"]},
                   {"point": "B", "type": "revolute", "bodies": ["coupler", "rocker"]},
                   {"point": "O4", "type": "ground", "body": "rocker", "at": [ground, 0.0]}],
        "drivers": [{"name": "crank", "body": "crank", "law": "harmonic", "theta0": start,
                     "omega": 2 * math.pi}]}
    t = np.linspace(0.0, 1.0, 97)
    ds = rm.solve(rm.load_mechanism(data), t, outputs=["position"])
    theta = ds["position"].sel(coord="theta").to_numpy()
    roots = _freudenstein_rocker(theta[:, 0], crank, coupler, rocker, ground)
    gaps = [np.abs(np.angle(np.exp(1j * (theta[:, 2] - root)))) for root in roots]
    np.testing.assert_allclose(np.minimum(*gaps), 0.0, atol=1e-10)
    # and it stays on the assembly branch it started on (the side of the line A-O4 B is on)
    pin_a = crank * np.exp(1j * theta[:, 0])
    pin_b = ground + rocker * np.exp(1j * theta[:, 2])
    side = np.sign(np.imag(np.conj(ground - pin_a) * (pin_b - pin_a)))
    assert np.all(side == side[0])
