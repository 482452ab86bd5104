"""Inverse dynamics as a linear function of the inertial parameters (the identification regressor).

With each body's frame at its nominal centre of gravity, the equations of motion of body ``b`` in
the coordinates of its frame origin ``O`` (x, y, theta) are linear in four inertial parameters:

``mass`` m, the first moments ``mx = m x_c`` and ``my = m y_c`` (the centre of gravity at
``(x_c, y_c)`` in the body frame; 0 nominally) and ``inertia`` ``I_O`` about the frame origin (the
mechanism file's inertia nominally). The right-hand side ``Q_e - M e''`` of the multiplier
equations is, with ``r = e^(i theta) (mx + i my)`` and ``a_O`` the origin's acceleration::

    force  = m (g - a_O) - (i alpha - omega^2) r
    moment = Im(conj(r) (g - a_O)) - I_O alpha

so every joint force and drive torque is ``Y(t) p`` with one regressor column per parameter: the
multipliers of ``C_e^T lambda = rhs_p`` for the right-hand side of that parameter alone. The
kinematics come from :func:`rigval.model.solve`; ``C_e`` from the same constraint Jacobian the
reference solver uses. With the nominal parameters ``Y p`` reproduces :func:`rigval.model.solve`'s
``joint_force`` and ``driver_torque`` (a test checks it to 1e-9 of their range).
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from rigval.acquisition.errors import ConfigError
from rigval.model.loops import loop_system
from rigval.model.mechanism import Mechanism, load_mechanism
from rigval.model.reference import constraint_jacobian
from rigval.model.solver import solve

__all__ = ["KINDS", "Regressor", "nominal_parameters", "parameter_names", "path_regressors",
           "regressor"]

logger = logging.getLogger(__name__)

KINDS: tuple[str, ...] = ("mass", "mx", "my", "inertia")
"""Inertial parameters per body: kg, kg m, kg m, kg m2 (inertia about the body frame origin)."""

UNITS: Mapping[str, str] = {"mass": "kg", "mx": "kg m", "my": "kg m", "inertia": "kg m2"}


@dataclass(frozen=True)
class Regressor:
    """Joint forces and drive torques as linear functions of the inertial parameters.

    Attributes
    ----------
    names : tuple of str
        Parameter names ``"<body>.<kind>"``, one per column.
    outputs : tuple of tuple
        The rows' outputs: ``("driver_torque", driver)`` or ``("joint_force", joint, axis)``.
    matrix : numpy.ndarray
        ``(n_outputs, n_samples, n_parameters)``: output = ``matrix @ p`` (N m or N).
    omega : dict of str to numpy.ndarray
        Each driven body's angular velocity per sample, rad/s (for drive friction).
    """

    names: tuple[str, ...]
    outputs: tuple[tuple[str, ...], ...]
    matrix: np.ndarray
    omega: dict[str, np.ndarray]


def parameter_names(mechanism: Mechanism) -> tuple[str, ...]:
    """Return every inertial parameter of a mechanism, ``"<body>.<kind>"`` in body order."""
    return tuple(f"{body.name}.{kind}" for body in mechanism.bodies for kind in KINDS)


def nominal_parameters(mechanism: Mechanism) -> dict[str, float]:
    """Return the mechanism file's inertial parameters (first moments 0: frames at the CG)."""
    values: dict[str, float] = {}
    for body in mechanism.bodies:
        values.update({f"{body.name}.mass": body.mass, f"{body.name}.mx": 0.0,
                       f"{body.name}.my": 0.0, f"{body.name}.inertia": body.inertia})
    return values


