"""Figures redrawn in one reused figure render exactly like new ones, and keep their content.

The run report draws the point kinematics of every point into one figure (as it does the
comparisons); the images must equal those of a new figure per point, in either order, with no
line, limit, label or "exactly 0" note of the previous point left over.
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from rigval.model import builtin_mechanism, load_mechanism
from rigval.model.predict import predict
from rigval.validation.report.page import figure_data_uri
from rigval.validation.report.plots import plot_point_kinematics, plot_points_kinematics


@pytest.fixture(scope="module")
def prediction() -> xr.Dataset:
    return predict(load_mechanism(builtin_mechanism("pendulum")), n_points=72)


def _with_resting_point(prediction: xr.Dataset) -> xr.Dataset:
    """Add a point "REST" that never moves: its speed and acceleration are exactly zero."""
    rest = prediction.isel(point=[0]).assign_coords(point=["REST"])
    for name in ("point_velocity", "point_acceleration"):
        rest[name] = xr.zeros_like(rest[name])
    rest["point_position"] = xr.full_like(rest["point_position"], 0.25)
    kinematic = ["point_position", "point_velocity", "point_acceleration"]
    return xr.concat([prediction[kinematic], rest[kinematic]], dim="point")


def test_reused_kinematics_figure_renders_like_a_new_one(prediction) -> None:
    data = _with_resting_point(prediction)
    points = [str(p) for p in data["point"].values]
    order = [points[-1], *points[:-1], points[-1]]  # the resting point first, between, last
    fresh = [figure_data_uri(plot_point_kinematics(data, p), dpi=40) for p in order]
    reused = [figure_data_uri(fig, dpi=40) for fig in plot_points_kinematics(data, order)]
    assert len(set(fresh)) == len(set(order))  # different points give different images
    assert reused == fresh


def test_reused_kinematics_figure_holds_only_the_current_point(prediction) -> None:
    data = _with_resting_point(prediction)
    figures = plot_points_kinematics(data, ["REST", "P1"])
    rest = next(figures)
    assert [len(ax.lines) for ax in rest.axes] == [1, 1, 1]
    assert [t.get_text() for t in rest.axes[1].texts] == ["exactly 0"]
    moving = next(figures)
    assert moving is rest  # one figure, redrawn
    assert [len(ax.lines) for ax in moving.axes] == [1, 1, 1]
    assert not any(ax.texts for ax in moving.axes)
    speed = np.hypot(*(data["point_velocity"].sel(point="P1", axis=a).values for a in "xy"))
    np.testing.assert_allclose(moving.axes[1].lines[0].get_ydata()[:-1], speed)
    assert moving.axes[1].get_ylabel() == "|v| of P1 [m/s]"
    low, high = moving.axes[1].get_ylim()
    assert low <= speed.min() and high >= speed.max() and (low, high) != (-1.0, 1.0)
