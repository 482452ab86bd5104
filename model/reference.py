"""The plain algorithm of the paper, step by step in full coordinates: a baseline and a check.

At every time step: Newton-Raphson on all ``3 n_bodies`` absolute coordinates ``C(e, t) = 0`` from
the previous step's solution, then ``C_e e' = -C_t`` (eq. 8), ``C_e e'' = Q_d`` (eq. 9) and
``C_e^T lambda = Q_e - M e''`` (eqs. 13, 18), each with LAPACK on the full matrix (least squares,
minimum norm, when the constraints are redundant). It is slow and independent of the reduced,
batched solver of :func:`rigval.model.solve`, which makes it the reference for tests and
benchmarks.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np
import xarray as xr

from rigval.model.drives import SampledDrive, drive_motion
from rigval.model.dynamics import applied_forces
from rigval.model.errors import AssemblyError
from rigval.model.loops import LoopSystem, loop_system
from rigval.model.mechanism import Mechanism, load_mechanism
from rigval.model.results import OUTPUTS, Solution, build_dataset, select

__all__ = ["constraint_jacobian", "solve_stepwise"]


def constraint_jacobian(system: LoopSystem, theta: np.ndarray) -> np.ndarray:
    """Full constraint Jacobian ``C_e`` at given body angles, batched.

    Parameters
    ----------
    system : LoopSystem
        Constraint matrices (incidence, point vectors, driven bodies).
    theta : numpy.ndarray
        (n, n_bodies) body angles, rad.

    Returns
    -------
    numpy.ndarray
        (n, 2 n_joints + n_drivers, 3 n_bodies): rows x, y of each joint then one per driver;
        columns x, y, theta of each body.
    """
    n, n_bodies = theta.shape
    n_joints = system.incidence.shape[0]
    jac = np.zeros((n, 2 * n_joints + system.driven.size, 3 * n_bodies))
    jac[:, 0:2 * n_joints:2, 0::3] = system.incidence
    jac[:, 1:2 * n_joints:2, 1::3] = system.incidence
    arm = 1j * system.points * np.exp(1j * theta)[:, None, :]
    jac[:, 0:2 * n_joints:2, 2::3] = arm.real
    jac[:, 1:2 * n_joints:2, 2::3] = arm.imag
    for row, body in enumerate(system.driven):
        jac[:, 2 * n_joints + row, 3 * body + 2] = 1.0
    return jac


def _residual(system: LoopSystem, e: np.ndarray, theta_d: np.ndarray) -> np.ndarray:
    """``C(e, t)`` for one step: joint gaps (x, y per joint) then driver errors."""
    position = e[0::3] + 1j * e[1::3]
    gap = system.incidence @ position + system.points @ np.exp(1j * e[2::3]) - system.ground
    return np.concatenate([np.stack([gap.real, gap.imag], axis=-1).ravel(),
                           e[2::3][system.driven] - theta_d])


def _lstsq(matrix: np.ndarray, rhs: np.ndarray, square: bool) -> np.ndarray:
    if square:
        return np.linalg.solve(matrix, rhs)
    return np.linalg.lstsq(matrix, rhs, rcond=None)[0]


def solve_stepwise(mechanism: Mechanism | str | Path, t: np.ndarray, *,
                   drives: Mapping[str, SampledDrive] | None = None, tol: float = 1e-12,
                   max_iter: int = 20) -> xr.Dataset:
    """Full inverse dynamics step by step in full coordinates (the paper's algorithm as written).

    Parameters
    ----------
    mechanism : Mechanism, str or pathlib.Path
        The mechanism or its file; Newton starts from the bodies' guesses.
    t : array_like
        (n,) times, s, close enough for each step to start from the previous one.
    drives : mapping, optional
        Sampled drives, as for :func:`rigval.model.solve`.
    tol : float
        Newton tolerance on the coordinate update (m and rad, relative to the mechanism size).
    max_iter : int
        Newton iterations per step.

    Returns
    -------
    xarray.Dataset
        Every variable of :data:`~rigval.model.results.OUTPUTS`, as :func:`rigval.model.solve`.
    """
    mech = mechanism if isinstance(mechanism, Mechanism) else load_mechanism(mechanism)
    times = np.asarray(t, dtype=float)
    system = loop_system(mech)
    motion = drive_motion(mech, times, drives)
    n, n_bodies, n_joints = times.size, len(mech.bodies), len(mech.joints)
    square = 2 * n_joints + len(mech.drivers) == 3 * n_bodies
    e = np.array([c for body in mech.bodies for c in body.guess])
    coords = np.empty((n, 3 * n_bodies))
    speeds = np.empty_like(coords)
    accels = np.empty_like(coords)
    lam = np.empty((n, 2 * n_joints + len(mech.drivers)))
    scale = np.tile([system.length_scale, system.length_scale, 1.0], n_bodies)
    for i in range(n):
        for _ in range(max_iter):
            jac = constraint_jacobian(system, e[None, 2::3])[0]
            step = _lstsq(jac, _residual(system, e, motion.theta[i]), square)
            e = e - step
            if np.max(np.abs(step) / scale) <= tol:
                break
        else:
            raise AssemblyError(f"Newton did not converge at t = {times[i]:.9g} s",
                                where={"file": mech.source, "time_s": float(times[i])},
                                hint="use smaller time steps")
        jac = constraint_jacobian(system, e[None, 2::3])[0]
        velocity_rhs = np.concatenate([np.zeros(2 * n_joints), motion.omega[i]])
        edot = _lstsq(jac, velocity_rhs, square)
        omega = edot[2::3]
        quad = system.points @ (omega**2 * np.exp(1j * e[2::3]))
        accel_rhs = np.concatenate([np.stack([quad.real, quad.imag], axis=-1).ravel(),
                                    motion.alpha[i]])
        eddot = _lstsq(jac, accel_rhs, square)
        force, moment = applied_forces(mech, (eddot[0::3] + 1j * eddot[1::3])[None],
                                       eddot[2::3][None])
        rhs = np.stack([force[0].real, force[0].imag, moment[0]], axis=-1).ravel()
        lam[i] = _lstsq(jac.T, rhs, square)
        coords[i], speeds[i], accels[i] = e, edot, eddot
    solution = Solution(
        times=times, theta=coords[:, 2::3], position=coords[:, 0::3] + 1j * coords[:, 1::3],
        omega=speeds[:, 2::3], velocity=speeds[:, 0::3] + 1j * speeds[:, 1::3],
        alpha=accels[:, 2::3], acceleration=accels[:, 0::3] + 1j * accels[:, 1::3],
        joint=lam[:, 0:2 * n_joints:2] + 1j * lam[:, 1:2 * n_joints:2],
        driver=lam[:, 2 * n_joints:], omega_driven=motion.omega)
    return build_dataset(mech, solution, select(mech, OUTPUTS, None, None),
                         {"title": f"rigval model (step-by-step reference): {mech.name}",
                          "mechanism": mech.name, "newton_tol": tol})
