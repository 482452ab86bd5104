"""The issue's five hard cases, each showing what happens: toggle, redundancy, bad start and large
steps, high speed and very long runs (plus whole-turn jumps), and a mechanism that cannot close."""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np
import pytest
import scipy.linalg

import rigval.model as rm
from rigval.acquisition.errors import NumericsWarning
from rigval.model.errors import AssemblyError, SingularityError
from rigval.model.loops import loop_system
from rigval.model.reference import constraint_jacobian

# fourbar.toml: crank a = 0.1 (O2 at 0, 0), coupler b = 0.35, rocker c = 0.3, O4 at (0.4, 0)
A, B, C, D = 0.1, 0.35, 0.3, 0.4


def _rocker_limits() -> tuple[float, float]:
    """Rocker angles where crank and coupler are collinear (the toggles), upper branch."""
    stretched = math.acos(((A + B) ** 2 - D * D - C * C) / (2 * D * C))
    folded = math.acos(((B - A) ** 2 - D * D - C * C) / (2 * D * C))
    return stretched, folded


def _rocker_driven(data: dict[str, Any], amplitude: float) -> dict[str, Any]:
    low, high = _rocker_limits()
    middle = 0.5 * (low + high)
    data["drivers"] = [{"name": "rocker", "body": "rocker", "law": "harmonic", "theta0": middle,
                        "omega": 0.0, "harmonics": [{"amplitude": amplitude, "omega": 1.0,
                                                     "phase": 0.0}]}]
    data["bodies"][2]["guess"][2] = middle
    data["bodies"][0]["guess"][2] = 2.2     # within the stated 0.5 rad of the assembly
    data["bodies"][1]["guess"][2] = 0.5
    return data


def test_toggle_warns_as_condition_grows(fourbar_dict: dict[str, Any]) -> None:
    low, high = _rocker_limits()
    mech = rm.load_mechanism(_rocker_driven(fourbar_dict, 0.5 * (high - low) - 1e-10))
    t = np.linspace(0.0, 0.5 * math.pi, 60)  # ends exactly at the top of the swing
    with pytest.warns(NumericsWarning, match="ill-conditioned near t = 1.5707") as record:
        ds = rm.solve(mech, t, outputs=["position", "joint_force", "condition_number"])
    assert "A" in str(record[0].message) and "B" in str(record[0].message)
    cond = ds["condition_number"].to_numpy()
    assert cond[-1] > 1e4 and cond[0] < 10 and np.all(np.diff(cond[30:]) > 0)
    # still an assembled mechanism at the last sample: crank and coupler nearly collinear
    theta = ds["position"].sel(coord="theta").to_numpy()[-1]
    assert abs(math.remainder(theta[0] - theta[1], math.pi)) < 1e-4


def test_past_the_toggle_is_an_error_naming_time_joints_residual(
        fourbar_dict: dict[str, Any]) -> None:
    low, high = _rocker_limits()
    mech = rm.load_mechanism(_rocker_driven(fourbar_dict, 0.5 * (high - low) + 1e-3))
    t = np.linspace(0.0, 0.5 * math.pi, 60)
    with pytest.raises(SingularityError) as info:
        rm.solve(mech, t, outputs=["position"])
    error = info.value
    assert error.where["time_s"] > 1.3
    assert {"A", "B"} <= set(error.joints)
    assert error.residual_m > 1e-6
    assert "residual" in str(error) and "joints involved" in str(error)


