"""The model side of a validation: only what the comparisons and predictions need, on phi_F.

:func:`run_model` solves the mechanism on a phi_F grid :data:`FINE_FACTOR` times finer than the
comparison grid (the chosen grid is every :data:`FINE_FACTOR`-th point, so its error is measured
by :func:`grid_error`): with measured drives, each driver's angle, speed and acceleration from
its encoder averaged over the revolutions at each grid angle as the encoder is smoothed, never
held on the whole grid (:func:`measured_drives`, which the pipeline's align stage calls, so
that the encoders are let go before the other streams are aligned); with analytic drives, the
mechanism file's laws over one revolution. What to compute comes from the scene through
:func:`rigval.validation.stage_settings.model_settings`. The power-balance check of the model's
numerics is :func:`rigval.model.balance.energy_residual`.
"""

from __future__ import annotations

import logging

import numpy as np
import xarray as xr

from rigval.model.mechanism import Mechanism
from rigval.model.output_values import coarse_grid_error, with_axial_forces
from rigval.model.solver import solve, solve_cycle
from rigval.processing.excitation import mean_drive_cycle
from rigval.processing.row_mean import RowMean
from rigval.validation.stage_settings import DriveEncoder, ModelSettings

__all__ = ["FINE_FACTOR", "MeanDrives", "drives_of", "grid_error", "measured_drives", "run_model"]

logger = logging.getLogger(__name__)

#: The model also runs on a grid this many times finer, to measure the chosen grid's error.
FINE_FACTOR = 4


#: Mean measured drives: the mean time since the start of the revolution per grid angle (s),
#: and per driver name its (theta, omega, alpha) on the grid (rad, rad/s, rad/s^2).
MeanDrives = tuple[np.ndarray, dict[str, tuple[np.ndarray, ...]]]


def measured_drives(encoders: tuple[DriveEncoder, ...], ref: xr.Dataset,
                    fine_times: np.ndarray) -> MeanDrives:
    """Drive angle, speed and acceleration per driver, averaged over revolutions per angle.

    Each driver's encoder handed to :func:`rigval.processing.excitation.mean_drive_cycle`,
    which averages the revolutions as it smooths the encoder: no driver's outputs are held on
    the whole fine grid.

    Parameters
    ----------
    encoders : tuple of DriveEncoder
        The drivers' encoders (:func:`rigval.validation.stage_settings.drive_encoders`).
    ref : xarray.Dataset
        The aligned reference stream holding the encoders.
    fine_times : numpy.ndarray
        Reference times of the fine phi_F grid, (n_cycle, n_fine), s.

    Returns
    -------
    times : numpy.ndarray
        Mean time since the start of the revolution per grid angle (s), for the solver.
    drives : dict
        Driver name -> (theta, omega, alpha) on the fine grid.
    """
    drives = {
        encoder.driver: mean_drive_cycle(
            ref, encoder.channel, fine_times, counts_per_rev=encoder.counts_per_rev,
            direction=encoder.direction, index_reset=encoder.index_reset,
            angle_at_reference=encoder.angle_at_reference)
        for encoder in encoders}
    return _mean_time_in_revolution(fine_times), drives


#: Revolutions of the fine grid's times taken at once by :func:`_mean_time_in_revolution`.
_BLOCK_REVOLUTIONS = 256


def _mean_time_in_revolution(fine_times: np.ndarray) -> np.ndarray:
    """Return the mean time since the start of the revolution per grid angle, s.

    ``(fine_times - fine_times[:, :1]).mean(axis=0)`` bit for bit
    (:class:`~rigval.processing.row_mean.RowMean`), a block of revolutions at a time (memory:
    not a copy of the whole grid's times).
    """
    mean = RowMean(fine_times.shape[1])
    for lo in range(0, fine_times.shape[0], _BLOCK_REVOLUTIONS):
        rows = fine_times[lo:lo + _BLOCK_REVOLUTIONS]
        mean.add(rows - rows[:, :1])
    return mean.mean()


def drives_of(fine: xr.Dataset) -> MeanDrives:
    """Return the mean drives a model of measured drives was solved with (:func:`run_model`).

    Parameters
    ----------
    fine : xarray.Dataset
        :func:`run_model`'s output for measured drives: ``drive_<driver>``, ``_dot`` and
        ``_ddot`` over its ``time`` coordinate.

    Returns
    -------
    times : numpy.ndarray
        Mean time since the start of the revolution per grid angle (s).
    drives : dict
        Driver name -> (theta, omega, alpha), the arrays themselves.
    """
    names = [str(name)[len("drive_"):] for name in fine.data_vars
             if str(name).startswith("drive_") and not str(name).endswith("dot")]
    drives = {name: tuple(fine[f"drive_{name}{end}"].values for end in ("", "_dot", "_ddot"))
              for name in names}
    return fine["time"].values, drives


def run_model(settings: ModelSettings, mechanism: Mechanism, fine_angle: np.ndarray, *,
              drives: MeanDrives | None = None) -> xr.Dataset:
    """Solve the model on the fine phi_F grid.

    Parameters
    ----------
    settings : ModelSettings
        What to compute and how the drives are excited.
    mechanism : rigval.model.Mechanism
        The mechanism.
    fine_angle : numpy.ndarray
        The fine grid over one revolution, rad.
    drives : (times, dict), optional
        The measured drives averaged on the fine grid (:func:`measured_drives`, or
        :func:`drives_of` of another mechanism's model of the same run: the drive motion is
        the measurement's, not the mechanism's); None, or analytic drives in ``settings``: the
        mechanism file's laws.

    Returns
    -------
    xarray.Dataset
        The requested model outputs with dim ``angle`` (rad); with measured drives also the mean
        drive angles ``drive_<driver>`` and their derivatives.
    """
    if settings.drives == "analytic" or drives is None:
        ds = solve_cycle(mechanism, fine_angle.size, **settings.request)
        return with_axial_forces(ds, mechanism, settings.compared.values())
    times, drives = drives
    ds = solve(mechanism, times, drives=drives, **settings.request)
    for name, (theta, omega, alpha) in drives.items():
        ds[f"drive_{name}"] = ("time", theta, {"units": "rad", "long_name": f"{name}, mean"})
        ds[f"drive_{name}_dot"] = ("time", omega, {"units": "rad s-1"})
        ds[f"drive_{name}_ddot"] = ("time", alpha, {"units": "rad s-2"})
    ds = ds.assign_coords(angle=("time", fine_angle, {"units": "rad", "long_name": "phi_F"}))
    return with_axial_forces(ds.swap_dims(time="angle"), mechanism, settings.compared.values())


def grid_error(settings: ModelSettings, fine: xr.Dataset) -> dict[str, float]:
    """Return the error of the chosen angle grid (every :data:`FINE_FACTOR`-th point) per name.

    :func:`rigval.model.output_values.coarse_grid_error` of each comparison's model quantity.

    Parameters
    ----------
    settings : ModelSettings
        The comparisons' model outputs.
    fine : xarray.Dataset
        Output of :func:`run_model`.
    """
    return coarse_grid_error(fine, settings.compared, FINE_FACTOR)
