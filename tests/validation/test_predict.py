"""Predictions and sweeps against the model, closed forms and conservation laws."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import xarray as xr

from rigval.acquisition.errors import ChannelNotFoundError, ConfigError
from rigval.model import builtin_mechanism, load_mechanism, solve, solve_cycle
from rigval.model.laws import Harmonic
from rigval.model.predict import (
    file_excitation,
    ground_pins,
    parse_sweep_option,
    predict,
    resolve_mechanism,
    sweep,
)

N = 90


@pytest.fixture(scope="module")
def pendulum():
    return load_mechanism(builtin_mechanism("pendulum"))


@pytest.fixture(scope="module")
def reference(pendulum) -> xr.Dataset:
    return predict(pendulum, n_points=N, joints=["P2"])


def test_builtin_name_and_path_give_the_same_mechanism(pendulum) -> None:
    builtin = resolve_mechanism("builtin:pendulum")
    assert builtin.bodies == pendulum.bodies and builtin.drivers == pendulum.drivers
    assert ground_pins(pendulum) == ("P3", "P10", "P11", "P4")


def test_prediction_reproduces_the_model_at_the_file_law(pendulum, reference) -> None:
    """predict's torques and support forces are solve_cycle's (model's own law and angle grid)."""
    cycle = solve_cycle(pendulum, N, outputs=["joint_force", "driver_torque", "point_position"],
                        points=["P1"])
    np.testing.assert_allclose(reference["time"].values, cycle["time"].values, rtol=0, atol=1e-12)
    torque = cycle["driver_torque"].sel(driver=list(reference["driver"].values)).values
    np.testing.assert_allclose(reference["driver_torque"].values, torque,
                               rtol=1e-9, atol=1e-9 * np.abs(torque).max())
    pins = list(reference["support"].values)
    on_frame = -cycle["joint_force"].sel(joint=pins, axis=["x", "y"]).values
    np.testing.assert_allclose(reference["support_force"].values, on_frame,
                               rtol=1e-9, atol=1e-9 * np.abs(on_frame).max())
    y = cycle["point_position"].sel(point="P1", axis="y").values
    assert float(reference["tip_vertical_range"]) == pytest.approx(y.max() - y.min(), rel=1e-12)
    assert reference["tip_vertical_range"].attrs["units"] == "m"


def test_support_force_is_the_force_on_the_frame(pendulum, reference) -> None:
    """Sign check against the model's own support_force output (force ON the ground)."""
    t = reference["time"].values
    ds = solve(pendulum, t, outputs=["support_force"])
    model = ds["support_force"].sel(support=list(reference["support"].values),
                                    axis=["x", "y"]).values
    np.testing.assert_allclose(reference["support_force"].values, model,
                               atol=1e-9 * np.abs(model).max())


def test_peaks_and_their_angles_match_the_curves(reference) -> None:
    force = reference["support_force"].sel(support="P3", axis="x").values
    i = int(np.argmax(np.abs(force)))
    peak = reference["support_force_peak"].sel(support="P3", component="x")
    assert float(peak) == pytest.approx(abs(force[i]))
    assert float(reference["support_force_peak_angle"].sel(support="P3", component="x")) == \
        pytest.approx(reference["angle"].values[i])



def test_torque_rms_is_a_time_average(pendulum, reference) -> None:
    """The RMS on the angle grid equals the plain RMS of the model on a uniform time grid."""
    t = np.arange(N) / N  # the file's law repeats every second
    torque = solve(pendulum, t, outputs=["driver_torque"])["driver_torque"].values
    np.testing.assert_allclose(reference["torque_rms"].values,
                               np.sqrt(np.mean(torque**2, axis=0)), rtol=1e-8)


def test_drives_do_no_net_work_over_a_cycle(reference) -> None:
    """No losses in the model: the drive power integrates to zero over a periodic cycle."""
    power = reference["drive_power"].sum("driver").values
    scale = float(np.trapezoid(np.abs(power), reference["time"].values))
    assert abs(float(reference["cycle_work"])) < 1e-9 * scale


def test_changed_lifting_phase_moves_the_tip_path(pendulum, reference) -> None:
    shifted = predict(pendulum, ["theta_H={phase = 1.0}"], n_points=N)
    base_y = reference["point_position"].sel(point="P1", axis="y").values
    y = shifted["point_position"].sel(point="P1", axis="y").values
    assert np.max(np.abs(y - base_y)) > 1e-3
    lifted = shifted["drive_angle"].sel(driver="theta_H").values
    np.testing.assert_allclose(lifted - reference["drive_angle"].sel(driver="theta_H").values,
                               1.0, atol=1e-12)


def test_constant_speed_sweep_without_gravity_scales_with_speed_squared(pendulum) -> None:
    """Torques and support forces of a constant-speed drive without gravity go as f**2."""
    weightless = dataclasses.replace(pendulum, gravity=(0.0, 0.0))
    constant = ["theta_F={harmonics = []}", "theta_H={harmonics = []}"]
    frequencies = np.array([0.5, 0.8, 1.0, 1.5])
    result = sweep(weightless, {"frequency": frequencies}, drives=constant, n_points=N,
                   summary=["support_force_peak", "torque_peak", "torque_rms",
                            "tip_acceleration_peak"])
    for name in ("support_force_peak", "torque_peak", "torque_rms", "tip_acceleration_peak"):
        per_f2 = (result[name] / result["frequency"] ** 2).values
        np.testing.assert_allclose(per_f2, np.broadcast_to(per_f2[0], per_f2.shape), rtol=1e-9)
    # ... and each point is what a full solve at that speed gives (no shortcut error).
    for frequency in frequencies:
        direct = predict(weightless, [*constant, f"theta_F={{frequency = {frequency}}}"],
                         n_points=N)
        point = result.sel(frequency=frequency)
        np.testing.assert_allclose(point["torque_peak"].values, direct["torque_peak"].values,
                                   rtol=1e-9)
        np.testing.assert_allclose(point["support_force_peak"].values,
                                   direct["support_force_peak"].sel(component="magnitude").values,
                                   rtol=1e-9)


def test_two_parameter_sweep_equals_direct_predictions(pendulum) -> None:
    phases = np.array([0.0, 2.0])
    result = sweep(pendulum, {"frequency": [0.7, 1.3], "theta_H.phase": phases}, n_points=N)
    assert result.attrs["model_solves"] == len(phases)  # one solve per tip path
    assert result["tip_vertical_range"].dims == ("frequency", "theta_H.phase")
    for frequency in (0.7, 1.3):
        for phase in phases:
            direct = predict(pendulum, [f"theta_F={{frequency = {frequency}}}",
                                        f"theta_H={{phase = {phase}}}"], n_points=N)
            point = result.sel(frequency=frequency, **{"theta_H.phase": phase})
            for name in ("tip_vertical_range", "tip_acceleration_peak", "torque_peak",
                         "torque_rms"):
                np.testing.assert_allclose(point[name].values, direct[name].values, rtol=1e-9)
            np.testing.assert_allclose(
                point["support_force_peak"].values,
                direct["support_force_peak"].sel(component="magnitude").values, rtol=1e-9)


def test_mass_sweep_reuses_kinematics_exactly(pendulum) -> None:
    masses = [300.0, 400.0, 550.0]
    result = sweep(pendulum, {"A.mass": masses, "frequency": [0.6, 1.2]}, n_points=N,
                   summary=["torque_peak", "support_force_peak"])
    heavier = dataclasses.replace(pendulum, bodies=tuple(
        dataclasses.replace(b, mass=550.0) if b.name == "A" else b for b in pendulum.bodies))
    direct = predict(heavier, ["theta_F={frequency = 1.2}"], n_points=N)
    np.testing.assert_allclose(result["torque_peak"].sel({"A.mass": 550.0, "frequency": 1.2}),
                               direct["torque_peak"].values, rtol=1e-9)
    assert result.attrs["model_solves"] == 2  # the base mass and a changed one


def test_summary_that_needs_only_positions_solves_no_forces(pendulum) -> None:
    result = sweep(pendulum, {"theta_H.h1.amplitude": [0.0, 0.1, 0.2]},
                   summary=["tip_vertical_range"], n_points=N)
    assert list(result.data_vars) == ["tip_vertical_range"]
    assert result.attrs["model_solves"] == 3
    assert float(result["tip_vertical_range"].sel({"theta_H.h1.amplitude": 0.1})) == \
        pytest.approx(float(predict(pendulum, n_points=N)["tip_vertical_range"]), rel=1e-12)


def test_harmonic_parameter_changes_the_law(pendulum) -> None:
    excitation = file_excitation(pendulum)
    assert excitation.law("theta_H").harmonics == (Harmonic(0.1, 1.0, 0.0),)


@pytest.mark.parametrize("parameters, text", [
    ({"theta_X.phase": [0.0]}, "cannot sweep"),
    ({"theta_H.h3.amplitude": [0.0]}, "no harmonic 3"),
    ({"A.volume": [1.0]}, "cannot sweep"),
    ({}, "one or two"),
    ({"frequency": [1.0], "A.mass": [1.0], "B.mass": [1.0]}, "one or two"),
    ({"frequency": []}, "non-empty"),
])
def test_bad_sweeps_are_config_errors(pendulum, parameters, text) -> None:
    with pytest.raises(ConfigError, match=text):
        sweep(pendulum, parameters, n_points=N)


def test_unknown_points_and_joints_list_what_exists(pendulum) -> None:
    with pytest.raises(ChannelNotFoundError, match="P99"):
        predict(pendulum, tip="P99", n_points=N)
    with pytest.raises(ChannelNotFoundError, match="P2"):
        predict(pendulum, joints=["Q"], n_points=N)


@pytest.mark.parametrize("text, name, values", [
    ("frequency=0.5:1.5:3", "frequency", [0.5, 1.0, 1.5]),
    ("theta_H.phase=0:180:3deg", "theta_H.phase", [0.0, math.pi / 2, math.pi]),
    ("frequency=30,60rpm", "frequency", [0.5, 1.0]),
    ("A.mass = 1e2, 2E2", "A.mass", [100.0, 200.0]),
])
def test_sweep_options_parse_to_si(text, name, values) -> None:
    parsed_name, parsed = parse_sweep_option(text)
    assert parsed_name == name
    np.testing.assert_allclose(parsed, values)


@pytest.mark.parametrize("text", ["frequency", "frequency=1:2", "frequency=a,b",
                                  "frequency=1:2:3furlongs", "frequency=nan", "frequency=1:2:0"])
def test_bad_sweep_options_are_config_errors(text) -> None:
    with pytest.raises(ConfigError):
        parse_sweep_option(text)


def test_swinging_main_drive_uses_the_cycle_phase_and_matches_the_closed_form() -> None:
    """Driven single pendulum: torque = m g l sin(theta) + (J + m l^2) theta'' (closed form)."""
    mechanism = resolve_mechanism("builtin:single_pendulum")
    result = predict(mechanism, tip="tip", n_points=64)
    assert "cycle phase" in result["angle"].attrs["long_name"]
    np.testing.assert_allclose(result["time"].values, np.arange(64) * 2.0 / 64, atol=1e-15)
    m, inertia, arm, g = 5.0, 0.2, 0.5, 9.81
    theta = result["drive_angle"].sel(driver="theta_P").values
    alpha = result["drive_acceleration"].sel(driver="theta_P").values
    expected = m * g * arm * np.sin(theta) + (inertia + m * arm**2) * alpha
    np.testing.assert_allclose(result["driver_torque"].sel(driver="theta_P").values, expected,
                               atol=1e-9 * np.abs(expected).max())
    swept = sweep(mechanism, {"frequency": [0.25, 1.0]}, tip="tip", n_points=64,
                  summary=["torque_peak"])
    faster = predict(mechanism, ["theta_P={frequency = 1.0}"], tip="tip", n_points=64)
    np.testing.assert_allclose(swept["torque_peak"].sel(frequency=1.0).values,
                               faster["torque_peak"].values, rtol=1e-9)
