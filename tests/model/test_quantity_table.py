"""The one table of model quantities (model/results.py) matches what the solver returns and what
the scene and prediction read from it."""

from __future__ import annotations

import numpy as np

import rigval.model as rm
from rigval.model.results import COMPARABLE, QUANTITIES
from rigval.validation.scene_types import MODEL_QUANTITIES

T = np.linspace(0.0, 0.2, 11)


def test_table_describes_the_solved_dataset(pendulum: rm.Mechanism) -> None:
    ds = rm.solve(pendulum, T, outputs=rm.OUTPUTS + rm.EXTRA_OUTPUTS)
    assert set(QUANTITIES) - {"joint_axial_force"} == set(ds.data_vars)
    for name in ds.data_vars:
        quantity = QUANTITIES[name]
        expected_dims = ("time", *(d for d in (quantity.item, quantity.axis) if d))
        assert ds[name].dims == expected_dims, name
        if quantity.axes is not None:
            assert tuple(ds[quantity.axis].to_numpy()) == quantity.axes, name
        units = ds[name].attrs["units"]
        assert {units, ds[name].attrs.get("theta_units", units)} == set(quantity.units.values())


def test_scene_reads_the_comparable_quantities_from_the_table() -> None:
    assert tuple(MODEL_QUANTITIES) == COMPARABLE
    assert MODEL_QUANTITIES["position"] == ("body", ("x", "y", "theta"),
                                            {"x": "m", "y": "m", "theta": "rad"})
    assert MODEL_QUANTITIES["driver_torque"] == ("driver", None, {"": "N m"})
    assert MODEL_QUANTITIES["joint_axial_force"] == ("joint", None, {"": "N"})


def test_prediction_units_come_from_the_table() -> None:
    from rigval.model.predict import predict, resolve_mechanism

    result = predict(resolve_mechanism("builtin:single_pendulum"), n_points=12)
    for name in ("point_position", "point_acceleration", "driver_torque", "drive_power",
                 "joint_force", "support_force"):
        assert result[name].attrs["units"] == next(iter(QUANTITIES[name].units.values()))
