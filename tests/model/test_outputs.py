"""The result contract (docs/model.md, *Result contract*): names, dims, units, subsets, stages
skipped, sampled drives, and evaluation over one revolution of the main drive."""

from __future__ import annotations

import math

import numpy as np
import pytest

import rigval.model as rm
import rigval.model.solver as solver_module
from rigval.acquisition.errors import ChannelNotFoundError, ConfigError, DataError

T = np.linspace(0.0, 0.2, 21)

CONTRACT = {
    "position": (("time", "body", "coord"), "m"),
    "velocity": (("time", "body", "coord"), "m s-1"),
    "acceleration": (("time", "body", "coord"), "m s-2"),
    "point_position": (("time", "point", "axis"), "m"),
    "point_velocity": (("time", "point", "axis"), "m s-1"),
    "point_acceleration": (("time", "point", "axis"), "m s-2"),
    "joint_force": (("time", "joint", "axis"), "N"),
    "driver_torque": (("time", "driver"), "N m"),
    "support_force": (("time", "support", "axis"), "N"),
    "kinetic_energy": (("time",), "J"),
    "potential_energy": (("time",), "J"),
    "drive_power": (("time", "driver"), "W"),
    "condition_number": (("time",), "1"),
}


def test_contract_names_dims_units(pendulum: rm.Mechanism) -> None:
    ds = rm.solve(pendulum, T, outputs=rm.OUTPUTS + rm.EXTRA_OUTPUTS)
    assert set(ds.data_vars) == set(CONTRACT)
    for name, (dims, units) in CONTRACT.items():
        assert ds[name].dims == dims, name
        assert ds[name].attrs["units"] == units, name
        assert ds[name].attrs["long_name"], name
        assert np.all(np.isfinite(ds[name].to_numpy())), name
    assert ds["position"].attrs["theta_units"] == "rad"
    assert ds["acceleration"].attrs["theta_units"] == "rad s-2"
    assert list(ds["coord"].to_numpy()) == ["x", "y", "theta"]
    assert list(ds["axis"].to_numpy()) == ["x", "y"]
    assert list(ds["joint"].to_numpy()) == list(pendulum.joint_names)
    assert list(ds["driver"].to_numpy()) == ["theta_F", "theta_H"]
    assert list(ds["support"].to_numpy()) == ["P3", "P10", "P11", "P4"]
    np.testing.assert_array_equal(ds["time"].to_numpy(), T)
    assert ds["time"].attrs["units"] == "s"
    assert set(rm.solve(pendulum, T).data_vars) == set(rm.OUTPUTS)


def test_subsets_of_points_and_joints(pendulum: rm.Mechanism) -> None:
    full = rm.solve(pendulum, T, outputs=["point_acceleration", "joint_force"])
    part = rm.solve(pendulum, T, outputs=["point_acceleration", "joint_force"], points=["P1"],
                    joints=["P5", "P3"])
    assert list(part["point"].to_numpy()) == ["P1"]
    assert list(part["joint"].to_numpy()) == ["P5", "P3"]
    np.testing.assert_array_equal(part["joint_force"].to_numpy(),
                                  full["joint_force"].sel(joint=["P5", "P3"]).to_numpy())
    np.testing.assert_array_equal(part["point_acceleration"].to_numpy(),
                                  full["point_acceleration"].sel(point=["P1"]).to_numpy())
    # every joint in another order: the forces follow the order asked for
    backwards = list(pendulum.joint_names)[::-1]
    turned = rm.solve(pendulum, T, outputs=["joint_force"], joints=backwards)
    np.testing.assert_array_equal(turned["joint_force"].to_numpy(),
                                  full["joint_force"].sel(joint=backwards).to_numpy())


@pytest.mark.parametrize(("option", "value", "missing"), [
    ("outputs", ["torque"], "torque"), ("points", ["P99"], "P99"), ("joints", "Q", "Q")])
def test_unknown_names_list_what_exists(pendulum: rm.Mechanism, option: str, value: object,
                                        missing: str) -> None:
    with pytest.raises(ChannelNotFoundError, match=missing) as info:
        rm.solve(pendulum, T, **{option: value})
    assert isinstance(info.value, KeyError) and info.value.available


def _forbid(monkeypatch: pytest.MonkeyPatch, name: str) -> None:
    def refuse(*_args: object, **_kwargs: object) -> None:
        raise AssertionError(f"{name} ran although nothing needed it")

    monkeypatch.setattr(solver_module, name, refuse)


