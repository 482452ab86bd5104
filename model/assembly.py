"""One configuration's assembly: the undriven body angles at given driven angles, by Newton.

The unknowns are the undriven body angles (positions follow linearly, see
:mod:`rigval.model.loops`). :func:`assemble` finds the configuration near the bodies' guesses:
Levenberg-Marquardt on the loop closures (robust to a guess far from the assembled
configuration), then Newton. :func:`newton` corrects many steps at once, :func:`taylor` gives the
second-order expansion a step is predicted from, and :func:`assembly_rank` and
:func:`check_constraint_count` tell whether a mechanism's constraints determine it. Following the
configuration through the time steps is :mod:`rigval.model.continuation`.

Newton stops when the angle update is below ``tol`` rad (plus the floating-point resolution of the
angle) and the loop gap below ``tol`` times the mechanism size: tolerances relative to the size of
the coordinates.
"""


from __future__ import annotations

import logging
import math
import warnings
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from rigval.acquisition.errors import NumericsWarning
from rigval.model.errors import AssemblyError, MechanismError
from rigval.model.linalg import BatchLU, row_max_abs
from rigval.model.loops import LoopSystem, loop_system

if TYPE_CHECKING:
    from rigval.model.mechanism_types import Mechanism

__all__ = [
    "COND_MAX",
    "GUESS_TOL",
    "Tolerances",
    "assemble",
    "assembly_rank",
    "check_constraint_count",
    "check_guesses",
    "closest_configuration",
    "condition_one",
    "driven_part",
    "full_angles",
    "involved_joints",
    "newton",
    "phasor",
    "rotate",
    "taylor",
]

logger = logging.getLogger(__name__)

_EPS = np.finfo(float).eps
#: Steps whose expansions are computed together (temporaries of a few MB, reused).
_BLOCK = 4096
#: Relative tolerances (x, cost, gradient) of the Levenberg-Marquardt start of an assembly.
_LM_TOL = 1e-10

#: Default stated accuracy of the body guess angles, rad (docs/mechanism.md, ``guess``). Branches
#: of the built-in mechanisms are at least 1.06 rad apart in some body angle, so guesses within
#: 0.5 rad select one branch unambiguously.
GUESS_TOL = 0.5

#: Largest ``cond(C_e)**2 * eps`` at which forces are still returned (see :data:`COND_MAX`).
FORCE_TRUST = 1e-5
#: Condition number of the column-equilibrated, reduced ``C_e`` past which the forces cannot be
#: trusted and a SingularityError is raised: ``sqrt(FORCE_TRUST / eps)``, about 2.1e5.
#:
#: Why ``cond**2 * eps``: near a toggle the undriven angles move ``cond`` times as far as the
#: driven ones, and the forces are inversely proportional to the distance from the toggle (itself
#: about ``1 / cond``). The driven angles are known only to rounding (``eps``, relative), so the
#: distance from the toggle, and with it every force, is uncertain by about ``cond**2 * eps``
#: relative: a property of the input, not of the solver, that no double-precision method avoids.
#: Measured on the four-bar driven into its toggle (tests/model/test_toggle_trust.py) the force
#: error is 100 to 5000 times ``cond**2 * eps`` (1e-3 to 7e-3 at condition 8.3e4, 0.07 to 0.15 at
#: 2.6e5, 1 to 2 at 8.3e5; docs/numerics.md), so the limit 1e-5 refuses before the error can
#: exceed about a percent, and always before no digit is left. (The computed condition saturates
#: near 2e7 to 3e7 at an exact toggle, so a limit like 1e10 never fires.)
COND_MAX = math.sqrt(FORCE_TRUST / _EPS)


