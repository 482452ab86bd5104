"""``solve`` and ``solve_cycle``: kinematics and inverse dynamics of a mechanism, batched in time.

Stages run only when a requested output needs them: positions always; velocities for velocities,
accelerations or forces; accelerations for accelerations or forces; multipliers for forces and
torques. One factorisation of the reduced ``C_e`` per step serves velocities, accelerations and
multipliers.
"""

from __future__ import annotations

import logging
import math
import warnings
from collections.abc import Iterable, Mapping
from pathlib import Path

import numpy as np
import scipy.interpolate
import xarray as xr

from rigval.acquisition.errors import ConfigError, DataError, NumericsWarning
from rigval.acquisition.hugepages import plain_pages
from rigval.acquisition.threads import single_blas_thread
from rigval.model import assembly
from rigval.model.continuation import Continuation, track
from rigval.model.drives import DriveSamples, SampledDrive, cycle_period, drive_motion
from rigval.model.dynamics import applied_forces, minimum_norm_multipliers, multipliers
from rigval.model.errors import SingularityError
from rigval.model.finite import check_finite
from rigval.model.kinematics import angular_accelerations, angular_velocities
from rigval.model.linalg import BatchLU
from rigval.model.loops import LoopSystem, loop_system
from rigval.model.mechanism import Mechanism, load_mechanism
from rigval.model.reference import constraint_jacobian
from rigval.model.results import Selection, Solution, build_dataset, select

__all__ = ["interpolate_cycle", "solve", "solve_cycle"]

logger = logging.getLogger(__name__)

#: Steps whose pivot estimate of the condition exceeds this fraction of ``cond_warn`` get the
#: exact condition number.
_SCREEN = 1e-3
#: Steps with the largest condition estimates that get the exact condition number.
_TOP = 256
#: Steps finished and post-processed together (their arrays stay near the processor: 8192
#: measured 2 % faster than 4096 on the pendulum once most steps need one Newton iteration).
_CHUNK = 8192
#: Outputs that read the centre-of-gravity position, velocity and acceleration arrays.
_NEEDS_POSITION = {"position", "point_position", "point_velocity", "point_acceleration",
                   "kinetic_energy", "potential_energy"}
_NEEDS_VELOCITY = {"velocity", "point_velocity", "point_acceleration", "kinetic_energy"}
_NEEDS_ACCELERATION = {"acceleration", "point_acceleration"}

def _as_mechanism(mechanism: Mechanism | str | Path) -> Mechanism:
    return mechanism if isinstance(mechanism, Mechanism) else load_mechanism(mechanism)