def test_positions_only_skip_velocities_and_forces(pendulum: rm.Mechanism,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    for name in ("angular_velocities", "angular_accelerations", "multipliers",
                 "applied_forces"):
        _forbid(monkeypatch, name)
    ds = rm.solve(pendulum, T, outputs=["position", "point_position"])
    assert set(ds.data_vars) == {"position", "point_position"}


def test_accelerations_without_forces_skip_multipliers(pendulum: rm.Mechanism,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    _forbid(monkeypatch, "multipliers")
    _forbid(monkeypatch, "applied_forces")
    ds = rm.solve(pendulum, T, outputs=["point_acceleration"], points="P1")
    assert ds["point_acceleration"].shape == (T.size, 1, 2)


@pytest.mark.parametrize("name", sorted(CONTRACT))
def test_each_output_alone_equals_the_full_solve(pendulum: rm.Mechanism, name: str) -> None:
    # Arrays an output does not read are not kept (forces use each chunk's accelerations):
    # every output asked for alone, e.g. the potential energy without velocities, is
    # bit-identical to the same output of a solve that keeps everything.
    full = rm.solve(pendulum, T, outputs=list(CONTRACT))
    alone = rm.solve(pendulum, T, outputs=[name])
    assert set(alone.data_vars) == {name}
    np.testing.assert_array_equal(alone[name].to_numpy(), full[name].to_numpy())


def test_sampled_drives_replace_the_law(pendulum: rm.Mechanism) -> None:
    samples = {d.name: d.motion(T) for d in pendulum.drivers}
    plain = rm.solve(pendulum, T, outputs=["driver_torque", "position"])
    sampled = rm.solve(pendulum, T, drives=samples, outputs=["driver_torque", "position"])
    np.testing.assert_array_equal(sampled["driver_torque"].to_numpy(),
                                  plain["driver_torque"].to_numpy())
    theta, omega, alpha = samples["theta_H"]
    slower = rm.solve(pendulum, T, drives={"theta_H": (theta, 0.5 * omega, alpha)},
                      outputs=["velocity"])
    np.testing.assert_allclose(slower["velocity"].sel(body="H", coord="theta").to_numpy(),
                               0.5 * omega)
    with pytest.raises(DataError, match="shape"):
        rm.solve(pendulum, T, drives={"theta_H": (theta[:-1], omega, alpha)})
    with pytest.raises(ChannelNotFoundError, match="theta_X"):
        rm.solve(pendulum, T, drives={"theta_X": (theta, omega, alpha)})
    with pytest.raises(DataError, match="not finite"):
        rm.solve(pendulum, T, drives={"theta_H": (theta, omega * np.nan, alpha)})


def test_solve_cycle_evaluates_at_main_drive_angles(pendulum: rm.Mechanism) -> None:
    cycle = rm.solve_cycle(pendulum, 64, outputs=["driver_torque", "position"])
    assert cycle["driver_torque"].dims == ("angle", "driver")
    angle = cycle["angle"].to_numpy()
    np.testing.assert_allclose(angle, np.arange(64) * 2 * math.pi / 64)
    theta_f = cycle["position"].sel(body="F", coord="theta").to_numpy()
    np.testing.assert_allclose(theta_f - pendulum.drivers[0].theta0, angle, atol=1e-12)
    direct = rm.solve(pendulum, cycle["time"].to_numpy(), outputs=["driver_torque"])
    np.testing.assert_array_equal(direct["driver_torque"].to_numpy(),
                                  cycle["driver_torque"].to_numpy())
    assert cycle.attrs["cycle_driver"] == "theta_F" and cycle.attrs["cycle_period_s"] == 1.0
    chosen = rm.solve_cycle(pendulum, np.array([0.5, 2.0]), angle_origin=0.0,
                            outputs=["position"])
    np.testing.assert_allclose(chosen["position"].sel(body="F", coord="theta").to_numpy(),
                               [0.5, 2.0], atol=1e-12)


def test_interpolated_cycle_matches_direct_solve(pendulum: rm.Mechanism) -> None:
    cycle = rm.solve_cycle(pendulum, 256, outputs=["driver_torque", "position"])
    angles = np.random.default_rng(1).uniform(0, 2 * math.pi, 50)
    fine = rm.interpolate_cycle(cycle, angles)
    direct = rm.solve_cycle(pendulum, np.sort(angles), outputs=["driver_torque", "position"])
    order = np.argsort(angles)
    torque = direct["driver_torque"].to_numpy()
    np.testing.assert_allclose(fine["driver_torque"].to_numpy()[order], torque,
                               atol=1e-4 * np.max(np.abs(torque)))
    np.testing.assert_allclose(fine["position"].to_numpy()[order], direct["position"].to_numpy(),
                               atol=1e-5)


def test_solve_cycle_needs_periodic_laws(pendulum_dict: dict) -> None:
    pendulum_dict["drivers"][1]["omega"] = 10.0
    with pytest.raises(ConfigError, match="does not repeat"):
        rm.solve_cycle(rm.load_mechanism(pendulum_dict), 8)
    with pytest.raises(ConfigError, match="sampled drives"):
        rm.solve_cycle(rm.builtin_mechanism("pendulum"), 8, drives={})


def test_solve_accepts_a_path_and_rejects_bad_times() -> None:
    ds = rm.solve(rm.builtin_mechanism("single_pendulum"), [0.0, 0.1], outputs="driver_torque")
    assert ds["driver_torque"].shape == (2, 1)
    for bad in ([[0.0, 0.1]], [], [0.0, np.nan]):
        with pytest.raises(DataError, match="1-D"):
            rm.solve(rm.builtin_mechanism("single_pendulum"), bad)
