"""Positions along the path: continuation from the assembly through every time step, batched.

The unknowns are the undriven body angles (positions follow linearly, see
:mod:`rigval.model.loops`). The path through the time steps is followed in four stages:

1. *Assembly* at t = 0 of the drive laws, where the bodies' guesses apply
   (:func:`rigval.model.assembly.assemble`), then continuation to the first time step along the
   shortest change of the driven angles.
2. *Anchors*, sequentially, every ``anchor_spacing`` rad of driven-angle travel (measured with
   each step's increments wrapped to (-pi, pi], so a jump of whole turns is no travel at all):
   second-order Taylor predictor in the driven angles, Newton corrector, step halving when the
   prediction's second-order term exceeds 0.75 times its first (beyond the series' range, where the
   prediction no longer tells the branches apart), when Newton fails, or when it lands farther
   from the prediction than the predicted move explains (another branch).
3. *Layers*, batched: steps every ``refine_spacings`` rad, each predicted from the nearest
   preceding solved step and corrected by Newton on a whole batch at once; steps beyond the
   series' range of their start wait for a later batch to come closer. When the drives' rates
   interpolate the driven angles (quintic Hermite in time, as drive laws do), the finest layer is
   ``interpolation_spacing`` apart instead.
4. *Finish*, batched over all steps: the rest interpolated in time between the two solved steps
   around them (with such rates: errors near the tolerance, so one iteration usually suffices)
   or else predicted from the finest layer, then Newton on every step at once (and on the few
   steps left) until the last update is below ``tol``; each step's last factorisation of ``J_u``
   is returned for the velocities, accelerations and multipliers.

Steps that fail a batched stage (no convergence, or a solution farther from its prediction than
the predicted move explains) are redone by sequential continuation. Newton stops when the angle
update is below ``tol`` rad (plus the floating-point resolution of the angle) and the loop gap
below ``tol`` times the mechanism size: tolerances relative to the size of the coordinates.
"""

from __future__ import annotations

import itertools
import logging
from typing import TYPE_CHECKING

import numpy as np

from rigval.model.assembly import (
    Tolerances,
    assemble,
    check_guesses,
    closest_configuration,
    condition_one,
    driven_part,
    full_angles,
    involved_joints,
    joint_gaps_text,
    newton,
    phasor,
    rotate,
    taylor,
)
from rigval.model.errors import AssemblyError, SingularityError
from rigval.model.linalg import BatchLU, row_max_abs, solve_one, static_row_order
from rigval.model.loops import LoopSystem

if TYPE_CHECKING:
    from rigval.model.mechanism_types import Mechanism

__all__ = ["Continuation", "track"]

logger = logging.getLogger(__name__)

_EPS = np.finfo(float).eps


#: Largest error of the quintic Hermite interpolation in time of the driven angles between the
#: finest layer's steps, rad, at which the undriven angles are interpolated the same way (rates
#: consistent with the angles, smooth in time); otherwise they are extrapolated from the earlier
#: solved step (:func:`track`).
_SMOOTH = 1e-10


#: Largest ratio of the second- to the first-order term of a continuation step's prediction:
#: longer steps are halved. On the pendulum and the four-bar (steps of 0.2 to 9 rad of crank from
#: 400 seeded starts each) Newton closed the loops on another branch from 3 rad on, at ratios of
#: 0.64 and more (1.4 and more where the corrector-distance test let it through); steps on the
#: right branch had ratios up to 0.85 at 1 rad. 0.5 cost the pendulum 14 % of solve's CPU time,
#: 0.75 9 %, 1.0 2 % (docs/numerics.md, case 3).
_SERIES_RATIO = 0.75


#: Largest first Newton update, rad, of a step converged by it whose factorisation of ``J_u`` (at
#: the angles before that update) serves the velocities, accelerations and forces; steps with
#: larger ones iterate once more, for factors at their solution (forces carry about the
#: condition times the update, relative).
_FRESH = 3e-13