def solve(mechanism: Mechanism | str | Path, t: np.ndarray, *,
          outputs: Iterable[str] | str | None = None,
          points: Iterable[str] | str | None = None,
          joints: Iterable[str] | str | None = None,
          drives: Mapping[str, SampledDrive] | None = None,
          tol: float = 1e-12, cond_warn: float = 1e4, cond_max: float = assembly.COND_MAX,
          guess_tol: float = assembly.GUESS_TOL) -> xr.Dataset:
    """Kinematics and inverse dynamics of a mechanism at the times ``t``.

    Parameters
    ----------
    mechanism : Mechanism, str or pathlib.Path
        The mechanism, or the path of its file.
    t : array_like
        (n,) times, s. Steps are followed in the given order (continuation), so consecutive
        samples should be close in drive angle; larger jumps are subdivided automatically.
    outputs : iterable of str, optional
        Variables to compute: any of :data:`~rigval.model.results.OUTPUTS` (the default: all of
        them) and :data:`~rigval.model.results.EXTRA_OUTPUTS`. Only the stages they need run.
    points : iterable of str, optional
        Points for the ``point_*`` variables (default: every named point).
    joints : iterable of str, optional
        Joints for ``joint_force`` (default: all).
    drives : mapping, optional
        Sampled drives replacing the file's laws: driver name -> ``(theta, omega, alpha)`` arrays
        on ``t`` (rad, rad/s, rad/s2).
    tol : float
        Newton tolerance: angle updates in rad, loop gaps relative to the mechanism size.
    cond_warn : float
        Condition number of the (column-equilibrated, reduced) ``C_e`` past which a
        NumericsWarning is issued.
    cond_max : float
        Condition number past which a SingularityError is raised; default
        :data:`~rigval.model.assembly.COND_MAX` (about 2.1e5, where ``cond**2 * eps`` reaches
        1e-5 and the forces stop being trustworthy, see docs/numerics.md).
    guess_tol : float
        Stated accuracy of the bodies' guess angles, rad (default 0.5): bodies assembled farther
        from their guesses get a NumericsWarning naming them (another assembly branch).

    Returns
    -------
    xarray.Dataset
        Dim ``time`` and the requested variables (see :mod:`rigval.model.results`).

    Raises
    ------
    AssemblyError
        The mechanism cannot be assembled or cannot follow the drives; names the open joints.
    SingularityError
        ``C_e`` loses rank (toggle); names the time, the joints involved and the residual.
    """
    mech = _as_mechanism(mechanism)
    times = np.asarray(t, dtype=float)
    if times.ndim != 1 or times.size == 0 or not np.all(np.isfinite(times)):
        raise DataError("t must be a non-empty 1-D array of finite times in s",
                        where={"key": "t"}, hint="pass sample times as a 1-D float array")
    selection = select(mech, outputs, points, joints)
    tolerances = assembly.Tolerances(tol=tol, cond_warn=cond_warn, cond_max=cond_max,
                                     guess_tol=guess_tol)
    motion = drive_motion(mech, times, drives)
    system = loop_system(mech)
    if mech.redundant_constraints and selection.forces:
        warnings.warn(
            f"{mech.name}: {mech.redundant_constraints} redundant constraint equations; joint "
            "forces and drive torques are not unique, the minimum-norm multipliers are returned",
            NumericsWarning, stacklevel=2)
    exact = "condition_number" in selection.outputs
    # Many tiny systems: BLAS threads only wait for each other. Arrays filled once: huge pages
    # only add synchronous compaction (measured in docs/performance.md).
    with single_blas_thread(), plain_pages():
        solution = _empty_solution(mech, times, motion, selection)
        continuation = track(mech, system, times, motion.theta, tolerances,
                                      rates=(motion.omega, motion.alpha))
        with np.errstate(over="ignore", invalid="ignore"):  # overflow: check_finite names it
            for start in range(0, times.size, _CHUNK):
                part = slice(start, min(start + _CHUNK, times.size))
                _solve_chunk(mech, system, continuation, motion, selection, solution, part,
                             exact)
        _check_condition(mech, system, times, solution, tolerances, exact)
    attrs = {"title": f"rigval model: {mech.name}", "mechanism": mech.name,
             "mechanism_source": mech.source, "newton_tol": tol,
             "redundant_constraints": mech.redundant_constraints,
             "max_condition_number": float(np.max(solution.condition, initial=1.0)),
             "sign_convention": "M e'' = Q_e - C_e^T lambda; joint_force = -lambda on the "
                                "first body; driver_torque = -lambda_driver"}
    with plain_pages():
        return build_dataset(mech, solution, selection, attrs)


def _empty_solution(mechanism: Mechanism, times: np.ndarray, motion: DriveSamples,
                    selection: Selection) -> Solution:
    """Arrays of every step for what the outputs read.

    The angles always (the condition check reads them); angular and centre-of-gravity
    velocities and accelerations only when an output reads them: forces use each chunk's
    kinematics while the chunk is in cache, and each chunk is checked for non-finite values
    before it is dropped (:func:`_solve_chunk`).
    """
    n, n_bodies = times.size, len(mechanism.bodies)
    wanted = set(selection.outputs)

    def kept(needed: set[str], dtype: type = float) -> np.ndarray | None:
        return np.empty((n, n_bodies), dtype=dtype) if wanted & needed else None

    solution = Solution(times=times, theta=np.empty((n, n_bodies)),
                        position=kept(_NEEDS_POSITION, complex), condition=np.empty(n))
    if selection.velocity:
        solution.omega = kept(_NEEDS_VELOCITY)
        solution.velocity = kept(_NEEDS_VELOCITY, complex)
        solution.omega_driven = motion.omega
    if selection.acceleration:
        solution.alpha = kept(_NEEDS_ACCELERATION)
        solution.acceleration = kept(_NEEDS_ACCELERATION, complex)
    if selection.forces:
        n_joints = len(mechanism.joints)
        # joint_force of every joint goes straight into the output's (axis, time, joint) layout
        direct = "joint_force" in wanted and selection.joints == mechanism.joint_names
        if direct:
            solution.joint_planar = np.empty((2, n, n_joints))
        if "support_force" in wanted or ("joint_force" in wanted and not direct):
            solution.joint = np.empty((n, n_joints), dtype=complex)
        solution.driver = np.empty((n, len(mechanism.drivers)))
    return solution