def _parallelogram() -> dict[str, Any]:
    """Three parallel cranks of 0.3 m under one coupler: one constraint pair is redundant."""
    crank = {"O": [-0.15, 0.0], "X": [0.15, 0.0]}
    bodies = []
    for name, ground, end in (("crank1", 0.0, "A"), ("crank2", 1.0, "B"), ("crank3", 0.5, "C")):
        bodies.append({"name": name, "mass": 2.0, "inertia": 0.02,
                       "guess": [ground + 0.15 * math.cos(0.5), 0.15 * math.sin(0.5), 0.5],
                       "points": {f"O{name[-1]}": crank["O"], end: crank["X"]}})
    bodies.append({"name": "coupler", "mass": 6.0, "inertia": 0.5,
                   "guess": [0.5 + 0.3 * math.cos(0.5), 0.3 * math.sin(0.5), 0.0],
                   "points": {"A": [-0.5, 0.0], "C": [0.0, 0.0], "B": [0.5, 0.0]}})
    joints = [{"point": f"O{i}", "type": "ground", "body": f"crank{i}", "at": [x, 0.0]}
              for i, x in ((1, 0.0), (2, 1.0), (3, 0.5))]
    joints += [{"point": p, "type": "revolute", "bodies": [f"crank{i}", "coupler"]}
               for i, p in ((1, "A"), (2, "B"), (3, "C"))]
    return {"schema": "rigval-mechanism/1", "name": "parallelogram with a redundant link",
            "bodies": bodies, "joints": joints,
            "drivers": [{"name": "crank", "body": "crank1", "law": "harmonic", "theta0": 0.5,
                         "omega": 2.0, "harmonics": [{"amplitude": 0.3, "omega": 2.0}]}]}


def test_redundant_constraints_detected_solved_and_minimum_norm() -> None:
    mech = rm.load_mechanism(_parallelogram())
    assert mech.redundant_constraints == 1
    t = np.linspace(0.0, 3.0, 61)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        kin = rm.solve(mech, t, outputs=["position", "velocity", "acceleration"])
    theta = kin["position"].sel(coord="theta").to_numpy()
    driven = theta[:, 0]
    np.testing.assert_allclose(theta[:, 1], driven, atol=1e-12)
    np.testing.assert_allclose(theta[:, 2], driven, atol=1e-12)
    np.testing.assert_allclose(theta[:, 3], 0.0, atol=1e-12)
    with pytest.warns(NumericsWarning, match="not unique.*minimum-norm"):
        ds = rm.solve(mech, t, outputs=["joint_force", "driver_torque", "acceleration",
                                        "position"])
    # equilibrium: the whole-system force balance holds
    mass = np.array([b.mass for b in mech.bodies])
    acc = ds["acceleration"].to_numpy()[..., :2]
    ground = ds["joint_force"].sel(joint=["O1", "O2", "O3"]).sum("joint").to_numpy()
    np.testing.assert_allclose(ground, np.einsum("b,tbk->tk", mass, acc - [0.0, -9.81]),
                               atol=1e-9)
    # minimum norm: the multipliers have no component along the self-stress (null space)
    system = loop_system(mech)
    jac = constraint_jacobian(system, ds["position"].sel(coord="theta").to_numpy())
    lam = np.concatenate([-ds["joint_force"].to_numpy().reshape(t.size, -1),
                          -ds["driver_torque"].to_numpy()], axis=1)
    for i in (0, 30, 60):
        null = scipy.linalg.null_space(jac[i].T)
        assert null.shape[1] == 1
        assert abs(float(null[:, 0] @ lam[i])) < 1e-9 * np.linalg.norm(lam[i])
    reference = rm.solve_stepwise(mech, t[:10])
    np.testing.assert_allclose(ds["joint_force"].to_numpy()[:10],
                               reference["joint_force"].to_numpy(), atol=1e-8)


def test_bad_guess_and_large_steps_stay_on_the_branch(fourbar: rm.Mechanism,
                                                      fourbar_dict: dict[str, Any]) -> None:
    t_dense = np.linspace(0.0, 2.0, 801)
    dense = rm.solve(fourbar, t_dense, outputs=["position"])
    for body, offset in zip(fourbar_dict["bodies"], (3.0, 0.7, -0.7), strict=True):
        body["guess"] = [body["guess"][0] + 5.0, body["guess"][1] - 4.0,
                         body["guess"][2] + offset]
    bad = rm.load_mechanism(fourbar_dict)
    coarse_t = t_dense[::50]  # 1/16 s: about 50 degrees of crank per step, 4 turns
    # the undriven guesses are 0.7 rad off: stated as such, so no NumericsWarning
    coarse = rm.solve(bad, coarse_t, outputs=["position"], guess_tol=0.75)
    np.testing.assert_allclose(coarse["position"].to_numpy(),
                               dense["position"].to_numpy()[::50], atol=1e-11)