@dataclass(frozen=True)
class Tolerances:
    """Numerical settings of the position solve.

    Attributes
    ----------
    tol : float
        Newton tolerance: angle updates in rad and loop gaps relative to the mechanism size.
    cond_warn : float
        Condition number of ``C_e`` (column-equilibrated, reduced) past which a NumericsWarning
        is issued.
    cond_max : float
        Condition number past which a SingularityError is raised (default :data:`COND_MAX`:
        forces would carry a relative error of about ``1e2 ... 5e3 * cond**2 * eps``).
    anchor_spacing : float
        Driven-angle travel between sequential anchors, rad.
    refine_spacings : tuple of float
        Driven-angle travel between the anchors of each batched layer, rad, coarse to fine;
        the remaining steps are predicted from the finest layer.
    interpolation_spacing : float
        Travel between the anchors of the finest layer, rad, when the drives' rates are given
        and interpolate the driven angles (quintic Hermite in time between the layer's steps,
        to 1e-10 rad, :mod:`rigval.model.continuation`): the steps between are then
        interpolated the same way, accurate to about the tolerance at this spacing, not
        extrapolated. Never finer than the last of
        ``refine_spacings``.
    max_iter : int
        Newton iterations per attempt.
    guess_tol : float
        Stated accuracy of the bodies' guess angles, rad: a body assembled farther than this from
        its guess (modulo whole turns) gets a NumericsWarning, since the assembly then cannot be
        the configuration the guesses describe (another branch, or a guess that is wrong).
    """

    tol: float = 1e-12
    cond_warn: float = 1e4
    cond_max: float = COND_MAX
    anchor_spacing: float = 3.0
    refine_spacings: tuple[float, ...] = (0.5, 0.02)
    interpolation_spacing: float = 0.08
    max_iter: int = 12
    guess_tol: float = GUESS_TOL


def full_angles(system: LoopSystem, theta_d: np.ndarray, theta_u: np.ndarray) -> np.ndarray:
    """Merge driven and undriven angles into body order.

    Parameters
    ----------
    system : LoopSystem
        Gives the driven and undriven body indices.
    theta_d, theta_u : numpy.ndarray
        (..., n_d) driven and (..., n_u) undriven angles, rad.

    Returns
    -------
    numpy.ndarray
        (..., n_bodies) body angles, rad.
    """
    n_bodies = system.loop_points.shape[1]
    theta = np.empty((*theta_d.shape[:-1], n_bodies))
    theta[..., system.driven] = theta_d
    theta[..., system.undriven] = theta_u
    return theta


def phasor(theta: np.ndarray) -> np.ndarray:
    """Return unit phasors ``exp(1j theta)`` (cos and sin beat the complex exponential)."""
    z = np.empty(theta.shape, dtype=complex)
    z.real = np.cos(theta)
    z.imag = np.sin(theta)
    return z


