"""The model side of a validation: only what the comparisons and predictions need, on phi_F.

:func:`run_model` solves the scene's mechanism on a phi_F grid :data:`FINE_FACTOR` times finer
than the comparison grid (the chosen grid is every :data:`FINE_FACTOR`-th point, so its error is
measured by :func:`grid_error`): with measured drives, each driver's angle, speed and
acceleration from its encoder averaged over the revolutions at each grid angle; with analytic
drives, the mechanism file's laws over one revolution. The power-balance check of the model's
numerics is :func:`rigval.model.balance.energy_residual`.
"""

from __future__ import annotations

import logging
from typing import Any

import numpy as np
import xarray as xr

from rigval.model.mechanism import Mechanism
from rigval.model.output_values import coarse_grid_error, model_values, with_axial_forces
from rigval.model.solver import solve, solve_cycle
from rigval.processing.excitation import mean_drive_cycle
from rigval.validation.scene_types import Scene

__all__ = ["FINE_FACTOR", "grid_error", "model_request", "model_values", "run_model"]

logger = logging.getLogger(__name__)

#: The model also runs on a grid this many times finer, to measure the chosen grid's error.
FINE_FACTOR = 4



def model_request(scene: Scene, mechanism: Mechanism) -> dict[str, Any]:
    """Return the :func:`rigval.model.solve` request of a scene: only what it compares or predicts.

    Parameters
    ----------
    scene : Scene
        The scene (its comparisons and ``[predictions]``).
    mechanism : rigval.model.Mechanism
        The mechanism (for the order of points and joints).

    Returns
    -------
    dict
        ``outputs`` and, where needed, ``points`` and ``joints``.
    """
    outputs = {c.model.quantity for c in scene.comparisons}
    points = {c.model.item for c in scene.comparisons if c.model.quantity.startswith("point_")}
    joints = {c.model.item for c in scene.comparisons
              if c.model.quantity in ("joint_force", "joint_axial_force")}
    if "joint_axial_force" in outputs:  # derived from joint forces and body angles
        outputs = (outputs - {"joint_axial_force"}) | {"joint_force", "position"}
    if scene.predictions.points:
        outputs |= {"point_position", "point_velocity", "point_acceleration"}
        points |= set(scene.predictions.points)
    if scene.predictions.supports is None or scene.predictions.supports:
        outputs.add("support_force")
    request: dict[str, Any] = {"outputs": sorted(outputs)}
    if points:
        request["points"] = [p for p in mechanism.point_names if p in points]
    if joints:
        request["joints"] = [j for j in mechanism.joint_names if j in joints]
    return request


def _measured_drives(scene: Scene, ref: xr.Dataset, fine_times: np.ndarray
                     ) -> tuple[np.ndarray, dict[str, tuple[np.ndarray, ...]]]:
    """Drive angle, speed and acceleration per driver, averaged over revolutions per angle.

    Each driver's encoder and ``angle_at_reference`` from ``[model.drivers]``, handed to
    :func:`rigval.processing.excitation.mean_drive_cycle`.

    Parameters
    ----------
    scene : Scene
        The scene (``[model.drivers]``).
    ref : xarray.Dataset
        The aligned reference stream holding the encoders.
    fine_times : numpy.ndarray
        Reference times of the fine phi_F grid, (n_cycle, n_fine).

    Returns
    -------
    times : numpy.ndarray
        Mean time since the start of the revolution per grid angle (s), for the solver.
    drives : dict
        Driver name -> (theta, omega, alpha) on the fine grid.
    """
    drives = {}
    for name, driver in scene.model.drivers.items():
        params = scene.channel(driver.encoder).params
        drives[name] = mean_drive_cycle(
            ref, driver.encoder.channel, fine_times, counts_per_rev=params["counts_per_rev"],
            direction=float(driver.direction), index_reset=bool(params.get("index_reset", False)),
            angle_at_reference=driver.angle_at_reference)
    times = (fine_times - fine_times[:, :1]).mean(axis=0)
    return times, drives


def run_model(scene: Scene, mechanism: Mechanism, ref: xr.Dataset, fine_times: np.ndarray,
               fine_angle: np.ndarray) -> xr.Dataset:
    """Solve the model on the fine phi_F grid.

    Parameters
    ----------
    scene : Scene
        The scene.
    mechanism : rigval.model.Mechanism
        Its mechanism.
    ref : xarray.Dataset
        The aligned reference stream (encoders, for measured drives).
    fine_times : numpy.ndarray
        Reference times of the fine grid, (n_cycle, n_fine), s.
    fine_angle : numpy.ndarray
        The fine grid over one revolution, rad.

    Returns
    -------
    xarray.Dataset
        The requested model outputs with dim ``angle`` (rad); with measured drives also the mean
        drive angles ``drive_<driver>`` and their derivatives.
    """
    request = model_request(scene, mechanism)
    if scene.model.drives == "analytic":
        return _with_axial(scene, mechanism, solve_cycle(mechanism, fine_angle.size, **request))
    times, drives = _measured_drives(scene, ref, fine_times)
    ds = solve(mechanism, times, drives=drives, **request)
    for name, (theta, omega, alpha) in drives.items():
        ds[f"drive_{name}"] = ("time", theta, {"units": "rad", "long_name": f"{name}, mean"})
        ds[f"drive_{name}_dot"] = ("time", omega, {"units": "rad s-1"})
        ds[f"drive_{name}_ddot"] = ("time", alpha, {"units": "rad s-2"})
    ds = ds.assign_coords(angle=("time", fine_angle, {"units": "rad", "long_name": "phi_F"}))
    return _with_axial(scene, mechanism, ds.swap_dims(time="angle"))


def _with_axial(scene: Scene, mechanism: Mechanism, ds: xr.Dataset) -> xr.Dataset:
    """Add ``joint_axial_force`` (dims angle, member; N, tension positive) where compared."""
    return with_axial_forces(ds, mechanism, (c.model for c in scene.comparisons))


def grid_error(scene: Scene, fine: xr.Dataset) -> dict[str, float]:
    """Return the error of the chosen angle grid (every :data:`FINE_FACTOR`-th point) per name.

    :func:`rigval.model.output_values.coarse_grid_error` of each comparison's model quantity.

    Parameters
    ----------
    scene : Scene
        The scene (its comparisons).
    fine : xarray.Dataset
        Output of :func:`run_model`.
    """
    return coarse_grid_error(fine, {c.name: c.model for c in scene.comparisons}, FINE_FACTOR)