def _solve_chunk(mechanism: Mechanism, system: LoopSystem, continuation: Continuation,
                 motion: DriveSamples, selection: Selection, solution: Solution, part: slice,
                 exact: bool) -> None:
    """Finish the positions of one chunk of steps and compute what the selection needs.

    The chunk's stages are checked for non-finite values (:func:`check_finite`, which names
    the first stage and time) and stored where ``solution`` keeps them.
    """
    theta_d = motion.theta[part]
    z_d = assembly.phasor(theta_d)
    theta_u, z_u, lu = continuation.polish(part, z_d)
    theta = assembly.full_angles(system, theta_d, theta_u)
    z = np.empty(theta.shape, dtype=complex)
    z[:, system.driven] = z_d
    z[:, system.undriven] = z_u
    s = solution
    chunk = Solution(times=s.times[part], theta=theta,
                     position=None if s.position is None else system.positions(z))
    if lu is None:
        s.condition[part] = 1.0
    else:
        s.condition[part] = lu.condition() if exact else lu.condition_estimate()
    if selection.velocity:
        omega = angular_velocities(system, z, lu, motion.omega[part])
        chunk.omega = omega
        if s.velocity is not None:
            chunk.velocity = -(1j * omega * z) @ system.position_map.T
    if selection.acceleration:
        alpha = angular_accelerations(system, z, lu, omega, motion.alpha[part])
        chunk.alpha = alpha
        chunk.acceleration = -((1j * alpha - omega**2) * z) @ system.position_map.T
    if selection.forces:
        force, moment = applied_forces(mechanism, chunk.acceleration, alpha)
        if mechanism.redundant_constraints:
            chunk.joint, chunk.driver = minimum_norm_multipliers(
                constraint_jacobian(system, theta), force, moment, len(mechanism.joints))
        else:
            chunk.joint, chunk.driver = multipliers(system, z, lu, force, moment)
    check_finite(mechanism, motion, chunk)
    for name in ("theta", "position", "omega", "velocity", "alpha", "acceleration", "joint",
                 "driver"):
        store = getattr(s, name)
        if store is not None:
            store[part] = getattr(chunk, name)
    if s.joint_planar is not None:  # joint_force = -lambda
        np.negative(chunk.joint.real, out=s.joint_planar[0, part])
        np.negative(chunk.joint.imag, out=s.joint_planar[1, part])


def _check_condition(mechanism: Mechanism, system: LoopSystem, times: np.ndarray,
                     solution: Solution, tolerances: assembly.Tolerances, exact: bool) -> None:
    """Warn or raise when the reduced ``C_e`` is ill-conditioned (updates the condition numbers).

    Every step was screened with the pivot estimate (at most a few hundred times too low for
    6 x 6 matrices); the exact condition is computed where the estimate exceeds
    ``_SCREEN * cond_warn`` and at the ``_TOP`` largest estimates (everywhere when ``exact``), so
    the largest value reported is an exact one.
    """
    cond = solution.condition
    if system.undriven.size == 0:
        return
    if not exact:
        suspect = np.flatnonzero(cond > _SCREEN * tolerances.cond_warn)
        largest = np.argpartition(cond, -_TOP)[-_TOP:] if cond.size > _TOP else np.arange(cond.size)
        suspect = np.union1d(suspect, largest)
        z_u = assembly.phasor(solution.theta[suspect][:, system.undriven])
        cond[suspect] = BatchLU(system.jacobian_stack(z_u)).condition()
    theta = solution.theta
    worst = int(np.argmax(cond))
    if cond[worst] > tolerances.cond_max:
        joints = assembly.involved_joints(mechanism, system, theta[worst])
        raise SingularityError(
            f"C_e loses rank at t = {times[worst]:.9g} s (condition {cond[worst]:.3g} > "
            f"{tolerances.cond_max:.3g}): a toggle or lock-up position; joints involved: "
            f"{', '.join(joints)}; residual 0 m (assembled, but forces are unbounded)",
            where={"file": mechanism.source, "time_s": float(times[worst]), "joints": joints},
            hint="keep the drives away from the limit position or change the geometry",
            joints=joints, residual_m=0.0, condition=float(cond[worst]))
    if cond[worst] > tolerances.cond_warn:
        joints = assembly.involved_joints(mechanism, system, theta[worst])
        warnings.warn(
            f"{mechanism.name}: C_e is ill-conditioned near t = {times[worst]:.9g} s (condition "
            f"{cond[worst]:.3g} > {tolerances.cond_warn:.3g}), close to a toggle position; "
            f"forces in joints {', '.join(joints)} are large and sensitive",
            NumericsWarning, stacklevel=3)


