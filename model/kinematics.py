"""Velocities and accelerations of the bodies and of named points (paper eqs. 8-12).

With the loop Jacobian ``J`` (see :mod:`rigval.model.loops`), the undriven angular velocities solve
``J_u w_u = -J_d w_d`` and the angular accelerations ``J_u a_u = -J_d a_d - sum_m H_m w_m^2``
(the Hessian of the loop closures is diagonal); the centre-of-gravity motion follows linearly from
``R = r0 - K z``: ``R' = -K (i w z)``, ``R'' = -K ((i a - w^2) z)``.
"""

from __future__ import annotations

import numpy as np

from rigval.model.linalg import BatchLU
from rigval.model.loops import LoopSystem

__all__ = ["angular_accelerations", "angular_velocities", "point_motion"]


def angular_velocities(system: LoopSystem, z: np.ndarray, lu: BatchLU,
                       omega_d: np.ndarray) -> np.ndarray:
    """Angular velocity of every body, (n, n_bodies), rad/s.

    Parameters
    ----------
    system : LoopSystem
        Reduced constraints.
    z : numpy.ndarray
        (n, n_bodies) unit phasors of the assembled body angles.
    lu : BatchLU
        Factors of ``J_u`` at these configurations.
    omega_d : numpy.ndarray
        (n, n_d) driven angular velocities, rad/s.
    """
    omega = np.zeros(z.shape)
    omega[:, system.driven] = omega_d
    if system.undriven.size:
        omega[:, system.undriven] = lu.solve(-system.rate(z, omega))
    return omega


def angular_accelerations(system: LoopSystem, z: np.ndarray, lu: BatchLU, omega: np.ndarray,
                          alpha_d: np.ndarray) -> np.ndarray:
    """Angular acceleration of every body, (n, n_bodies), rad/s2.

    Parameters
    ----------
    system, z, lu
        As for :func:`angular_velocities`.
    omega : numpy.ndarray
        (n, n_bodies) angular velocities, rad/s.
    alpha_d : numpy.ndarray
        (n, n_d) driven angular accelerations, rad/s2.
    """
    alpha = np.zeros(z.shape)
    alpha[:, system.driven] = alpha_d
    if system.undriven.size:
        # sum_m (d Phi / d theta_m) a_m + (d2 Phi / d theta_m2) w_m^2 with d Phi / d theta_m =
        # 1j W_m z_m and d2 Phi / d theta_m2 = -W_m z_m: one product for both sums
        rhs = ((1j * alpha - omega**2) * z) @ system.loop_points.T
        alpha[:, system.undriven] = lu.solve(-np.concatenate([rhs.real, rhs.imag], axis=-1))
    return alpha


def point_motion(local: np.ndarray, position: np.ndarray, z: np.ndarray,
                 velocity: np.ndarray | None = None, omega: np.ndarray | None = None,
                 acceleration: np.ndarray | None = None, alpha: np.ndarray | None = None
                 ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """Position, velocity and acceleration of body points, complex (n, n_points) (eqs. 10-12).

    Parameters
    ----------
    local : numpy.ndarray
        (n_points,) complex point vectors in their bodies' frames, m.
    position, z, velocity, omega, acceleration, alpha : numpy.ndarray
        The owning bodies' centre-of-gravity position (complex, m), unit phasor, velocity
        (complex, m/s), angular velocity (rad/s), acceleration (complex, m/s2) and angular
        acceleration (rad/s2), each (n, n_points). Velocity and acceleration are computed when
        their inputs are given.
    """
    arm = local * z
    r = position + arm
    v = None if velocity is None else velocity + 1j * omega * arm
    a = None if acceleration is None else acceleration + (1j * alpha - omega**2) * arm
    return r, v, a
