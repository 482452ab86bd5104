"""Inputs whose results overflow double precision are a ModelError naming the cause (item 10).

Without the check, a mass or gravity of 1e308 or a drive speed of 1e300 gave inf/NaN torques with
only numpy's RuntimeWarning (an error under pytest's filter here: ``-W error`` makes the old
behaviour fail loudly).
"""

from __future__ import annotations

import dataclasses
import tomllib
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

import rigval.model as rm
from rigval.acquisition.errors import DataError
from rigval.model.errors import MechanismError, ModelError

T = np.linspace(0.0, 0.5, 11)


def _fourbar(change: Callable[[dict[str, Any]], object]) -> rm.Mechanism:
    data = tomllib.loads(rm.builtin_mechanism("fourbar").read_text())
    change(data)
    return rm.load_mechanism(data)


def _with_body(mech: rm.Mechanism, name: str, **values: float) -> rm.Mechanism:
    bodies = tuple(dataclasses.replace(b, **values) if b.name == name else b for b in mech.bodies)
    return dataclasses.replace(mech, bodies=bodies)


OVERFLOWING = [
    (lambda d: d["bodies"][1].update(mass=1e308),
     lambda m: _with_body(m, "coupler", mass=1e308), "mass 1e+308 kg of body 'coupler'",
     "bodies[1].mass"),
    (lambda d: d["bodies"][2].update(inertia=1e308),
     lambda m: _with_body(m, "rocker", inertia=1e308), "inertia 1e+308 kg m2 of body 'rocker'",
     "bodies[2].inertia"),
    (lambda d: d.update(gravity=[0.0, -1e308]),
     lambda m: dataclasses.replace(m, gravity=(0.0, -1e308)), "gravity 1e+308 m/s2",
     "gravity[1]"),
]


@pytest.mark.parametrize(("change", "key"), [(c[0], c[3]) for c in OVERFLOWING])
def test_overflowing_mass_or_gravity_is_refused_in_the_file(change, key: str) -> None:
    with pytest.raises(MechanismError, match="expected a magnitude of at most") as info:
        _fourbar(change)
    assert info.value.where["key"] == key


@pytest.mark.parametrize(("build", "cause"), [(c[1], c[2]) for c in OVERFLOWING])
def test_overflowing_mass_or_gravity_is_a_model_error(build, cause: str) -> None:
    """Built in code (past the file's ranges), the solver still names the overflow's cause."""
    mech = build(rm.load_mechanism(rm.builtin_mechanism("fourbar")))
    with warnings.catch_warnings():
        warnings.simplefilter("error")          # no numpy RuntimeWarning on the way
        with pytest.raises(ModelError, match="not finite") as info:
            rm.solve(mech, T, outputs=["driver_torque", "joint_force"])
    assert cause in str(info.value)
    assert info.value.where["time_s"] == 0.0
    # kinematics alone do not involve the masses: still fine
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ds = rm.solve(mech, T, outputs=["acceleration"])
    assert np.all(np.isfinite(ds["acceleration"].to_numpy()))


def test_overflowing_drive_speed_is_a_model_error() -> None:
    mech = rm.load_mechanism(rm.builtin_mechanism("fourbar"))
    drive = (0.3 + 0.1 * T, np.full_like(T, 1e300), np.zeros_like(T))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ModelError, match="not finite") as info:
            rm.solve(mech, T, drives={"theta_crank": drive}, outputs=["driver_torque"])
    assert "drive speed 1e+300 rad/s of driver 'theta_crank'" in str(info.value)


def test_non_finite_drive_samples_are_a_data_error() -> None:
    mech = rm.load_mechanism(rm.builtin_mechanism("fourbar"))
    speed = np.ones_like(T)
    speed[4] = np.inf
    with pytest.raises(DataError, match=r"theta_crank.*not finite at index 4"):
        rm.solve(mech, T, drives={"theta_crank": (0.3 + T, speed, np.zeros_like(T))},
                 outputs=["driver_torque"])


def test_large_but_finite_inputs_still_solve_exactly() -> None:
    """1e150 kg is absurd but representable: torques scale exactly with the masses.

    A mechanism file refuses such masses (docs/mechanism.md, Ranges); built in code, the
    solver still handles them exactly.
    """
    scale = 1e150
    mech = rm.load_mechanism(rm.builtin_mechanism("fourbar"))
    base = rm.solve(mech, T, outputs=["driver_torque"])
    heavy = dataclasses.replace(mech, bodies=tuple(
        dataclasses.replace(b, mass=b.mass * scale, inertia=b.inertia * scale)
        for b in mech.bodies))
    scaled = rm.solve(heavy, T, outputs=["driver_torque"])
    np.testing.assert_allclose(scaled["driver_torque"].to_numpy() / scale,
                               base["driver_torque"].to_numpy(), rtol=1e-12)


def test_predict_with_an_absurd_frequency_exits_2_naming_it(tmp_path, capsys) -> None:
    from rigval.validation.cli import main

    for option in (["--drive", "theta_crank={frequency = 1e300}"],
                   ["--sweep", "frequency=1,1e300"]):
        code = main(["predict", "builtin:fourbar", "--out", str(tmp_path / "p"), "--points",
                     "36", *option])
        err = capsys.readouterr().err
        assert code == 2, err
        assert "frequency" in err and "1e+300" in err and "Traceback" not in err
    assert not (tmp_path / "p").exists()