def _unwrap_path(theta_d: np.ndarray) -> np.ndarray:
    """Driven angles along the continuation path: each step's increment wrapped to (-pi, pi]."""
    increments = np.diff(theta_d, axis=0)
    increments = increments - 2 * np.pi * np.round(increments / (2 * np.pi))
    path = np.empty_like(theta_d)
    path[0] = theta_d[0]
    path[1:] = theta_d[0] + np.cumsum(increments, axis=0)
    return path


def _travel(path: np.ndarray) -> np.ndarray:
    """Cumulative driven-angle travel along the path (largest driver increment per step), rad."""
    travel = np.zeros(path.shape[0])
    if path.shape[1] and path.shape[0] > 1:
        np.cumsum(row_max_abs(np.diff(path, axis=0)), out=travel[1:])
    return travel


def _anchor_indices(travel: np.ndarray, spacing: float) -> np.ndarray:
    """Return the steps where the travel since the last mark reaches ``spacing`` (and step 0)."""
    marks = np.floor(travel / spacing)
    picks = np.flatnonzero(marks[1:] != marks[:-1]) + 1
    return np.concatenate([[0], picks])



def _within_series_range(linear: np.ndarray, bend: np.ndarray) -> bool:
    """Whether a Taylor step stays well inside the branch's range of convergence.

    ``linear`` and ``bend`` are the first- and second-order terms of the predicted change of the
    undriven angles, rad. Their ratio estimates the step over the distance to the nearest branch
    point (a toggle, real or complex), where the branches meet: beyond it the prediction says
    nothing about the branch, and Newton from it can close the loops on another one however
    close it lands (docs/numerics.md, case 3).
    """
    return float(np.abs(bend).max(initial=0.0)) <= (
        _SERIES_RATIO * float(np.abs(linear).max(initial=0.0)) + 1e-6)