def regressor(mechanism: Mechanism | str | Path, t: np.ndarray, outputs: Sequence[Sequence[str]],
              *, drives: Mapping[str, tuple[np.ndarray, np.ndarray, np.ndarray]] | None = None
              ) -> Regressor:
    """Build the regressor of the requested joint forces and drive torques.

    Parameters
    ----------
    mechanism : Mechanism, str or pathlib.Path
        The mechanism (its geometry; its masses and inertias do not enter).
    t : numpy.ndarray
        (n,) times, s, as for :func:`rigval.model.solve`.
    outputs : sequence of sequence of str
        ``("driver_torque", driver)`` or ``("joint_force", joint, axis)`` with axis ``x`` or
        ``y`` (the force ON the joint's first body, the solver's convention).
    drives : mapping, optional
        Sampled drives, as for :func:`rigval.model.solve`.

    Returns
    -------
    Regressor
        ``matrix`` of shape ``(len(outputs), n, 4 n_bodies)``.

    Raises
    ------
    ConfigError
        For an unknown output, driver, joint or axis.
    """
    mech = mechanism if isinstance(mechanism, Mechanism) else load_mechanism(mechanism)
    rows = [_output_row(mech, tuple(output)) for output in outputs]
    ds = solve(mech, t, drives=drives, outputs=["position", "velocity", "acceleration"])
    theta, omega, alpha, _, acc = _kinematics(ds)
    lam = _multipliers(mech, theta, _rhs(mech, theta, omega, alpha, acc))
    return _regressor(mech, outputs, rows, lam, omega)


def path_regressors(mechanism: Mechanism, outputs: Sequence[Sequence[str]], phi: np.ndarray,
                    path: Mapping[str, tuple[np.ndarray, np.ndarray, np.ndarray]],
                    speeds: np.ndarray, accelerations: np.ndarray) -> list[Regressor]:
    """Regressors of one path of the drive angles travelled at several speeds, from one solve.

    Every driver follows a path in a parameter ``phi`` (the leading drive's angle): its angle
    ``theta_d(phi)``, ``kappa_d = d theta_d / d phi`` and ``bend_d = d2 theta_d / d phi2``; a
    pass ``r`` travels it at ``phi' = speeds[r]`` and ``phi'' = accelerations[r]``, so that
    ``omega_d = kappa_d phi'`` and ``alpha_d = bend_d phi'^2 + kappa_d phi''``. On one path the
    positions are those of ``phi`` alone, the velocities are ``phi' U`` and the accelerations
    ``phi'' U + phi'^2 W``, with ``U`` and ``W`` the velocities and accelerations of the pass at
    unit speed without acceleration (the velocity constraints are linear in the drive speeds,
    the acceleration constraints linear in the drive accelerations plus a quadratic form of the
    velocities). So one :func:`rigval.model.solve` of the unit pass and one solve of ``C_e^T``
    for all passes' right-hand sides give what :func:`regressor` gives pass by pass (to the
    Newton tolerance; ``tests/model/test_identify_paths.py`` compares the two).

    Parameters
    ----------
    mechanism : Mechanism
        The mechanism (its geometry).
    outputs : sequence of sequence of str
        As for :func:`regressor`.
    phi : numpy.ndarray
        ``(n,)`` the path parameter at the samples, rad, monotonic.
    path : mapping
        Driver name to ``(theta_d, kappa_d, bend_d)`` on the ``n`` samples (rad, 1, rad-1).
    speeds, accelerations : numpy.ndarray
        ``(n_pass, n)`` ``phi'`` (rad/s) and ``phi''`` (rad/s2) of each pass.

    Returns
    -------
    list of Regressor
        One per pass, as :func:`regressor` of that pass's sampled drives.
    """
    rows = [_output_row(mechanism, tuple(output)) for output in outputs]
    sign = 1.0 if float(np.mean(speeds)) >= 0.0 else -1.0
    unit = {name: (theta, kappa * sign, bend) for name, (theta, kappa, bend) in path.items()}
    ds = solve(mechanism, (phi - phi[0]) / sign, drives=unit,
               outputs=["position", "velocity", "acceleration"])
    theta, omega_u, alpha_u, velocity_u, acc_u = _kinematics(ds)
    rate = (speeds / sign)[:, :, np.newaxis]           # phi' / sign: velocities are rate * U
    gain = (accelerations / sign)[:, :, np.newaxis]
    square = (speeds**2)[:, :, np.newaxis]
    omega = rate * omega_u
    rhs = np.concatenate([_rhs(mechanism, theta, omega[r], gain[r] * omega_u + square[r] * alpha_u,
                               gain[r] * velocity_u + square[r] * acc_u)
                          for r in range(speeds.shape[0])], axis=2)
    lam = _multipliers(mechanism, theta, rhs)
    width = 4 * theta.shape[1]
    return [_regressor(mechanism, outputs, rows, lam[:, :, r * width:(r + 1) * width], omega[r])
            for r in range(speeds.shape[0])]