def test_high_speed_torques_grow_with_the_square_of_speed(pendulum_dict: dict[str, Any]) -> None:
    pendulum_dict["gravity"] = [0.0, 0.0]
    slow = rm.load_mechanism(pendulum_dict)
    factor = 100.0
    for driver in pendulum_dict["drivers"]:
        driver["omega"] *= factor
        for term in driver["harmonics"]:
            term["omega"] *= factor
    fast = rm.load_mechanism(pendulum_dict)
    t = np.linspace(0.0, 1.0, 201)
    slow_ds = rm.solve(slow, t, outputs=["driver_torque", "joint_force"])
    fast_ds = rm.solve(fast, t / factor, outputs=["driver_torque", "joint_force"])
    for name in ("driver_torque", "joint_force"):
        expected = factor**2 * slow_ds[name].to_numpy()
        np.testing.assert_allclose(fast_ds[name].to_numpy(), expected, rtol=0,
                                   atol=1e-10 * np.max(np.abs(expected)))


def test_very_long_run_angles_of_a_million_radians(pendulum: rm.Mechanism) -> None:
    t = np.linspace(0.0, 1.0, 101)
    late = rm.solve(pendulum, 1e5 + t, outputs=["position", "driver_torque", "joint_force"])
    early = rm.solve(pendulum, t, outputs=["position", "driver_torque", "joint_force"])
    assert late["position"].sel(body="H", coord="theta").to_numpy()[0] > 1e6
    for name in ("driver_torque", "joint_force"):
        expected = early[name].to_numpy()
        np.testing.assert_allclose(late[name].to_numpy(), expected, rtol=0,
                                   atol=1e-7 * np.max(np.abs(expected)))
    undriven = ["A", "B", "C", "D", "E", "G"]
    np.testing.assert_allclose(late["position"].sel(body=undriven).to_numpy(),
                               early["position"].sel(body=undriven).to_numpy(), atol=1e-8)


def test_jump_of_whole_turns_keeps_the_branch(fourbar: rm.Mechanism) -> None:
    t = np.linspace(0.0, 1.0, 201)
    theta, omega, alpha = fourbar.drivers[0].motion(t)
    jumped = theta + 2 * math.pi * 3 * (t > 0.3) - 2 * math.pi * 7 * (t > 0.6)
    ds = rm.solve(fourbar, t, drives={"theta_crank": (jumped, omega, alpha)},
                  outputs=["position", "driver_torque"])
    plain = rm.solve(fourbar, t, outputs=["position", "driver_torque"])
    np.testing.assert_allclose(ds["position"].sel(coord="theta", body="crank").to_numpy(), jumped)
    for body in ("coupler", "rocker"):
        np.testing.assert_allclose(ds["position"].sel(body=body).to_numpy(),
                                   plain["position"].sel(body=body).to_numpy(), atol=1e-11)
    np.testing.assert_allclose(ds["driver_torque"].to_numpy(), plain["driver_torque"].to_numpy(),
                               atol=1e-9)


def test_mechanism_that_cannot_close_names_the_open_joints(fourbar_dict: dict[str, Any]) -> None:
    fourbar_dict["bodies"][1]["points"] = {"A": [-0.01, 0.0], "B": [0.01, 0.0]}
    fourbar_dict["bodies"][2]["points"] = {"B": [0.05, 0.0], "O4": [-0.05, 0.0]}
    mech = rm.load_mechanism(fourbar_dict)  # counts are fine: the geometry is the problem
    with pytest.raises(AssemblyError, match="cannot be assembled: joints stay open") as info:
        rm.solve(mech, np.linspace(0.0, 0.1, 5))
    assert info.value.joints and set(info.value.joints) <= {"O2", "A", "B", "O4"}
    assert info.value.where["time_s"] == 0.0
    assert info.value.residual_m > 0.01
    assert "m)" in str(info.value) or " m" in str(info.value)


def test_first_step_far_from_the_guess_is_reached_by_continuation(
        pendulum: rm.Mechanism) -> None:
    t = np.linspace(0.0, 1.0, 101)
    whole = rm.solve(pendulum, t, outputs=["position", "driver_torque"])
    tail = rm.solve(pendulum, t[63:], outputs=["position", "driver_torque"])
    np.testing.assert_allclose(tail["position"].to_numpy(),
                               whole["position"].to_numpy()[63:], atol=1e-11)
