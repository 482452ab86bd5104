"""Inverse dynamics: Lagrange multipliers, joint forces, drive torques and energy (paper eq. 18).

``C_e^T lambda = Q_e - M e''``. The position rows ``D^T lambda_j = F_R`` are solved by
``lambda_j = (D^+)^T F_R + N^T mu`` (``N`` spans their null space); the undriven angle rows
then give
``J_u^T mu = F_theta,u - (S^T (D^+)^T F_R)_u``, the same ``J_u`` as for the kinematics, transposed;
the driven angle rows give the driver multipliers. Forces on bodies are ``-C_e^T lambda``: a joint
pushes its first body with ``-lambda_k``, a driver turns its body with ``-lambda_d``.

With redundant constraints the multipliers are not unique; the minimum-norm solution of the full
``C_e^T lambda = Q_e - M e''`` is returned (:func:`minimum_norm_multipliers`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from rigval.model.linalg import BatchLU
from rigval.model.loops import LoopSystem

if TYPE_CHECKING:
    from rigval.model.mechanism import Mechanism

__all__ = ["applied_forces", "mechanical_energy", "minimum_norm_multipliers", "multipliers"]


def applied_forces(mechanism: Mechanism, acceleration: np.ndarray, alpha: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Right-hand side ``Q_e - M e''`` of the multiplier equations (gravity only in ``Q_e``).

    Parameters
    ----------
    mechanism : Mechanism
        Masses, inertias and gravity.
    acceleration : numpy.ndarray
        (n, n_bodies) complex centre-of-gravity accelerations, m s-2.
    alpha : numpy.ndarray
        (n, n_bodies) angular accelerations, rad s-2.

    Returns
    -------
    force : numpy.ndarray
        (n, n_bodies) complex forces, N.
    moment : numpy.ndarray
        (n, n_bodies) moments, N m.
    """
    mass = np.array([b.mass for b in mechanism.bodies])
    inertia = np.array([b.inertia for b in mechanism.bodies])
    gravity = complex(*mechanism.gravity)
    return mass * (gravity - acceleration), -inertia * alpha


def multipliers(system: LoopSystem, z: np.ndarray, lu: BatchLU, force: np.ndarray,
                moment: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Joint and driver multipliers from ``C_e^T lambda = (force, moment)``.

    Parameters
    ----------
    system : LoopSystem
        Reduced constraints (square ``J_u``: no redundancy).
    z : numpy.ndarray
        (n, n_bodies) unit phasors of the body angles.
    lu : BatchLU
        Factors of ``J_u``.
    force, moment : numpy.ndarray
        (n, n_bodies) right-hand side: complex forces (N) and moments (N m).

    Returns
    -------
    joint : numpy.ndarray
        (n, n_joints) complex joint multipliers, N.
    driver : numpy.ndarray
        (n, n_drivers) driver multipliers, N m.
    """
    lam = force @ system.incidence_pinv
    conj_points = system.points.conj()
    # the moments of the joint multipliers on the bodies, only of the columns each stage reads
    if system.undriven.size:
        u = system.undriven
        held = np.imag(z[:, u].conj() * (lam @ conj_points[:, u]))
        mu = lu.solve_transposed(moment[:, u] - held)
        n_loops = system.loop_points.shape[0]
        lam = lam + (mu[:, :n_loops] + 1j * mu[:, n_loops:]) @ system.loop_basis
    d = system.driven
    held = np.imag(z[:, d].conj() * (lam @ conj_points[:, d]))
    driver = moment[:, d] - held
    return lam, driver


def minimum_norm_multipliers(jacobian: np.ndarray, force: np.ndarray, moment: np.ndarray,
                             n_joints: int) -> tuple[np.ndarray, np.ndarray]:
    """Minimum-norm multipliers of ``C_e^T lambda = (force, moment)`` for redundant constraints.

    Parameters
    ----------
    jacobian : numpy.ndarray
        (n, n_equations, 3 n_bodies) full constraint Jacobian ``C_e`` (joint rows x, y per joint,
        then one row per driver; columns x, y, theta per body).
    force, moment : numpy.ndarray
        (n, n_bodies) complex forces (N) and moments (N m).
    n_joints : int
        Number of joints (the first ``2 n_joints`` rows).

    Returns
    -------
    joint, driver : numpy.ndarray
        As :func:`multipliers` returns them: (n, n_joints) complex joint multipliers (N) and
        (n, n_drivers) driver multipliers (N m).
    """
    rhs = np.stack([force.real, force.imag, moment], axis=-1).reshape(force.shape[0], -1)
    lam = (np.linalg.pinv(np.swapaxes(jacobian, -1, -2)) @ rhs[..., None])[..., 0]
    joint = lam[:, 0:2 * n_joints:2] + 1j * lam[:, 1:2 * n_joints:2]
    return joint, lam[:, 2 * n_joints:]


def mechanical_energy(mechanism: Mechanism, position: np.ndarray, velocity: np.ndarray | None,
                      omega: np.ndarray | None) -> tuple[np.ndarray | None, np.ndarray]:
    """Kinetic and potential energy of the whole mechanism, each (n,), J.

    Parameters
    ----------
    mechanism : Mechanism
        Masses, inertias, gravity.
    position, velocity : numpy.ndarray
        (n, n_bodies) complex centre-of-gravity position (m) and velocity (m/s); velocity None
        when only the potential energy is wanted (the kinetic energy is then None).
    omega : numpy.ndarray or None
        (n, n_bodies) angular velocities, rad/s (None with ``velocity``).
    """
    mass = np.array([b.mass for b in mechanism.bodies])
    inertia = np.array([b.inertia for b in mechanism.bodies])
    gravity = complex(*mechanism.gravity)
    kinetic = None if velocity is None or omega is None else \
        0.5 * (np.abs(velocity) ** 2 @ mass + omega**2 @ inertia)
    potential = -(np.real(np.conj(gravity) * position) @ mass)
    return kinetic, potential
