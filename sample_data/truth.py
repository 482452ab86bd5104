"""Model truth of the virtual rig: the quantities every sensor sees, on a fine uniform time grid.

The model is solved along the true drive motion (:class:`~rigval.sample_data.drive.DriveMotion`)
on a uniform grid of true time; each device later interpolates the grid at its own sample times
with a cubic spline (relative error about ``(2 pi f h)^4 / 384``: 1e-7 for 25 Hz content on a
1 kHz grid, far below any sensor noise). The grid quantities are

=====================  ======  ================================================================
name                   unit    meaning
=====================  ======  ================================================================
``acc_P1_x``           m s-2   ``point_acceleration`` of P1 (pendulum tip), global x
``acc_P2_x``           m s-2   ``point_acceleration`` of P2 (rod B / pendulum joint), global x
``frame_force_P3_x``   N       horizontal force the main-drive pivot P3 puts on the frame
``rod_B_axial_force``  N       tension in rod B at mid-length, mean of its two end forces along
                               the rod axis P5 -> P2
``torque_theta_F``     N m     ``driver_torque`` of theta_F (whole machine, both main shafts)
``torque_theta_H``     N m     ``driver_torque`` of theta_H (both lifting shafts)
=====================  ======  ================================================================

and, used by the rig's departures (:mod:`~rigval.sample_data.departures`):
``rod_B_bending_moment`` (N m), the in-plane bending moment of rod B at mid-length from its end
forces across the axis as for a uniform load (weight and inertia), ``-(V5 + V2) L / 8``, positive
stretching the face at +n (the axis P5 -> P2 turned 90 degrees counter-clockwise);
``rod_B_axis_x`` (1), the x component of rod B's unit axis; ``rod_B_length`` (m), P5 to P2 in
the body's frame (constant).
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy.interpolate import CubicSpline

from rigval.acquisition.errors import DataError
from rigval.processing.arrays import FloatArray
from rigval.sample_data.carried_filters import CarriedLsim
from rigval.sample_data.drive import DriveMotion

__all__ = ["TruthGrid", "frame_filter", "frame_vibration", "model_truth"]

logger = logging.getLogger(__name__)

#: Knots beyond a window that :meth:`TruthGrid.window` keeps (0.27**64 ~ 1e-36).
WINDOW_MARGIN = 64


@dataclass(frozen=True)
class TruthGrid:
    """True quantities on a uniform grid of true time.

    Parameters
    ----------
    t : numpy.ndarray
        Uniform true times in s, increasing.
    values : mapping of str to numpy.ndarray
        One array per quantity, same length as ``t`` (names and units in the module docstring).
    """

    t: FloatArray
    values: Mapping[str, FloatArray]
    _splines: dict[str, CubicSpline] = field(default_factory=dict, init=False, repr=False,
                                             compare=False)

    @property
    def fs(self) -> float:
        """Grid rate in Hz."""
        return float((self.t.size - 1) / (self.t[-1] - self.t[0]))

    def at(self, name: str, t: ArrayLike) -> FloatArray:
        """Interpolate quantity ``name`` at true times ``t`` (s) with a cubic spline.

        Raises
        ------
        DataError
            If a time lies outside the grid.
        """
        t = np.asarray(t, dtype=np.float64)
        if t.size and (t.min() < self.t[0] or t.max() > self.t[-1]):
            raise DataError(f"truth asked for times {t.min():.6f} ... {t.max():.6f} s outside "
                            f"the truth grid {self.t[0]:.6f} ... {self.t[-1]:.6f} s",
                            where={"channel": name},
                            hint="extend the truth grid (pre-roll and margin) in rig settings")
        if name not in self._splines:
            self._splines[name] = CubicSpline(self.t, self.values[name])
        return np.asarray(self._splines[name](t), dtype=np.float64)

    def window(self, t_from: float, t_to: float, margin: int = WINDOW_MARGIN) -> TruthGrid:
        """Return the part of the grid from ``t_from`` to ``t_to`` (s) with ``margin`` points more.

        Its splines are those of the whole grid to rounding: a cubic spline's dependence on a
        knot decays by a factor of about 0.27 per knot, so ``margin`` knots beyond the
        window leave nothing of the cut at float64 precision. The values are views.
        """
        i0 = max(int(np.searchsorted(self.t, t_from)) - margin, 0)
        i1 = min(int(np.searchsorted(self.t, t_to)) + margin, self.t.size)
        return TruthGrid(self.t[i0:i1], {k: v[i0:i1] for k, v in self.values.items()})


def model_truth(mechanism_path: str | Path | Mapping[str, Any], drive: DriveMotion,
                t: ArrayLike) -> TruthGrid:
    """Solve the mechanism along the true drive motion and return the truth grid.

    Parameters
    ----------
    mechanism_path : str, Path or mapping
        Mechanism file (``pendulum.toml`` or one with the same points, joints and drivers), or
        its parsed content (:func:`rigval.model.load_mechanism` takes both).
    drive : DriveMotion
        True motion of both drives.
    t : array_like
        Uniform true times in s.

    Returns
    -------
    TruthGrid
        The quantities of the module docstring at ``t``.
    """
    from rigval.model import load_mechanism, solve

    t = np.asarray(t, dtype=np.float64)
    mechanism = load_mechanism(mechanism_path)
    result = solve(mechanism, t, drives=drive.angles(t),
                   outputs=("point_position", "point_acceleration", "joint_force",
                            "driver_torque"),
                   points=("P1", "P2", "P5"), joints=("P2", "P3", "P5"))
    acc = result["point_acceleration"]
    force = result["joint_force"]
    pos = result["point_position"]
    axis = (pos.sel(point="P2") - pos.sel(point="P5")).values
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    # Force ON rod B at P5 (B is the first body of joint P5) and at P2 (B is the second body of
    # joint P2, so the force on it is the negative of the joint force).
    on_b_p5 = force.sel(joint="P5").values
    on_b_p2 = -force.sel(joint="P2").values
    tension = 0.5 * (np.einsum("ij,ij->i", on_b_p2, axis) - np.einsum("ij,ij->i", on_b_p5, axis))
    normal = np.stack([-axis[:, 1], axis[:, 0]], axis=1)
    # the rod's length from its body frame: a constant, exactly the same in every piece
    rod = next(body for body in mechanism.bodies if body.name == "B")
    length = np.full(t.size, float(np.hypot(*np.subtract(rod.points["P2"], rod.points["P5"]))))
    bending = -(np.einsum("ij,ij->i", on_b_p2, normal)
                + np.einsum("ij,ij->i", on_b_p5, normal)) * length / 8.0
    values = {
        "acc_P1_x": acc.sel(point="P1", axis="x").values,
        "acc_P2_x": acc.sel(point="P2", axis="x").values,
        # P3 pins crank F to the ground: the joint force acts on F, the frame gets its negative.
        "frame_force_P3_x": -force.sel(joint="P3", axis="x").values,
        "rod_B_axial_force": tension,
        "torque_theta_F": result["driver_torque"].sel(driver="theta_F").values,
        "torque_theta_H": result["driver_torque"].sel(driver="theta_H").values,
        "rod_B_bending_moment": bending,
        "rod_B_axis_x": axis[:, 0],
        "rod_B_length": length,
    }
    return TruthGrid(t, {k: np.asarray(v, dtype=np.float64) for k, v in values.items()})


def frame_filter(dt: float, natural_hz: float, damping_ratio: float,
                 modal_mass: float) -> CarriedLsim:
    """Return the frame mode seen by acc3 as a filter from support force (N) to acceleration.

    The frame is rigid in the model; the accelerometer acc3 near P3 sees its lowest mode, a
    single degree of freedom ``m x'' + 2 zeta omega_n m x' + omega_n^2 m x = F``, whose acceleration
    is ``s^2 / (m (s^2 + 2 zeta omega_n s + omega_n^2)) F`` (m s-2 per N). It starts at rest and
    is solved exactly for an input linear between samples, piece by piece if need be.

    Parameters
    ----------
    dt : float
        Sample spacing of the force in s (the grid's ``t[1] - t[0]``).
    natural_hz : float
        Natural frequency in Hz.
    damping_ratio : float
        Damping ratio zeta (1).
    modal_mass : float
        Modal mass in kg.
    """
    wn = 2.0 * np.pi * natural_hz
    return CarriedLsim(([1.0 / modal_mass, 0.0, 0.0], [1.0, 2.0 * damping_ratio * wn, wn**2]),
                       dt)


def frame_vibration(t: ArrayLike, force: ArrayLike, natural_hz: float, damping_ratio: float,
                    modal_mass: float) -> FloatArray:
    """Return the acceleration (m s-2) of the frame mode (:func:`frame_filter`) over a record.

    Parameters
    ----------
    t : array_like
        Uniform times in s.
    force : array_like
        Force on the frame along the sensor axis in N.
    natural_hz, damping_ratio, modal_mass : float
        The mode: Hz, 1, kg.
    """
    t = np.asarray(t, dtype=np.float64)
    return frame_filter(float(t[1] - t[0]), natural_hz, damping_ratio, modal_mass).step(force)