def solve_cycle(mechanism: Mechanism | str | Path, angles: int | np.ndarray, *,
                driver: str | None = None, angle_origin: float | None = None,
                **options: object) -> xr.Dataset:
    """Solve at main-drive angles over one revolution (all drive laws must repeat with it).

    Parameters
    ----------
    mechanism : Mechanism, str or pathlib.Path
        The mechanism or its file.
    angles : int or array_like
        Number of equally spaced angles in [0, 2 pi), or the angles themselves (rad, past the
        origin, within one revolution).
    driver : str, optional
        Main driver (default: the first one); its angle is the cycle coordinate (phi_F).
    angle_origin : float, optional
        Main driver's body angle at angle 0, rad (default: its angle at t = 0).
    **options
        Passed to :func:`solve` (``outputs``, ``points``, ``joints``, ``tol``, ...).

    Returns
    -------
    xarray.Dataset
        The :func:`solve` variables with dim ``angle`` (rad) instead of ``time``; ``time`` (s,
        within the revolution starting at the origin) is a coordinate along ``angle``.
    """
    mech = _as_mechanism(mechanism)
    if "drives" in options:
        raise ConfigError("solve_cycle evaluates the file's drive laws; sampled drives are not "
                          "periodic", where={"key": "drives"},
                          hint="use solve() with the sample times for measured drives")
    main, period = cycle_period(mech, driver)
    if isinstance(angles, int | np.integer):
        if angles < 1:
            raise ConfigError(f"need at least one angle, got {angles}", where={"key": "angles"})
        phi = np.arange(int(angles)) * (2.0 * math.pi / int(angles))
    else:
        phi = np.asarray(angles, dtype=float)
        if phi.ndim != 1 or np.any(phi < 0) or np.any(phi >= 2 * math.pi + 1e-12):
            raise ConfigError("angles must be a 1-D array within one revolution [0, 2 pi)",
                              where={"key": "angles"}, hint="wrap the angles with np.mod")
    origin = float(main.motion(np.zeros(1))[0][0]) if angle_origin is None \
        else float(angle_origin)
    times = main.times_at(origin + phi)
    ds = solve(mech, times, **options)  # type: ignore[arg-type]
    ds = ds.assign_coords(angle=("time", phi, {
        "units": "rad", "long_name": f"angle of driver {main.name} past {origin:.6g} rad"}))
    ds = ds.swap_dims(time="angle")
    ds.attrs.update(cycle_driver=main.name, cycle_period_s=period, angle_origin_rad=origin)
    return ds


def interpolate_cycle(cycle: xr.Dataset, angles: np.ndarray) -> xr.Dataset:
    """Interpolate a :func:`solve_cycle` result to other angles with periodic cubic splines.

    Parameters
    ----------
    cycle : xarray.Dataset
        Result of :func:`solve_cycle` on equally or unequally spaced angles covering a revolution.
    angles : array_like
        Angles past the origin, rad (any values; taken modulo 2 pi).

    Returns
    -------
    xarray.Dataset
        Every variable with dim ``angle`` interpolated; dim ``angle`` holds the given angles.
        Body angles that turn whole revolutions per cycle are interpolated on top of their
        steady increase over the revolution.
    """
    grid = cycle["angle"].to_numpy()
    order = np.argsort(grid)
    grid = grid[order]
    closed = np.concatenate([grid, [grid[0] + 2 * math.pi]])
    target = np.mod(np.asarray(angles, dtype=float) - grid[0], 2 * math.pi) + grid[0]
    out = {}
    for name, var in cycle.data_vars.items():
        if "angle" not in var.dims:
            continue
        values = np.moveaxis(var.to_numpy(), var.dims.index("angle"), 0)[order]
        winding = _winding(name, var, values)
        ramp = np.multiply.outer(closed - grid[0], winding / (2 * math.pi))
        values = np.concatenate([values, values[:1] + winding], axis=0) - ramp
        spline = scipy.interpolate.CubicSpline(closed, values, axis=0, bc_type="periodic")
        ramp = np.multiply.outer(target - grid[0], winding / (2 * math.pi))
        data = np.moveaxis(spline(target) + ramp, 0, var.dims.index("angle"))
        out[name] = xr.Variable(var.dims, data, var.attrs)
    coords = {k: v for k, v in cycle.coords.items() if "angle" not in v.dims}
    coords["angle"] = ("angle", np.asarray(angles, dtype=float), cycle["angle"].attrs)
    return xr.Dataset(out, coords=coords, attrs=cycle.attrs)


def _winding(name: str, var: xr.DataArray, values: np.ndarray) -> np.ndarray:
    """Change over one revolution of each entry: whole turns of the body angles, 0 otherwise."""
    winding = np.zeros(values.shape[1:])
    if name == "position" and values.shape[0] > 1:
        theta = list(var["coord"].to_numpy()).index("theta")
        sub = [slice(None)] * (values.ndim - 1)
        sub[var.dims.index("coord") - 1] = theta
        ahead = 2 * values[-1] - values[-2] - values[0]
        winding[tuple(sub)] = 2 * math.pi * np.round(ahead[tuple(sub)] / (2 * math.pi))
    return winding