def _kinematics(ds: Any) -> tuple[np.ndarray, ...]:
    """Return theta, omega, alpha and the origins' complex velocity and acceleration.

    Each ``(n, n_bodies)``, from a :func:`rigval.model.solve` result with positions,
    velocities and accelerations.
    """

    def part(name: str, coord: str) -> np.ndarray:
        return ds[name].sel(coord=coord).to_numpy()

    return (part("position", "theta"), part("velocity", "theta"), part("acceleration", "theta"),
            part("velocity", "x") + 1j * part("velocity", "y"),
            part("acceleration", "x") + 1j * part("acceleration", "y"))


def _rhs(mech: Mechanism, theta: np.ndarray, omega: np.ndarray, alpha: np.ndarray,
         acc: np.ndarray) -> np.ndarray:
    """Right-hand side ``Q_e - M e''`` of each parameter alone, ``(n, 3 n_bodies, 4 n_bodies)``."""
    n, n_bodies = theta.shape
    gravity = complex(*mech.gravity)
    free = gravity - acc                                    # g - a_O, (n, n_bodies)
    rotor = np.exp(1j * theta)
    spin = 1j * alpha - omega**2
    rhs = np.zeros((n, 3 * n_bodies, 4 * n_bodies))
    for b in range(n_bodies):
        columns = {0: (free[:, b], np.zeros(n)),
                   1: (-spin[:, b] * rotor[:, b], np.imag(np.conj(rotor[:, b]) * free[:, b])),
                   2: (-spin[:, b] * 1j * rotor[:, b],
                       np.imag(np.conj(1j * rotor[:, b]) * free[:, b])),
                   3: (np.zeros(n, dtype=complex), -alpha[:, b])}
        for k, (force, moment) in columns.items():
            rhs[:, 3 * b, 4 * b + k] = force.real
            rhs[:, 3 * b + 1, 4 * b + k] = force.imag
            rhs[:, 3 * b + 2, 4 * b + k] = moment
    return rhs


def _multipliers(mech: Mechanism, theta: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Solve ``C_e^T lambda = rhs`` at every sample (minimum norm for redundant constraints)."""
    jac_t = np.swapaxes(constraint_jacobian(loop_system(mech), theta), -1, -2)
    if jac_t.shape[1] == jac_t.shape[2] and not mech.redundant_constraints:
        return np.linalg.solve(jac_t, rhs)
    return np.linalg.pinv(jac_t) @ rhs  # minimum-norm multipliers, as the solver returns


def _regressor(mech: Mechanism, outputs: Sequence[Sequence[str]], rows: list[int],
               lam: np.ndarray, omega: np.ndarray) -> Regressor:
    """Return the Regressor of the multipliers ``lam`` ``(n, n_constraints, 4 n_bodies)``."""
    matrix = np.stack([-lam[:, row, :] for row in rows])
    driven = {d.name: omega[:, [b.name for b in mech.bodies].index(d.body)]
              for d in mech.drivers}
    logger.debug("regressor: %d outputs x %d samples x %d parameters", *matrix.shape)
    return Regressor(parameter_names(mech), tuple(tuple(o) for o in outputs), matrix, driven)


def _output_row(mechanism: Mechanism, output: tuple[str, ...]) -> int:
    """Row of ``C_e`` (joint x, y rows, then drivers) whose multiplier gives the output."""
    joints, drivers = mechanism.joint_names, mechanism.driver_names
    if output and output[0] == "driver_torque" and len(output) == 2:
        if output[1] not in drivers:
            raise ConfigError(f"unknown driver {output[1]!r}", where={"key": "outputs"},
                              hint=f"drivers: {', '.join(drivers)}")
        return 2 * len(joints) + drivers.index(output[1])
    if output and output[0] == "joint_force" and len(output) == 3:
        if output[1] not in joints:
            raise ConfigError(f"unknown joint {output[1]!r}", where={"key": "outputs"},
                              hint=f"joints: {', '.join(joints)}")
        if output[2] not in ("x", "y"):
            raise ConfigError(f"unknown axis {output[2]!r}", where={"key": "outputs"},
                              hint="use x or y")
        return 2 * joints.index(output[1]) + ("x", "y").index(output[2])
    raise ConfigError(f"cannot identify from {output!r}", where={"key": "outputs"},
                      hint='use ("driver_torque", DRIVER) or ("joint_force", JOINT, AXIS)')