class _Tracker:
    """Sequential continuation of one mechanism's assembly along a path of driven angles."""

    def __init__(self, mechanism: Mechanism, system: LoopSystem, times: np.ndarray,
                 tolerances: Tolerances) -> None:
        self.mechanism = mechanism
        self.system = system
        self.times = times
        self.tols = tolerances
        self.square = system.n_equations == system.undriven.size
        self.w_u = system.loop_points[:, system.undriven]
        self.w_d = system.loop_points[:, system.driven]

    def _newton(self, theta_d: np.ndarray, theta_u: np.ndarray
                ) -> tuple[np.ndarray, bool, float, np.ndarray]:
        """Newton-Raphson for one configuration.

        Returns the angles, whether they converged, the last loop gap (m) and the last ``J_u``.
        """
        tol, scale = self.tols.tol, self.system.length_scale
        base = np.exp(1j * theta_d) @ self.w_d.T - self.system.loop_offset
        gap, jac = np.inf, np.zeros((self.system.n_equations, theta_u.size))
        gap_limit = max(tol, 64 * _EPS) * scale
        small, previous = False, np.inf
        for _ in range(self.tols.max_iter + 1):
            z = np.exp(1j * theta_u)
            phi = base + self.w_u @ z
            gap = float(np.abs(phi).max())  # the method: a third of np.max's overhead
            block = self.w_u * (1j * z)
            jac = np.concatenate([block.real, block.imag])
            # Converged: the error left after the last update (predicted from the quadratic
            # convergence, as in newton()) is below tol and the loops close here. Near a toggle
            # the angles are only defined to rounding times the condition: a gap at rounding
            # level is then the test.
            if (gap <= gap_limit and small) or gap <= 16 * _EPS * scale:
                return theta_u, True, gap, jac
            if _ == self.tols.max_iter:
                break
            rhs = np.concatenate([phi.real, phi.imag])
            try:
                step = solve_one(jac, rhs) if self.square else \
                    np.linalg.lstsq(jac, rhs, rcond=None)[0]
            except np.linalg.LinAlgError:
                return theta_u, False, gap, jac
            theta_u = theta_u - step
            size = float(np.abs(step).max())
            predicted = size**3 / previous**2 if size < 1e-4 and 0 < previous < np.inf else size
            small = predicted <= tol + 8 * _EPS * float(np.abs(theta_u).max())
            previous = size
        return theta_u, False, gap, jac

    def _expand(self, theta_d: np.ndarray, theta_u: np.ndarray, jac_u: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
        """First and second derivatives of the undriven in the driven angles at one point.

        ``jac_u`` is ``J_u`` at (or within the Newton tolerance of) the point.
        """
        z_d, z_u = np.exp(1j * theta_d), np.exp(1j * theta_u)
        inv = np.linalg.inv(jac_u) if self.square else np.linalg.pinv(jac_u)
        block = self.w_d * (1j * z_d)
        first = -inv @ np.concatenate([block.real, block.imag])
        n_u, n_d = first.shape
        bend_u = -self.w_u * z_u
        bend_d = -self.w_d * z_d
        pairs = (first[:, :, None] * first[:, None, :]).reshape(n_u, n_d * n_d)
        bend = bend_u @ pairs
        bend[:, :: n_d + 1] += bend_d
        bend = np.concatenate([bend.real, bend.imag])
        return first, -(inv @ bend).reshape(n_u, n_d, n_d)

    def step(self, theta_d0: np.ndarray, theta_u0: np.ndarray, path_delta: np.ndarray,
             theta_d1: np.ndarray, index: int) -> np.ndarray:
        """Follow the path from one assembled configuration to the next, halving on trouble."""
        fraction, size = 0.0, 1.0
        travel = float(np.abs(path_delta).max()) if path_delta.size else 0.0
        if travel > self.tols.anchor_spacing:
            size = self.tols.anchor_spacing / travel
        current_d, current_u = theta_d0, theta_u0
        z = phasor(full_angles(self.system, current_d, current_u))[None]
        expansion = self._expand(current_d, current_u,
                                 self.system.jacobian(z, self.system.undriven)[0])
        while fraction < 1.0:
            target = min(1.0, fraction + size)
            delta = (target - fraction) * path_delta
            goal_d = theta_d1 if target >= 1.0 else theta_d0 + target * path_delta
            first, second = expansion
            linear, bend = first @ delta, 0.5 * (second @ delta) @ delta
            # beyond the predictor's range the branch would be a guess: no Newton there
            if _within_series_range(linear, bend):
                guess = current_u + linear + bend
                found, ok, _gap, jac = self._newton(goal_d, guess)
                moved = float(np.abs(found - guess).max())
                expected = float(np.abs(guess - current_u).max())
                if ok and moved <= max(0.25 * max(travel * (target - fraction), expected), 1e-6):
                    fraction, current_d, current_u = target, goal_d, found
                    if fraction < 1.0:
                        expansion = self._expand(current_d, current_u, jac)
                    size = min(2 * size, 1.0)
                    continue
            size /= 2.0
            if size * travel < 1e-14 or size < 1e-12:
                self.fail(index, current_d, current_u, theta_d1)
        return current_u

    def fail(self, index: int, good_d: np.ndarray, good_u: np.ndarray,
             goal_d: np.ndarray) -> None:
        """Raise the error for a step the continuation cannot reach.

        The residual reported is the smallest loop gap reachable at the step's driven angles.
        """
        system, mechanism = self.system, self.mechanism
        good = full_angles(system, good_d, good_u)
        cond = condition_one(system.jacobian(phasor(good)[None], system.undriven)[0])
        time_s = float(self.times[index])
        closest = closest_configuration(system, goal_d, good_u)
        gaps = system.joint_residuals(phasor(full_angles(system, goal_d, closest)))
        residual = float(np.max(gaps))
        if cond > self.tols.cond_warn:
            joints = involved_joints(mechanism, system, good)
            raise SingularityError(
                f"C_e loses rank: the mechanism reaches a toggle or limit position before t = "
                f"{time_s:.9g} s (condition {cond:.3g}) and cannot follow the driven angles "
                f"beyond it; joints involved: {', '.join(joints)}; residual {residual:.3g} m",
                where={"file": mechanism.source, "time_s": time_s, "joints": joints},
                hint="keep the drives inside the mechanism's range of motion, or change the "
                     "geometry", joints=joints, residual_m=residual, condition=cond)
        names, text = joint_gaps_text(mechanism, gaps, 1e3 * self.tols.tol * system.length_scale)
        raise AssemblyError(
            f"the mechanism cannot follow the drives at t = {time_s:.9g} s: joints stay open "
            f"({text or 'none'})",
            where={"file": mechanism.source, "time_s": time_s, "joints": names},
            hint="check that the drive angles are reachable and continuous", joints=names,
            residual_m=residual)



def track(mechanism: Mechanism, system: LoopSystem, times: np.ndarray, theta_d: np.ndarray,
          tolerances: Tolerances, guess_u: np.ndarray | None = None,
          rates: tuple[np.ndarray, np.ndarray] | None = None) -> Continuation:
    """Follow the assembly branch of the guess through every step (all but the last polish).

    Parameters
    ----------
    mechanism, system
        The mechanism and its reduced constraints.
    times : numpy.ndarray
        (n,) times, s (for messages only).
    theta_d : numpy.ndarray
        (n, n_d) driven angles, rad.
    tolerances : Tolerances
        Numerical settings.
    guess_u : numpy.ndarray, optional
        Undriven angles near the configuration at t = 0 of the file's drive laws (default: the
        bodies' guesses). The mechanism is assembled there and followed to the first step along
        the shortest change of the driven angles.
    rates : tuple of numpy.ndarray, optional
        (n, n_d) driven angular velocities (rad/s) and accelerations (rad/s2) at ``times``: the
        steps between solved ones are then interpolated in time, not extrapolated, where the
        driven angles agree (:meth:`Continuation._predict`).

    Returns
    -------
    Continuation
        Anchors and layers solved, the other steps predicted; :meth:`Continuation.polish`
        finishes a chunk of steps and returns its factorisation of ``J_u``.
    """
    n = theta_d.shape[0]
    if guess_u is None:
        guess_u = np.array([mechanism.bodies[i].guess[2] for i in system.undriven])
    theta_u = np.empty((n, system.undriven.size))
    tracker = _Tracker(mechanism, system, times, tolerances)
    if n == 0 or system.undriven.size == 0:
        return Continuation(tracker, _unwrap_path(theta_d), theta_d, theta_u,
                            np.ones(n, dtype=bool), None)
    # The guesses describe the mechanism at t = 0 of the drive laws: assemble there, then follow
    # the shortest change of the driven angles (modulo whole turns) to the first step.
    start_d = np.array([d.motion(np.zeros(1))[0][0] for d in mechanism.drivers])
    start_u = assemble(mechanism, system, start_d, guess_u, tolerances.tol, 0.0)
    check_guesses(mechanism, system, guess_u, start_u, tolerances.guess_tol)
    turn = theta_d[0] - start_d
    turn -= 2 * np.pi * np.round(turn / (2 * np.pi))
    theta_u[0] = tracker.step(start_d, start_u, turn, theta_d[0], 0)
    if theta_d.shape[1] == 0:  # no drivers: a structure, the same configuration at every step
        theta_u[1:] = theta_u[0]
        return Continuation(tracker, theta_d, theta_d, theta_u, np.ones(n, dtype=bool), None)
    row_order = None
    if tracker.square:
        z0 = phasor(full_angles(system, theta_d[0], theta_u[0]))[None]
        row_order = static_row_order(system.jacobian(z0, system.undriven)[0])
    path = _unwrap_path(theta_d)
    travel = _travel(path)
    anchors = _anchor_indices(travel, tolerances.anchor_spacing)
    for prev, nxt in itertools.pairwise(anchors):
        theta_u[nxt] = tracker.step(theta_d[prev], theta_u[prev], path[nxt] - path[prev],
                                    theta_d[nxt], int(nxt))
    solved = np.zeros(n, dtype=bool)
    solved[anchors] = True
    spacings = tolerances.refine_spacings
    if rates is not None and spacings:
        finest = max(spacings[-1], tolerances.interpolation_spacing)
        if _rates_interpolate(times, path, rates, _anchor_indices(travel, finest)):
            spacings = (*spacings[:-1], finest)
        else:  # rates inconsistent with the angles (measured drives): extrapolate
            rates = None
    for spacing in spacings:
        targets = _anchor_indices(travel, spacing)
        targets = targets[~solved[targets]]
        if targets.size:
            _refine(tracker, path, theta_d, theta_u, solved, targets, row_order)
    return Continuation(tracker, path, theta_d, theta_u, solved, row_order, rates)


def _predict(system: LoopSystem, path: np.ndarray, theta_d: np.ndarray, theta_u: np.ndarray,
             known: np.ndarray, targets: np.ndarray, row_order: np.ndarray | None = None
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Second-order predictions of ``targets`` from the nearest preceding solved step.

    Returns the guesses, the base steps they were predicted from, the driven increments, and
    whether each prediction is within the series range (:func:`_within_series_range`).
    """
    rows = np.searchsorted(known, targets, side="right") - 1
    base = known[rows]
    used, local = np.unique(rows, return_inverse=True)
    expansion = taylor(system, theta_d[known[used]], theta_u[known[used]], row_order)
    delta = path[targets] - path[base]
    linear = np.einsum("nij,nj->ni", expansion.first[local], delta)
    pairs = (delta[:, :, None] * delta[:, None, :]).reshape(delta.shape[0], -1)
    bend = 0.5 * np.einsum("nik,nk->ni", expansion.second[local], pairs)
    near = row_max_abs(bend) <= _SERIES_RATIO * row_max_abs(linear) + 1e-6
    return theta_u[base] + linear + bend, base, delta, near


def _plausible(found: np.ndarray, guess: np.ndarray, start: np.ndarray, delta: np.ndarray
               ) -> np.ndarray:
    """Solutions no farther from their prediction than the predicted move explains (branch)."""
    moved = row_max_abs(found - guess)
    expected = row_max_abs(guess - start)
    return moved <= np.maximum(0.25 * np.maximum(row_max_abs(delta), expected), 1e-6)


def _quintic(h: np.ndarray, start: tuple[np.ndarray, ...], end: tuple[np.ndarray, ...]
             ) -> np.ndarray:
    """Quintic Hermite polynomials on intervals, in powers of the fraction ``u`` of each.

    ``h`` (m,) are the intervals' lengths; ``start`` and ``end`` the values and their first and
    second derivatives at the intervals' ends, (m, k) each. Returns the coefficients
    (m, 6, k) of ``u**0 ... u**5`` (evaluate with :func:`_horner`).
    """
    h = h[:, None]
    step = end[0] - start[0]
    d0, d1 = h * start[1], h * end[1]
    a0, a1 = (h * h) * start[2], (h * h) * end[2]
    coef = np.empty((step.shape[0], 6, step.shape[1]))
    coef[:, 0] = start[0]
    coef[:, 1] = d0
    coef[:, 2] = 0.5 * a0
    coef[:, 3] = 10.0 * step - 6.0 * d0 - 4.0 * d1 - 1.5 * a0 + 0.5 * a1
    coef[:, 4] = -15.0 * step + 8.0 * d0 + 7.0 * d1 + 1.5 * a0 - a1
    coef[:, 5] = 6.0 * step - 3.0 * (d0 + d1) - 0.5 * (a0 - a1)
    return coef


def _horner(coef: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Evaluate polynomials (n, degree + 1, k) in ascending powers at ``u`` (n,), (n, k)."""
    u = u[:, None]
    value = coef[:, -1] * u
    for power in range(coef.shape[1] - 2, 0, -1):
        value += coef[:, power]
        value *= u
    value += coef[:, 0]
    return value


def _sixth_order(times: np.ndarray, coef: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Add the sixth-order term to quintic Hermite polynomials between points, estimated.

    The quintic's error is about ``c u**3 (u - 1)**3`` on each interval; ``c`` is estimated from
    its misses at the neighbouring points (``values`` (m, k) at ``times`` (m,), the mean of both
    sides where both exist). Returns the coefficients (m - 1, 7, k) of ``u**0 ... u**6``.
    """
    h = np.diff(times)
    term = np.zeros((coef.shape[0], coef.shape[2]))
    count = np.zeros(coef.shape[0])
    if times.size > 2:
        ahead = (times[2:] - times[:-2]) / h[:-1]  # the next point, in fractions of interval i
        term[:-1] += (values[2:] - _horner(coef[:-1], ahead)) / (ahead**3 * (ahead - 1)**3)[:, None]
        behind = (times[:-2] - times[1:-1]) / h[1:]  # the previous point, for interval i + 1
        term[1:] += (values[:-2] - _horner(coef[1:], behind)) / (
            behind**3 * (behind - 1)**3)[:, None]
        count[:-1] += 1
        count[1:] += 1
    term /= np.maximum(count, 1)[:, None]
    out = np.empty((coef.shape[0], 7, coef.shape[2]))
    out[:, :6] = coef
    out[:, 3] -= term  # u**3 (u - 1)**3 = u**6 - 3 u**5 + 3 u**4 - u**3
    out[:, 4] += 3.0 * term
    out[:, 5] -= 3.0 * term
    out[:, 6] = term
    return out


def _rates_interpolate(times: np.ndarray, path: np.ndarray, rates: tuple[np.ndarray, np.ndarray],
                       knots: np.ndarray) -> bool:
    """Whether the drives' rates interpolate the driven angles between ``knots`` (steps).

    Quintic Hermite polynomials in time between consecutive knots, from the angles, velocities
    and accelerations there, must reproduce the driven angles to :data:`_SMOOTH` at the step
    nearest the middle of every interval (where such errors peak): rates consistent with the
    angles and motion smooth at the knots' spacing, as drive laws give.
    """
    middle = (knots[:-1] + knots[1:]) // 2
    inside = np.flatnonzero(middle > knots[:-1])
    if not inside.size:
        return False
    first, last, middle = knots[inside], knots[inside + 1], middle[inside]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        h = times[last] - times[first]
        coef = _quintic(h, (path[first], *(r[first] for r in rates)),
                        (path[last], *(r[last] for r in rates)))
        error = row_max_abs(_horner(coef, (times[middle] - times[first]) / h) - path[middle])
    return bool(np.all(error <= _SMOOTH))


def _refine(tracker: _Tracker, path: np.ndarray, theta_d: np.ndarray, theta_u: np.ndarray,
            solved: np.ndarray, targets: np.ndarray, row_order: np.ndarray | None) -> None:
    """Solve ``targets`` from the nearest preceding solved step, in place, and mark them solved.

    Batches of the targets within the series range of their start (Newton on each batch at
    once), each batch starting from the previous ones; the rest by sequential continuation.
    """
    system, tols = tracker.system, tracker.tols
    pending = targets
    while pending.size:
        guess, base, delta, near = _predict(system, path, theta_d, theta_u,
                                            np.flatnonzero(solved), pending, row_order)
        if not np.any(near):  # steps longer than the series range: sequential halving
            _sequential(tracker, path, theta_d, theta_u, pending, base)
            solved[pending] = True
            return
        batch = pending[near]
        found, _z, ok, _gap = newton(system, driven_part(system, phasor(theta_d[batch])),
                                     guess[near], tols.tol, tols.max_iter, row_order)
        good = ok & _plausible(found, guess[near], theta_u[base[near]], delta[near])
        theta_u[batch[good]] = found[good]
        _sequential(tracker, path, theta_d, theta_u, batch[~good], base[near][~good])
        solved[batch] = True
        pending = pending[~near]


def _sequential(tracker: _Tracker, path: np.ndarray, theta_d: np.ndarray, theta_u: np.ndarray,
                targets: np.ndarray, starts: np.ndarray) -> None:
    """Solve ``targets`` one by one by continuation from the steps ``starts`` (in place)."""
    for target, start in zip(targets, starts, strict=True):
        theta_u[target] = tracker.step(theta_d[start], theta_u[start],
                                       path[target] - path[start], theta_d[target], int(target))


class Continuation:
    """Every step's undriven angles, solved (anchors and layers) or predicted, ready to polish.

    :meth:`polish` runs the last Newton iterations on a chunk of steps and returns the chunk's
    angles with the factorisation of ``J_u`` of its last iteration, so that velocities,
    accelerations and multipliers are computed chunk by chunk while the chunk is in cache.
    """

    def __init__(self, tracker: _Tracker, path: np.ndarray, theta_d: np.ndarray,
                 theta_u: np.ndarray, solved: np.ndarray, row_order: np.ndarray | None,
                 rates: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        self.tracker = tracker
        self.path = path
        self.theta_d = theta_d
        self.theta_u = theta_u
        self.row_order = row_order
        self.solved = solved
        self.known = np.flatnonzero(solved)
        self.start = self.known[np.searchsorted(self.known, np.arange(theta_d.shape[0]),
                                                side="right") - 1]
        self.expansion = None
        if not np.all(solved) and theta_u.shape[1]:
            self.expansion = taylor(tracker.system, theta_d[self.known], theta_u[self.known],
                                    row_order)
        # quintic Hermite polynomials in time between consecutive solved steps, of the driven
        # and the undriven angles (from their first and second time derivatives), for
        # :meth:`_predict`
        self.interpolation = None
        if self.expansion is not None and rates is not None and self.known.size > 1:
            first, second = self.expansion.first, self.expansion.second
            w, a = rates[0][self.known], rates[1][self.known]
            n_d = w.shape[1]
            speed = np.zeros(first.shape[:2])
            turn = np.zeros(first.shape[:2])
            start_t = tracker.times[self.known]
            h = np.diff(start_t)
            # rates that overflow give non-finite polynomials: their steps are extrapolated
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                for j in range(n_d):
                    speed += first[:, :, j] * w[:, j, None]
                    turn += first[:, :, j] * a[:, j, None]
                    for k in range(n_d):
                        turn += second[:, :, j * n_d + k] * (w[:, j, None] * w[:, k, None])
                solved_u = theta_u[self.known]
                self.interpolation = (
                    start_t[:-1], 1.0 / h,
                    _sixth_order(start_t, _quintic(h, (solved_u[:-1], speed[:-1], turn[:-1]),
                                                   (solved_u[1:], speed[1:], turn[1:])),
                                 solved_u))

    @property
    def size(self) -> int:
        """Number of steps."""
        return self.theta_d.shape[0]

    def _predict(self, part: slice) -> np.ndarray:
        """Angles of a chunk: solved steps as they are, the others predicted from their start.

        With rates that interpolate the driven angles (:func:`track`), a step between two solved
        steps is interpolated in time (quintic Hermite from both ends' angles and first and
        second time derivatives, plus a sixth-order term estimated from the neighbouring solved
        steps: errors near rounding, so one Newton iteration usually meets the tolerance); the
        other steps are extrapolated from their start (:class:`Taylor`).
        """
        theta_u = self.theta_u[part].copy()
        if self.expansion is None:
            return theta_u
        rows = np.flatnonzero(~self.solved[part])
        if not rows.size:
            return theta_u
        steps = rows + (part.start or 0)
        start = self.start[steps]
        index = np.searchsorted(self.known, start)
        extrapolate = np.ones(rows.size, dtype=bool)
        if self.interpolation is not None:
            inner = np.flatnonzero(index + 1 < self.known.size)
            if inner.size:
                extrapolate[inner] = ~self._interpolate(theta_u, rows[inner], steps[inner],
                                                        index[inner])
        if np.any(extrapolate):
            rows, steps, start = rows[extrapolate], steps[extrapolate], start[extrapolate]
            theta_u[rows] = self.expansion.predict(index[extrapolate],
                                                   self.path[steps] - self.path[start])
        return theta_u

    def _interpolate(self, theta_u: np.ndarray, rows: np.ndarray, steps: np.ndarray,
                     index: np.ndarray) -> np.ndarray:
        """Interpolate chunk ``rows`` between the solved steps ``index`` and ``index + 1``.

        In place where the interpolation is finite (second derivatives may overflow); returns
        where it is.
        """
        start_t, inverse_h, coef = self.interpolation  # type: ignore[misc]
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            guess = _horner(coef[index], (self.tracker.times[steps] - start_t[index])
                            * inverse_h[index])
            finite = np.isfinite(row_max_abs(guess))
        theta_u[rows[finite]] = guess[finite]
        return finite

    def polish(self, part: slice, z_d: np.ndarray) -> tuple[np.ndarray, np.ndarray,
                                                            BatchLU | None]:
        """Newton on the steps of ``part`` until the last update is below ``tol``.

        ``z_d`` are the chunk's driven phasors. Returns the chunk's undriven angles (rad), their
        phasors, and the factors of ``J_u`` of the last iteration (None without undriven angles).
        """
        tracker = self.tracker
        system, tols = tracker.system, tracker.tols
        theta_u = self._predict(part)
        guess = theta_u.copy()
        z_u = phasor(theta_u)
        if theta_u.shape[1] == 0:
            return theta_u, z_u, None
        base_phi = driven_part(system, z_d)
        w_u = system.loop_points[:, system.undriven]
        limit = tols.tol + 8 * _EPS * row_max_abs(theta_u)
        offset = part.start or 0
        start = self.start[part]
        checked = False
        # Rows still iterating: the whole chunk first, then only the rows not yet converged
        # when they are few (interpolated steps), their factors replacing theirs in the chunk's:
        # each row keeps the factors of its own last iteration.
        active = np.arange(theta_u.shape[0])
        settled = np.zeros(theta_u.shape[0], dtype=bool)
        lu: BatchLU | None = None
        for attempt in range(tols.max_iter + 1):
            whole = lu is None or 2 * active.size > theta_u.shape[0]
            if whole:
                active = np.arange(theta_u.shape[0])
            z_a = z_u if whole else z_u[active]
            factors = BatchLU(system.jacobian_stack(z_a), self.row_order)
            phi = (base_phi if whole else base_phi[active]) + z_a @ w_u.T
            phi = np.concatenate([phi.real, phi.imag], axis=1)
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                step = factors.solve(phi)
            size = row_max_abs(step)
            finite = np.isfinite(size)
            if whole and np.all(finite):
                theta_u -= step
                z_u = rotate(z_u, -step)
            else:
                rows = active[finite]
                theta_u[rows] -= step[finite]
                z_u[rows] = rotate(z_a[finite], -step[finite])
            if whole:
                lu = factors
            else:
                lu.assign(active, factors)  # type: ignore[union-attr]
            converged = size <= limit[active]
            if not np.all(converged):
                # near a toggle the angles are only defined to rounding times the condition
                converged |= row_max_abs(phi) <= 16 * _EPS * system.length_scale
            # Converged on the first iteration (from an interpolated guess) with an update above
            # _FRESH: one more iteration, for factors at the solution (the forces' accuracy).
            again = converged & ~settled[active] & (size > _FRESH) if attempt == 0 else \
                np.zeros(active.size, dtype=bool)
            converged |= settled[active]
            settled[active[again]] = True
            active = active[~converged | again]
            if not active.size:
                if not checked:
                    checked = True
                    delta = self.path[part] - self.path[start]
                    wrong = np.flatnonzero(~_plausible(theta_u, guess, self.theta_u[start],
                                                       delta))
                    if wrong.size:
                        self._redo(theta_u, z_u, wrong, offset)
                        active = wrong
                        continue
                self.theta_u[part] = theta_u
                return theta_u, z_u, lu  # type: ignore[return-value]
            stuck = active
            if attempt == tols.max_iter:
                first = offset + int(stuck[0])
                origin = int(self.start[first])
                tracker.fail(first, self.theta_d[origin], self.theta_u[origin],
                             self.theta_d[first])
            if attempt >= 2:
                self._redo(theta_u, z_u, stuck, offset)
        raise AssemblyError("Newton did not converge", where={"file": tracker.mechanism.source})

    def _redo(self, theta_u: np.ndarray, z_u: np.ndarray, rows: np.ndarray, offset: int) -> None:
        """Solve chunk rows by sequential continuation from their solved start steps."""
        for row in rows:
            target = offset + int(row)
            origin = int(self.start[target])
            theta_u[row] = self.tracker.step(self.theta_d[origin], self.theta_u[origin],
                                             self.path[target] - self.path[origin],
                                             self.theta_d[target], target)
            z_u[row] = phasor(theta_u[row])
        logger.debug("%d steps needed sequential continuation", rows.size)