def rotate(z: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """``z * exp(1j angle)``; cos and sin by their series (exact to rounding) for small angles."""
    largest = float(np.max(np.abs(angle))) if angle.size else 0.0
    turn = np.empty((*angle.shape, 2))
    if largest <= 1e-8:  # the series round to 1 and the angle itself
        turn[..., 0] = 1.0
        turn[..., 1] = angle
    elif largest <= 1e-3:
        a2 = angle * angle
        turn[..., 0] = 1.0 - a2 * (0.5 - a2 / 24.0)
        turn[..., 1] = angle * (1.0 - a2 / 6.0 * (1.0 - a2 / 20.0))
    else:
        turn[..., 0] = np.cos(angle)
        turn[..., 1] = np.sin(angle)
    return z * turn.view(complex)[..., 0]


def driven_part(system: LoopSystem, z_d: np.ndarray) -> np.ndarray:
    """Part of the complex loop closures fixed by the driven angles, (n, n_loops), m."""
    return z_d @ system.loop_points[:, system.driven].T - system.loop_offset


def newton(system: LoopSystem, base: np.ndarray, theta_u: np.ndarray, tol: float,
           max_iter: int, row_order: np.ndarray | None = None
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Newton-Raphson on the loop closures for a batch of steps.

    A step is converged when its predicted error after the update is below ``tol`` (plus the
    angle's floating-point resolution): the update itself on the first iteration, and
    ``|s_k|^3 / |s_k-1|^2`` (quadratic convergence) once the updates are small.

    Parameters
    ----------
    system : LoopSystem
        Reduced constraints.
    base : numpy.ndarray
        (n, n_loops) complex loop-closure part of the driven angles (:func:`driven_part`), m.
    theta_u : numpy.ndarray
        (n, n_u) starting undriven angles, rad.
    tol : float
        Tolerance (see :class:`Tolerances`).
    max_iter : int
        Iterations at most.
    row_order : numpy.ndarray, optional
        Initial row order for :class:`~rigval.model.linalg.BatchLU`.

    Returns
    -------
    theta_u : numpy.ndarray
        (n, n_u) final angles, rad.
    z_u : numpy.ndarray
        (n, n_u) their unit phasors.
    converged : numpy.ndarray
        (n,) bool.
    gap : numpy.ndarray
        (n,) largest loop gap before the last update, m.
    """
    n = theta_u.shape[0]
    if n > _BLOCK:  # blocks of steps: each iteration's arrays stay in the processor's cache
        blocks = [newton(system, base[start:start + _BLOCK], theta_u[start:start + _BLOCK], tol,
                         max_iter, row_order) for start in range(0, n, _BLOCK)]
        theta, z, ok, gap = (np.concatenate(parts) for parts in zip(*blocks, strict=True))
        return theta, z, ok, gap
    w_u = system.loop_points[:, system.undriven]
    theta_out, z_out = theta_u.copy(), phasor(theta_u)
    converged = np.zeros(n, dtype=bool)
    gap = np.full(n, np.inf)
    rows = np.arange(n)
    theta_w, z_w, base_w = theta_out, z_out, base
    previous = np.full(n, np.inf)
    for _ in range(max_iter):
        phi = base_w + z_w @ w_u.T
        phi = np.concatenate([phi.real, phi.imag], axis=1)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            step = BatchLU(system.jacobian_stack(z_w), row_order).solve(phi)
        size = row_max_abs(step)
        finite = np.isfinite(size)
        step[~finite] = 0.0
        theta_w = theta_w - step
        z_w = rotate(z_w, -step)
        with np.errstate(divide="ignore", invalid="ignore"):
            predicted = np.where((size < 1e-4) & np.isfinite(previous), size**3 / previous**2,
                                 size)
        floor = 8 * _EPS * row_max_abs(theta_w)
        done = finite & (predicted <= tol + floor)
        leave = done | ~finite
        gap_w = row_max_abs(phi)
        if np.all(leave) or _ == max_iter - 1:
            theta_out[rows], z_out[rows], gap[rows] = theta_w, z_w, gap_w
            converged[rows[done]] = True
            break
        if np.any(leave):
            theta_out[rows[leave]], z_out[rows[leave]] = theta_w[leave], z_w[leave]
            gap[rows[leave]] = gap_w[leave]
            converged[rows[done]] = True
            keep = ~leave
            rows, theta_w, z_w, base_w = rows[keep], theta_w[keep], z_w[keep], base_w[keep]
            size = size[keep]
        previous = size
    return theta_out, z_out, converged, gap


@dataclass(frozen=True)
class Taylor:
    """Second-order expansion of the undriven angles in the driven angles at some configurations.

    ``theta_u(theta_d + d) = theta_u + T d + 1/2 sum_jk Q[:, j, k] d_j d_k``, with ``T`` stored as
    ``first`` (n, n_u, n_d) and ``Q`` as ``second`` (n, n_u, n_d * n_d).
    """

    theta_u: np.ndarray
    first: np.ndarray
    second: np.ndarray

    def predict(self, rows: np.ndarray, delta: np.ndarray) -> np.ndarray:
        """Predicted undriven angles at driven-angle increments ``delta`` from anchors ``rows``."""
        n_d = delta.shape[1]
        guess = self.theta_u[rows]
        # elementwise over the few driven angles, gathering one coefficient at a time: faster
        # than stacks of tiny matrix products; Q is symmetric (its columns j k and k j are
        # solved from identical right-hand sides), so each pair j < k is added once, whole
        for j in range(n_d):
            dj = delta[:, j, None]
            guess += self.first[rows, :, j] * dj
            guess += self.second[rows, :, j * n_d + j] * (0.5 * dj * dj)
            for k in range(j + 1, n_d):
                guess += self.second[rows, :, j * n_d + k] * (dj * delta[:, k, None])
        return guess


def taylor(system: LoopSystem, theta_d: np.ndarray, theta_u: np.ndarray,
           row_order: np.ndarray | None = None) -> Taylor:
    """Second-order Taylor coefficients of the undriven in the driven angles (batched).

    Differentiating ``Phi(theta) = 0`` once gives ``J_u T = -J_d``; twice, with the diagonal
    loop Hessian, ``J_u Q_jk = -sum_m (d2 Phi / d theta_m2) v_mj v_mk`` with ``v`` the first
    derivatives of all angles (``T`` for the undriven, the identity for the driven).

    Parameters
    ----------
    system : LoopSystem
        Reduced constraints.
    theta_d, theta_u : numpy.ndarray
        (n, n_d) and (n, n_u) assembled angles, rad.
    row_order : numpy.ndarray, optional
        Initial row order for :class:`~rigval.model.linalg.BatchLU` (the static pivot order:
        far fewer matrices need row swaps than in the given order).

    Returns
    -------
    Taylor
        Coefficients in rad/rad and rad/rad2.
    """
    n, n_u, n_d = theta_u.shape[0], theta_u.shape[1], system.driven.size
    first = np.empty((n, n_u, n_d))
    second = np.empty((n, n_u, n_d * n_d))
    # blocks of steps: the temporaries stay small and are reused instead of fresh memory
    for start in range(0, n, _BLOCK):
        part = slice(start, min(start + _BLOCK, n))
        first[part], second[part] = _taylor_block(system, theta_d[part], theta_u[part],
                                                  row_order)
    return Taylor(theta_u, first, second)


def _taylor_block(system: LoopSystem, theta_d: np.ndarray, theta_u: np.ndarray,
                  row_order: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """:func:`taylor`'s first and second derivatives for one block of steps."""
    z = phasor(full_angles(system, theta_d, theta_u))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        lu = BatchLU(system.jacobian_stack(z[:, system.undriven]), row_order)
        first = -lu.solve(system.jacobian(z, system.driven))
        # sum_m (d2 Phi / d theta_m2) v_mj v_mk with d2 Phi / d theta_m2 = -W_m z_m and v the
        # first derivatives (T for the undriven angles, the identity for the driven ones): one
        # (n_loops, n_u) x (n_u, n) product per pair j <= k, batch last as the solve wants it
        n_d, n_loops = system.driven.size, system.loop_points.shape[0]
        w_u = system.loop_points[:, system.undriven]
        z_t = np.ascontiguousarray(z.T)
        z_u, first_t = z_t[system.undriven], np.moveaxis(first, 0, -1)
        bend = np.empty((2 * n_loops, n_d * n_d, z.shape[0]))
        for j in range(n_d):
            for k in range(j, n_d):
                block = w_u @ (z_u * (first_t[:, j] * first_t[:, k]))
                if j == k:
                    block += np.multiply.outer(system.loop_points[:, system.driven[j]],
                                               z_t[system.driven[j]])
                np.negative(block.real, out=bend[:n_loops, j * n_d + k])
                np.negative(block.imag, out=bend[n_loops:, j * n_d + k])
                bend[:, k * n_d + j] = bend[:, j * n_d + k]
        second = -lu.solve(np.moveaxis(bend, -1, 0))
    return first, second


def joint_gaps_text(mechanism: Mechanism, gaps: np.ndarray, threshold: float) -> tuple[list[str],
                                                                                        str]:
    """Names of joints whose gap exceeds ``threshold`` (largest first) and a readable summary."""
    order = np.argsort(-gaps)
    names = [mechanism.joints[k].name for k in order if gaps[k] > threshold]
    text = ", ".join(f"{mechanism.joints[k].name} {gaps[k]:.3g} m" for k in order
                     if gaps[k] > threshold)
    return names, text


def involved_joints(mechanism: Mechanism, system: LoopSystem, theta: np.ndarray) -> list[str]:
    """Joints carrying the self-stress of a near-singular configuration (largest first).

    The left singular vector of the smallest singular value of ``J_u`` is a loop-force mode that
    the undriven angles cannot resist; mapped to the joints (``N^T u``) it names the joints whose
    forces grow without bound.

    Parameters
    ----------
    mechanism, system
        The mechanism and its reduced constraints.
    theta : numpy.ndarray
        (n_bodies,) body angles of the configuration, rad.

    Returns
    -------
    list of str
        Joint names with at least 5 % of the largest share of the mode.
    """
    z = phasor(theta)
    jac = system.jacobian(z, system.undriven)
    if jac.shape[-1] == 0:
        return []
    u = np.linalg.svd(jac)[0][:, -1]
    n_loops = system.loop_points.shape[0]
    mode = np.abs((u[:n_loops] + 1j * u[n_loops:]) @ system.loop_basis)
    order = np.argsort(-mode)
    return [mechanism.joints[k].name for k in order if mode[k] > 0.05 * mode.max()]


def closest_configuration(system: LoopSystem, theta_d: np.ndarray, theta_u: np.ndarray
                          ) -> np.ndarray:
    """Undriven angles minimising the loop gaps (scipy's MINPACK Levenberg-Marquardt).

    Converges from far guesses; where the loops cannot close it stops at the smallest gaps. It
    only has to bring the angles into the quadratic range of :func:`newton`, which polishes them
    to the tolerance: the relative tolerances 1e-10 stop it there (the gaps left before Newton
    were below 3e-15 m on the built-in mechanisms from guesses 2 rad off).

    Parameters
    ----------
    system : LoopSystem
        Reduced constraints.
    theta_d : numpy.ndarray
        (n_d,) driven angles, rad.
    theta_u : numpy.ndarray
        (n_u,) starting guess, rad.

    Returns
    -------
    numpy.ndarray
        (n_u,) undriven angles, rad.
    """
    from scipy.optimize import least_squares  # imported here: scipy only when assembling

    def gaps(angles: np.ndarray) -> np.ndarray:
        return system.residual(phasor(full_angles(system, theta_d, angles)))

    def jacobian(angles: np.ndarray) -> np.ndarray:
        return system.jacobian(phasor(full_angles(system, theta_d, angles)), system.undriven)

    # A mechanism reaches assembly only with at least as many loop equations as undriven angles
    # (check_constraint_count), which MINPACK's method needs.
    return least_squares(gaps, theta_u, jac=jacobian, method="lm", xtol=_LM_TOL, ftol=_LM_TOL,
                         gtol=_LM_TOL).x


def assemble(mechanism: Mechanism, system: LoopSystem, theta_d: np.ndarray, guess_u: np.ndarray,
             tol: float, time_s: float | None = None) -> np.ndarray:
    """Assemble one configuration from a guess (Levenberg-Marquardt, then Newton).

    Parameters
    ----------
    mechanism, system
        The mechanism and its reduced constraints.
    theta_d : numpy.ndarray
        (n_d,) driven angles, rad.
    guess_u : numpy.ndarray
        (n_u,) guess of the undriven angles, rad.
    tol : float
        Newton tolerance.
    time_s : float, optional
        Time of this configuration, for error messages.

    Returns
    -------
    numpy.ndarray
        (n_u,) assembled undriven angles, rad.

    Raises
    ------
    AssemblyError
        Naming the joints whose gaps stay large.
    """
    theta_u = np.asarray(guess_u, dtype=float).copy()
    if theta_u.size == 0:
        return theta_u
    theta_u = closest_configuration(system, theta_d, theta_u)
    base = driven_part(system, phasor(theta_d)[None])
    polished, _z, ok, _gap = newton(system, base, theta_u[None], tol, 8)
    if ok[0]:
        return polished[0]
    gaps = system.joint_residuals(phasor(full_angles(system, theta_d, theta_u)))
    names, text = joint_gaps_text(mechanism, gaps, 1e3 * tol * system.length_scale)
    raise AssemblyError(
        f"the mechanism cannot be assembled: joints stay open ({text or 'none'})",
        where={"file": mechanism.source, "time_s": time_s, "joints": names},
        hint="check the joint points and ground positions (link lengths that cannot close the "
             "loop), the drive angles, and the bodies' guess angles", joints=names,
        residual_m=float(np.max(gaps)))




def condition_one(jacobian: np.ndarray) -> float:
    """Condition number of one ``J_u`` as :meth:`BatchLU.condition` defines it.

    Parameters
    ----------
    jacobian : numpy.ndarray
        (n_equations, n_u) loop Jacobian, m.

    Returns
    -------
    float
        Condition number of the column-equilibrated matrix (1-norm; 2-norm when tall).
    """
    if jacobian.shape[-1] == 0:
        return 1.0
    scaled = jacobian / np.sum(np.abs(jacobian), axis=0)
    if scaled.shape[0] != scaled.shape[1]:
        return float(np.linalg.cond(scaled / np.linalg.norm(scaled, axis=0)))
    return float(np.linalg.cond(scaled, 1))




def check_guesses(mechanism: Mechanism, system: LoopSystem, guess_u: np.ndarray,
                   assembled_u: np.ndarray, guess_tol: float) -> None:
    """Warn when bodies assembled farther from their guess angles than ``guess_tol`` (rad)."""
    offset = np.remainder(assembled_u - guess_u + np.pi, 2 * np.pi) - np.pi
    far = np.flatnonzero(np.abs(offset) > guess_tol)
    if far.size == 0:
        return
    bodies = [mechanism.bodies[system.undriven[k]].name for k in far]
    detail = ", ".join(f"{mechanism.bodies[system.undriven[k]].name} guessed "
                       f"{guess_u[k]:.4g} rad, assembled {guess_u[k] + offset[k]:.4g} rad"
                       for k in far)
    logger.info("assembly far from the guesses: %s", detail)
    warnings.warn(
        f"{mechanism.name}: at t = 0 of the drive laws the mechanism assembled farther than "
        f"{guess_tol:g} rad from the guess angles of {len(bodies)} bodies ({detail}): probably "
        f"another assembly branch (mirror image) than the guesses describe. Fix: set the guess "
        f"angles of {', '.join(bodies)} in {mechanism.source} to the machine's configuration at "
        "t = 0, or pass a larger guess_tol if they are known to be rough",
        NumericsWarning, stacklevel=4)




def assembly_rank(mechanism: Mechanism) -> tuple[int, int]:
    """Rank of the loop Jacobian at the mechanism assembled at t = 0, and the undriven count.

    Raises
    ------
    MechanismError
        When the mechanism cannot be assembled at t = 0.
    """
    system = loop_system(mechanism)
    theta_d = np.array([d.motion(np.zeros(1))[0][0] for d in mechanism.drivers])
    guess = np.array([mechanism.bodies[i].guess[2] for i in system.undriven])
    try:
        theta_u = assemble(mechanism, system, theta_d, guess, 1e-12, 0.0)
    except AssemblyError as exc:
        raise MechanismError(
            f"too many constraints ({2 * len(mechanism.joints) + len(mechanism.drivers)} "
            f"equations for {3 * len(mechanism.bodies)} coordinates) and the mechanism cannot "
            f"be assembled at t = 0 to check whether they are redundant: {exc.message}",
            where={"file": mechanism.source, "key": "drivers"},
            hint="remove surplus drivers or joints, or fix the guesses") from exc
    z = phasor(full_angles(system, theta_d, theta_u))
    jac = system.jacobian(z, system.undriven)
    if jac.shape[-1] == 0:
        return 0, 0
    sv = np.linalg.svd(jac, compute_uv=False)
    rank = int(np.sum(sv > 1e-9 * sv[0]))
    return rank, system.undriven.size


def check_constraint_count(mechanism: Mechanism) -> Mechanism:
    """Check that joints and drivers determine every coordinate, and detect redundancy.

    ``2 n_joints + n_drivers`` equations must match ``3 n_bodies`` coordinates. Fewer is always an
    error (degrees of freedom without a driver). More is accepted only when the surplus equations
    are redundant but consistent (for example a parallelogram with a parallel link): the mechanism
    is assembled at t = 0 and the rank of the loop Jacobian must equal the number of undriven
    angles; the surplus is recorded in ``Mechanism.redundant_constraints``.

    Parameters
    ----------
    mechanism : Mechanism
        Parsed mechanism.

    Returns
    -------
    Mechanism
        The same mechanism, with ``redundant_constraints`` set.

    Raises
    ------
    MechanismError
        When the count does not match and the surplus is not redundancy.
    """
    n_eq = 2 * len(mechanism.joints) + len(mechanism.drivers)
    n_coord = 3 * len(mechanism.bodies)
    where = {"file": mechanism.source, "key": "drivers"}
    if n_eq < n_coord:
        raise MechanismError(
            f"too few constraints: {len(mechanism.joints)} joints (2 equations each) and "
            f"{len(mechanism.drivers)} drivers give {n_eq} equations for {n_coord} coordinates "
            f"({len(mechanism.bodies)} bodies x 3)", where=where,
            hint=f"add {n_coord - n_eq} [[drivers]] (one per degree of freedom) or the missing "
                 "joints")
    if n_eq == n_coord:
        return mechanism
    rank, n_unknown = assembly_rank(mechanism)
    surplus = n_eq - n_coord
    if rank < n_unknown:
        raise MechanismError(
            f"too many constraints: {n_eq} equations for {n_coord} coordinates, and they are "
            f"not redundant at t = 0 (loop Jacobian rank {rank} < {n_unknown} undriven angles)",
            where=where, hint=f"remove {surplus} driver(s) or joint(s)")
    logger.info("%s: %d redundant constraint equations", mechanism.name, surplus)
    return replace(mechanism, redundant_constraints=surplus)


