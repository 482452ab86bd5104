"""The identification problem from measured curves: stacked, weighted regressors and data.

Each measured curve (a drive torque or a joint force on the phi_F grid, its mean over the
revolutions and each revolution) is matched by its row of the regressor
(:func:`rigval.model.identify.regressor`) on the same grid; :func:`build_design` stacks them,
each weighted by the inverse of its cycle-to-cycle scatter, with friction columns for the
drivers whose torque is measured and offset columns for curves whose constant part is removed.
:func:`revolution_problems` gives each revolution its own regressor: the main shaft's speed and
acceleration over that revolution from its times at the grid angles, the other drives on the
mean path in angle, so that the slow speed wander, which the mean drives take into account,
does not count as error. :mod:`rigval.model.identify_fit` solves the problem
(docs/identify.md).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from rigval.model.identify import (
    UNITS,
    Regressor,
    nominal_parameters,
    parameter_names,
    path_regressors,
    regressor,
)
from rigval.model.identify_fit import Design, typical_sizes
from rigval.model.mechanism_types import Mechanism

__all__ = ["Curve", "build_design", "revolution_problems"]

#: (theta [rad], omega [rad/s], alpha [rad/s2]) of a driver on the grid.
DriveCurves = tuple[np.ndarray, np.ndarray, np.ndarray]


@dataclass(frozen=True)
class Curve:
    """One measured curve on the phi_F grid and the model output it measures.

    Attributes
    ----------
    name : str
        Name of the curve (the comparison).
    output : tuple of str
        ``("driver_torque", driver)`` or ``("joint_force", joint, axis)``.
    scale : float
        Measured = ``scale`` x model output.
    mean : numpy.ndarray
        ``(n,)`` mean over revolutions, signal units.
    cycles : numpy.ndarray
        ``(n_cycles, n)`` each whole revolution, signal units.
    weight : float
        Weight of its rows, 1 / signal unit (the inverse of its scatter).
    remove_offset : bool
        Its constant part is removed (an offset column is projected out).
    u_rel : float
        Relative calibration uncertainty of the sensor.
    """

    name: str
    output: tuple[str, ...]
    scale: float
    mean: np.ndarray
    cycles: np.ndarray
    weight: float
    remove_offset: bool = False
    u_rel: float = 0.0


def build_design(mechanism: Mechanism, times: np.ndarray, curves: Sequence[Curve],
                 drives: Mapping[str, DriveCurves] | None = None, *,
                 friction: bool = False) -> Design:
    """Stack the weighted regressor and data of the curves into one least-squares problem.

    Parameters
    ----------
    mechanism : Mechanism
        Geometry and nominal parameters.
    times : numpy.ndarray
        ``(n,)`` model times of the grid, s.
    curves : sequence of Curve
        The measured curves, each on the ``n`` grid points.
    drives : mapping, optional
        Driver name to its mean angle, speed and acceleration on the grid (measured drives);
        None for the mechanism file's laws.
    friction : bool
        Add viscous (N m s/rad) and Coulomb (N m) friction columns for every driver whose torque
        is among the curves; their typical size is 1 % of the nominal torque's RMS.

    Returns
    -------
    Design
        Every inertial parameter of the mechanism (and friction), rows weighted per curve.
    """
    outputs = [c.output for c in curves]
    reg = regressor(mechanism, times, outputs, drives=drives)
    nominal = nominal_parameters(mechanism)
    names = list(parameter_names(mechanism))
    values = [nominal[n] for n in names]
    units = [UNITS[n.split(".")[1]] for n in names]
    size = typical_sizes(names, nominal)
    torque_drivers = tuple(sorted({c.output[1] for c in curves
                                   if c.output[0] == "driver_torque"})) if friction else ()
    for driver in torque_drivers:
        omega = reg.omega[driver]
        for kind, column, unit in (("viscous", omega, "N m s rad-1"),
                                   ("coulomb", np.sign(omega), "N m")):
            names.append(f"{driver}.{kind}")
            values.append(0.0)
            units.append(unit)
            curve = (reg.matrix[outputs.index(("driver_torque", driver))]
                     @ np.array(values[:4 * len(mechanism.bodies)]))
            torque = float(np.sqrt(np.mean(curve**2)))
            scale = float(np.sqrt(np.mean(column**2))) or 1.0
            size.append(0.01 * torque / scale)
    weights = np.array([c.weight for c in curves])
    n = times.size
    blocks = tuple(slice(i * n, (i + 1) * n) for i in range(len(curves)))
    n_cycles = min(c.cycles.shape[0] for c in curves)
    cycles = np.concatenate([c.cycles[:n_cycles] * c.weight for c in curves], axis=1)
    mean = np.concatenate([c.mean * c.weight for c in curves])
    offsets = [i for i, c in enumerate(curves) if c.remove_offset]
    nuisance = np.zeros((len(curves) * n, len(offsets)))
    for j, i in enumerate(offsets):
        nuisance[blocks[i], j] = weights[i]
    return Design(tuple(names), np.array(values), tuple(units),
                  _weighted_columns(reg, curves, torque_drivers), np.abs(np.array(size)), mean,
                  cycles, nuisance, blocks, tuple(c.name for c in curves), weights,
                  np.array([c.u_rel for c in curves]), torque_drivers)


def _weighted_columns(reg: Regressor, curves: Sequence[Curve], friction: Sequence[str]
                      ) -> np.ndarray:
    """Stacked, scaled and weighted regressor ``(n_outputs * n, P)``, friction columns last."""
    columns = [np.moveaxis(reg.matrix, 2, 0)]     # (P, n_out, n)
    for driver in friction:
        omega = reg.omega[driver]
        for column in (omega, np.sign(omega)):
            columns.append(np.stack([column if c.output[:2] == ("driver_torque", driver)
                                     else 0.0 * column for c in curves])[None])
    stacked = np.concatenate(columns)             # (P, n_out, n)
    return np.concatenate([stacked[:, i, :] * c.scale * c.weight for i, c in enumerate(curves)],
                          axis=1).T


def revolution_problems(mechanism: Mechanism, curves: Sequence[Curve], design: Design,
                        drives: Mapping[str, DriveCurves], leading: str,
                        angle_times: np.ndarray, step: float, cycles: Sequence[np.ndarray]
                        ) -> tuple[np.ndarray, np.ndarray]:
    """Each revolution's own weighted regressor and data, for the random part of the std.

    The main drive's speed and acceleration over a revolution come from its reference times at
    the grid angles (``omega = 1 / t'``, ``alpha = -t'' omega^3``, second-order differences);
    the drive angles keep the mean path in angle, and every other drive follows it,
    ``omega_H = kappa omega_F``, ``alpha_H = kappa' omega_F^2 + kappa alpha_F`` with
    ``kappa = d theta_H / d theta_F`` of the mean drives.

    Parameters
    ----------
    mechanism : Mechanism
        As for :func:`build_design`.
    curves : sequence of Curve
        As for :func:`build_design`.
    design : Design
        The problem built from them (its friction drivers).
    drives : mapping
        Each driver's mean angle, speed and acceleration on the grid.
    leading : str
        The driver on the main encoder.
    angle_times : numpy.ndarray
        ``(n_rev, n)`` reference times of each revolution at the grid angles, s.
    step : float
        Grid step, rad.
    cycles : sequence of numpy.ndarray
        Per curve, ``(n_rev, n)``: its measurement in the same revolutions.

    Returns
    -------
    columns : numpy.ndarray
        ``(n_rev, n_rows, P)`` weighted regressors.
    data : numpy.ndarray
        ``(n_rev, n_rows)`` weighted measurements.
    """
    lead = drives[leading]
    slope = np.gradient(np.asarray(angle_times, dtype=float), step, axis=1)
    speeds = 1.0 / slope
    accelerations = -np.gradient(slope, step, axis=1) * speeds**3
    path = {}
    for name, (theta, w, a) in drives.items():
        kappa = w / lead[1]
        path[name] = (theta, kappa, (a - kappa * lead[2]) / lead[1] ** 2)
    # one path in angle at each revolution's speed: one model solve for all (path_regressors)
    regressors = path_regressors(mechanism, [c.output for c in curves], lead[0], path, speeds,
                                 accelerations)
    columns = [_weighted_columns(reg, curves, design.friction) for reg in regressors]
    data = [np.concatenate([c[row] * curve.weight for c, curve in zip(cycles, curves, strict=True)])
            for row in range(len(regressors))]
    return np.array(columns), np.array(data)
