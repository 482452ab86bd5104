"""One model quantity picked out of a result, and the axial forces added to it."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

import rigval.model as rm
from rigval.model.mechanism import mechanism_file
from rigval.model.output_values import (
    ModelOutput,
    axial_label,
    coarse_grid_error,
    model_values,
    with_axial_forces,
)
from rigval.model.results import axial_joint_force


def test_picked_values_and_axial_force_match_the_result() -> None:
    # Independent expectation: the same numbers read straight from the solver's Dataset, and the
    # axial force from rigval.model.results.axial_joint_force; units from the result contract.
    mechanism = rm.load_mechanism(mechanism_file("builtin:fourbar"))
    result = rm.solve_cycle(mechanism, 36)
    joint = next(j for j in mechanism.joints if "ground" not in j.bodies)
    body = joint.bodies[0]
    point = mechanism.point_names[0]
    driver = mechanism.driver_names[0]
    picked = model_values(result, ModelOutput("point_velocity", point, "y"))
    np.testing.assert_array_equal(
        picked, result["point_velocity"].sel(point=point, axis="y").to_numpy())
    torque = ModelOutput("driver_torque", driver)
    np.testing.assert_array_equal(model_values(result, torque),
                                  result["driver_torque"].sel(driver=driver).to_numpy())
    assert torque.units == "N m" and ModelOutput("position", body, "theta").units == "rad"
    axial = ModelOutput("joint_axial_force", joint.name, body=body)
    assert with_axial_forces(result, mechanism, [torque]) is result       # nothing asked
    added = with_axial_forces(result, mechanism, [axial, torque, axial])
    assert list(added["member"].values) == [axial_label(axial)]          # once each
    expected = axial_joint_force(result, mechanism, joint.name, body)
    np.testing.assert_array_equal(model_values(added, axial), expected.to_numpy())
    assert str(axial) == f"joint_axial_force[{joint.name}] on {body}"


def test_coarse_grid_error_equals_a_periodic_spline_through_every_step_th_angle() -> None:
    # Second method: scipy's periodic cubic spline through every 4th (12th) of 72 angles of the
    # four-bar, evaluated on all 72, against the fine values, relative to the range; the grid
    # itself (step 1) has no error, and a coarser grid a larger one.
    mechanism = rm.load_mechanism(mechanism_file("builtin:fourbar"))
    fine = rm.solve_cycle(mechanism, 72)
    outputs = {"x": ModelOutput("point_position", mechanism.point_names[-1], "x"),
               "torque": ModelOutput("driver_torque", mechanism.driver_names[0])}
    angle = fine["angle"].to_numpy()
    for step in (4, 12):
        got = coarse_grid_error(fine, outputs, step)
        for name, output in outputs.items():
            values = model_values(fine, output)
            knots = np.append(angle[::step], angle[0] + 2 * np.pi)
            spline = CubicSpline(knots, np.append(values[::step], values[0]), bc_type="periodic")
            expected = np.max(np.abs(spline(angle) - values)) / np.ptp(values)
            assert abs(got[name] - expected) <= 1e-9 * max(expected, 1e-12), (step, name)
    assert coarse_grid_error(fine, outputs, 4)["torque"] < coarse_grid_error(
        fine, outputs, 12)["torque"]
    assert coarse_grid_error(fine, outputs, 1) == {"x": 0.0, "torque": 0.0}


def test_picked_values_are_a_float64_copy_and_an_unknown_label_is_refused() -> None:
    # Independent expectation: xarray's own sel of every quantity, item and axis of a result,
    # the values bit for bit; the picked array is the caller's (float64, not a view).
    mechanism = rm.load_mechanism(mechanism_file("builtin:fourbar"))
    result = rm.solve_cycle(mechanism, 24)
    point, driver = mechanism.point_names[0], mechanism.driver_names[0]
    for output, expected in (
            (ModelOutput("point_acceleration", point, "x"),
             result["point_acceleration"].sel(point=point, axis="x")),
            (ModelOutput("driver_torque", driver), result["driver_torque"].sel(driver=driver))):
        picked = model_values(result, output)
        assert picked.dtype == np.float64 and picked.flags.owndata
        assert picked.tobytes() == expected.to_numpy().astype(np.float64).tobytes()
        picked[:] = np.nan
        assert np.all(np.isfinite(model_values(result, output)))
    with pytest.raises(KeyError):
        model_values(result, ModelOutput("driver_torque", "no such driver"))
