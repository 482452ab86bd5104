"""``rigval predict`` takes its defaults (tip point, drivers, outputs) from the mechanism given."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import xarray as xr

from rigval.model.predict import default_tip, predict, resolve_mechanism
from rigval.validation.cli import main


def test_default_tip_is_the_point_farthest_from_the_ground_pins() -> None:
    assert default_tip(resolve_mechanism("builtin:pendulum")) == "P1"
    assert default_tip(resolve_mechanism("builtin:fourbar")) == "B"
    assert default_tip(resolve_mechanism("builtin:single_pendulum")) == "tip"


def test_predict_builtin_fourbar_runs_with_the_mechanisms_defaults(tmp_path: Path,
                                                                    capsys) -> None:
    out = tmp_path / "fourbar"
    assert main(["predict", "builtin:fourbar", "--out", str(out), "--points", "72"]) == 0
    printed = capsys.readouterr().out
    assert "theta_crank: peak torque" in printed and "B vertical range" in printed
    cycle = pd.read_csv(out / "cycle.csv")
    # B sits on the rocker, 0.3 m from the ground pin O4 at (0.4, 0): its path is that circle
    radius = np.hypot(cycle["B_position_x_m"] - 0.4, cycle["B_position_y_m"])
    np.testing.assert_allclose(radius, 0.3, rtol=1e-9)
    with xr.open_datatree(out / "prediction.nc") as tree:
        assert list(tree["prediction"]["driver"].values) == ["theta_crank"]
        assert sorted(tree["prediction"]["support"].values) == ["O2", "O4"]


def test_predict_function_default_tip_follows_the_mechanism() -> None:
    prediction = predict(resolve_mechanism("builtin:fourbar"), n_points=36)
    assert prediction.attrs["tip_point"] == "B"
    y = prediction["point_position"].sel(point="B", axis="y").values
    assert float(prediction["tip_vertical_range"]) == pytest.approx(np.ptp(y), rel=1e-12)
