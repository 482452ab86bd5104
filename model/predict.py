"""Predictions of the model for drive settings nobody measured ([paper] section 5).

:func:`predict` runs the model over one cycle for an excitation (the mechanism file's drive laws,
laws changed on the command line or in TOML, a tabulated profile, or a measured run) and returns
the quantities engineers look at when they change the drives: the path, speed and acceleration of
the mechanism's tip (the pendulum's P1, see :func:`default_tip`), the drive torques and power,
the support forces on the frame at every ground pin (with peaks and the angles where they occur)
and the forces of chosen joints.

:func:`sweep` varies one or two parameters over a grid and returns only summary numbers per point
(tip-path vertical range, peak tip acceleration, peak support forces, peak and RMS drive torques).
It solves the model once per distinct tip path and reuses the result exactly (see
:func:`sweep` for the superposition it relies on).

Everything is evaluated on a grid of the main-drive angle ``phi_F`` (dim ``angle``, rad, in
``[0, 2 pi)`` from the main drive's position at t = 0), the coordinate the validation compares on.
"""

from __future__ import annotations

import dataclasses
import itertools
import logging
import math
import re
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import xarray as xr

from rigval.acquisition.errors import ChannelNotFoundError, ConfigError
from rigval.model import Mechanism, load_mechanism, solve
from rigval.model.drive_laws import apply_drive_options, excitation_from_measured
from rigval.model.laws import Excitation
from rigval.model.mechanism import mechanism_file
from rigval.model.results import QUANTITIES, output_attrs

__all__ = [
    "SUMMARIES",
    "DriveSpec",
    "default_tip",
    "file_excitation",
    "ground_pins",
    "make_excitation",
    "parse_sweep_option",
    "predict",
    "resolve_mechanism",
    "sweep",
]

logger = logging.getLogger(__name__)

#: Summary quantities a sweep can evaluate, with their units and meaning.
SUMMARIES: dict[str, tuple[str, str]] = {
    "tip_vertical_range": ("m", "vertical range of the tip path over a cycle"),
    "tip_acceleration_peak": ("m s-2", "peak absolute acceleration of the tip"),
    "support_force_peak": ("N", "peak magnitude of the support force on the frame"),
    "torque_peak": ("N m", "peak absolute drive torque"),
    "torque_rms": ("N m", "root mean square of the drive torque over a cycle"),
}

#: What an excitation may be given as: None (the mechanism file's laws), an Excitation,
#: ``NAME=LAW`` option strings, or a Dataset of measured drive angles.
DriveSpec = Excitation | Sequence[str] | xr.Dataset | None

_AXES = ("x", "y")
#: Unit suffixes of sweep values and the factor to SI (rad, Hz).
_SWEEP_UNITS = {"": 1.0, "rad": 1.0, "deg": math.pi / 180.0, "hz": 1.0, "rev/s": 1.0,
                "rpm": 1.0 / 60.0, "kg": 1.0, "kgm2": 1.0}
_FORCE_SUMMARIES = {"support_force_peak", "torque_peak", "torque_rms"}


def resolve_mechanism(mechanism: Mechanism | str | Path) -> Mechanism:
    """Return a loaded mechanism from a Mechanism, a file path or ``builtin:NAME``.

    Parameters
    ----------
    mechanism : Mechanism, str or pathlib.Path
        A loaded mechanism (returned as is), the path of a mechanism TOML file, or
        ``builtin:pendulum`` for a mechanism shipped with rigval.
    """
    if isinstance(mechanism, Mechanism):
        return mechanism
    return load_mechanism(mechanism_file(mechanism))


def file_excitation(mechanism: Mechanism, *, main: str | None = None) -> Excitation:
    """Return the mechanism file's drive laws as an :class:`Excitation` (exact, no refit).

    Parameters
    ----------
    mechanism : Mechanism
        The mechanism.
    main : str, optional
        Main drive (the cycle's reference); default the first driver.
    """
    return mechanism.excitation(main)


def make_excitation(mechanism: Mechanism, drives: DriveSpec = None, *, main: str | None = None,
                    base_dir: Path | None = None) -> Excitation:
    """Return the excitation that ``drives`` describes for ``mechanism``.

    Parameters
    ----------
    mechanism : Mechanism
        The mechanism.
    drives : Excitation, sequence of str, xarray.Dataset or None
        None for the file's laws; an Excitation (its drive names must be the mechanism's);
        ``NAME=LAW`` options applied to the file's laws (see
        :func:`rigval.model.drive_laws.parse_drive_option`); or a measured run's drive angles
        (see :func:`rigval.model.drive_laws.excitation_from_measured`).
    main : str, optional
        Main drive; default the first driver.
    base_dir : pathlib.Path, optional
        Folder relative profile and law paths are resolved against.
    """
    if isinstance(drives, Excitation):
        excitation = drives
    elif isinstance(drives, xr.Dataset):
        excitation = excitation_from_measured(drives, mechanism.driver_names, main=main)
    elif drives is None or isinstance(drives, Sequence):
        if isinstance(drives, str):
            drives = [drives]
        excitation = apply_drive_options(file_excitation(mechanism, main=main), drives or (),
                                         base_dir=base_dir)
    else:
        raise ConfigError(f"cannot use {type(drives).__name__} as drives",
                          hint="pass None, an Excitation, NAME=LAW strings or a Dataset")
    if set(excitation.names) != set(mechanism.driver_names):
        raise ChannelNotFoundError(
            f"the excitation drives {list(excitation.names)} but the mechanism has drivers "
            f"{list(mechanism.driver_names)}", where={"file": mechanism.source},
            hint="give one law per driver of the mechanism",
            available=list(mechanism.driver_names))
    return excitation


def ground_pins(mechanism: Mechanism) -> tuple[str, ...]:
    """Return the names of the joints that pin a body to the ground (the supports)."""
    return tuple(j.name for j in mechanism.joints if j.kind == "ground")


def default_tip(mechanism: Mechanism) -> str:
    """Return the mechanism's tip: the point farthest from every ground pin.

    Distances are taken in the configuration of the body guesses (the file's assembled
    configuration at t = 0): the point whose smallest distance to a ground pin is largest. This is
    ``P1`` for the built-in pendulum, the rocker pin ``B`` for the four-bar and ``tip`` for the
    single pendulum. A mechanism without ground pins measures from the origin.

    Parameters
    ----------
    mechanism : Mechanism
        The mechanism.

    Returns
    -------
    str
        A point name of the mechanism.
    """
    pins = [np.asarray(j.at, dtype=float) for j in mechanism.joints
            if j.kind == "ground" and j.at is not None] or [np.zeros(2)]
    best, best_distance = mechanism.point_names[0], -1.0
    for body in mechanism.bodies:
        x, y, theta = body.guess
        c, s = math.cos(theta), math.sin(theta)
        for name, (u, v) in body.points.items():
            where = np.array([x + c * u - s * v, y + s * u + c * v])
            distance = min(float(np.hypot(*(where - pin))) for pin in pins)
            if distance > best_distance + 1e-12:
                best, best_distance = name, distance
    return best


def _check_names(kind: str, names: Sequence[str], available: Sequence[str]) -> None:
    for name in names:
        if name not in available:
            raise ChannelNotFoundError(f"no {kind} named {name!r}", where={kind: name},
                                       hint=f"choose one of the mechanism's {kind}s",
                                       available=list(available))


def _solve(mechanism: Mechanism, excitation: Excitation, t: np.ndarray, *,
           outputs: Sequence[str], points: Sequence[str], joints: Sequence[str],
           with_statics: bool = False) -> xr.Dataset:
    """Run the model at times ``t`` with the excitation's drive angles, only what is asked.

    With ``with_statics`` every time step is followed by a copy at the same drive angles with
    zero drive speed and acceleration: the odd rows of the result hold the static (gravity-only)
    forces of the same configuration, at almost no cost (the position continuation does not move
    between a step and its copy).
    """
    drives = excitation.evaluate(t)
    ordered = {d.name: drives[d.name] for d in mechanism.drivers}
    if with_statics:
        t = np.repeat(t, 2)
        ordered = {name: (np.repeat(theta, 2), _then_zero(speed), _then_zero(accel))
                   for name, (theta, speed, accel) in ordered.items()}
    return solve(mechanism, t, drives=ordered, outputs=tuple(outputs), points=tuple(points),
                 joints=tuple(joints))


def _then_zero(values: np.ndarray) -> np.ndarray:
    """Return ``values`` with a zero after every element."""
    return np.stack([values, np.zeros_like(values)], axis=1).ravel()


def _cycle_grid(excitation: Excitation, n_points: int
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, str]:
    """Return the cycle coordinate (rad), the times (s), its rate (rad/s) and what it means.

    The coordinate is the main-drive angle phi_F when the main drive turns steadily, otherwise
    (a swinging main drive) the cycle phase ``2 pi t / period`` on a uniform time grid.
    """
    if excitation.turns_steadily():
        angle, t = excitation.cycle_times(n_points)
        law = excitation.law(excitation.main)
        rate = math.copysign(1.0, law.ratio) * law.evaluate(t, excitation.omega)[1]
        return angle, t, rate, (f"main-drive angle phi_F ({excitation.main}) from its position "
                                "at t = 0")
    if n_points < 4:
        excitation.cycle_times(n_points)  # raises the error about too few points
    angle = 2.0 * math.pi * np.arange(n_points) / n_points
    logger.info("main drive %s reverses within the cycle: the coordinate is the cycle phase",
                excitation.main)
    return angle, angle / excitation.omega, np.full(n_points, excitation.omega), (
        f"cycle phase 2 pi t / period (the main drive {excitation.main} reverses, so its angle "
        "cannot serve)")


def _angle_coords(angle: np.ndarray, t: np.ndarray, meaning: str) -> dict[str, Any]:
    return {
        "angle": ("angle", angle, {"units": "rad", "long_name": meaning}),
        "time": ("angle", t, {"units": "s", "long_name": "time from cycle start"}),
    }


def _peak(values: np.ndarray, angle: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return the largest absolute value along axis 0 and the angle where it occurs."""
    index = np.argmax(np.abs(values), axis=0)
    return np.take_along_axis(np.abs(values), index[None], axis=0)[0], angle[index]


def predict(mechanism: Mechanism | str | Path, drives: DriveSpec = None, *, n_points: int = 360,
            tip: str | None = None, points: Sequence[str] = (), joints: Sequence[str] = (),
            main: str | None = None, base_dir: Path | None = None) -> xr.Dataset:
    """Predict the response of a mechanism to an excitation over one cycle.

    Parameters
    ----------
    mechanism : Mechanism, str or pathlib.Path
        The mechanism (see :func:`resolve_mechanism`).
    drives : Excitation, sequence of str, xarray.Dataset or None
        The excitation (see :func:`make_excitation`); None for the file's drive laws.
    n_points : int
        Grid points over one cycle of the main drive (uniform in its angle).
    tip : str, optional
        The point whose path is reported; default :func:`default_tip` (the pendulum's ``P1``).
    points : sequence of str
        Further points whose kinematics are reported.
    joints : sequence of str
        Joints whose forces are reported besides the ground pins.
    main : str, optional
        Main drive; default the first driver.
    base_dir : pathlib.Path, optional
        Folder relative profile and law paths are resolved against.

    Returns
    -------
    xarray.Dataset
        On dim ``angle`` (rad; ``time`` in s along it): ``drive_angle``, ``drive_speed``,
        ``drive_acceleration`` (angle, driver); ``point_position``, ``point_velocity``,
        ``point_acceleration`` (angle, point, axis) in m, m s-1, m s-2 with ``point_speed`` and
        ``point_acceleration_magnitude``; ``driver_torque`` (N m, on the driven body) and
        ``drive_power`` (W, torque times angular speed) per driver; ``support_force`` (angle,
        support, axis), the force ON THE FRAME at each ground pin (minus the model's
        ``joint_force``), N; ``joint_force`` (angle, joint, axis) of the chosen joints (model
        convention: on the joint's first body); and the summaries ``tip_vertical_range``,
        ``tip_acceleration_peak``, ``support_force_peak`` and ``support_force_peak_angle``
        (support, component), ``torque_peak``, ``torque_peak_angle``, ``torque_rms``,
        ``cycle_work`` (net drive work per cycle, J: zero for a conservative machine).
    """
    mech = resolve_mechanism(mechanism)
    excitation = make_excitation(mech, drives, main=main, base_dir=base_dir)
    tip = default_tip(mech) if tip is None else tip
    point_names = list(dict.fromkeys([tip, *points]))
    _check_names("point", point_names, mech.point_names)
    _check_names("joint", joints, mech.joint_names)
    pins = ground_pins(mech)
    joint_names = [j for j in dict.fromkeys(joints) if j not in pins]
    angle, t, rate, meaning = _cycle_grid(excitation, n_points)
    result = _solve(mech, excitation, t, points=point_names, joints=joint_names,
                    outputs=("point_position", "point_velocity", "point_acceleration",
                             "driver_torque", "drive_power", "support_force",
                             *(("joint_force",) if joint_names else ())))
    values = excitation.evaluate(t)
    drivers = list(mech.driver_names)
    torque = result["driver_torque"].sel(driver=drivers).values
    power = result["drive_power"].sel(driver=drivers).values
    support = _support(result, pins)
    joint_force = (result["joint_force"].sel(joint=joint_names, axis=list(_AXES)).values
                   if joint_names else np.zeros((t.size, 0, len(_AXES))))
    pos = result["point_position"].sel(point=point_names, axis=list(_AXES)).values
    vel = result["point_velocity"].sel(point=point_names, axis=list(_AXES)).values
    acc = result["point_acceleration"].sel(point=point_names, axis=list(_AXES)).values
    acc_magnitude = np.hypot(acc[..., 0], acc[..., 1])
    data: dict[str, Any] = {}
    for i, (label, unit) in enumerate((("angle", "rad"), ("speed", "rad s-1"),
                                       ("acceleration", "rad s-2"))):
        data[f"drive_{label}"] = (("angle", "driver"),
                                  np.stack([values[d][i] for d in drivers], axis=-1),
                                  {"units": unit, "long_name": f"drive {label}"})
    for name, array in (("point_position", pos), ("point_velocity", vel),
                        ("point_acceleration", acc)):
        data[name] = (("angle", "point", "axis"), array, output_attrs(name))
    data["point_speed"] = (("angle", "point"), np.hypot(vel[..., 0], vel[..., 1]),
                           {"units": "m s-1", "long_name": "absolute speed of the point"})
    data["point_acceleration_magnitude"] = (("angle", "point"), acc_magnitude, {
        "units": "m s-2", "long_name": "absolute acceleration of the point"})
    data["driver_torque"] = (("angle", "driver"), torque, output_attrs("driver_torque"))
    data["drive_power"] = (("angle", "driver"), power, output_attrs("drive_power"))
    data["support_force"] = (("angle", "support", "axis"), support, {
        "units": QUANTITIES["support_force"].units["x"],
        "long_name": "support force ON THE FRAME at the ground pin (minus joint_force)"})
    data["joint_force"] = (("angle", "joint", "axis"), joint_force,
                           output_attrs("joint_force"))
    data |= _summaries(angle, rate, tip=tip, tip_y=pos[:, 0, 1],
                       tip_acceleration=acc_magnitude[:, 0], support=support, torque=torque,
                       power=power)
    coords = {**_angle_coords(angle, t, meaning), "driver": drivers, "point": point_names,
              "axis": list(_AXES), "support": list(pins), "joint": joint_names,
              "component": ["x", "y", "magnitude"]}
    ds = xr.Dataset(data, coords=coords, attrs={
        "title": f"rigval prediction: {mech.name}",
        "mechanism": mech.name, "mechanism_source": mech.source,
        "frequency_hz": excitation.frequency, "main_drive": excitation.main, "tip_point": tip,
        "drive_laws": "\n".join(_law_descriptions(excitation)), "n_points": n_points,
    })
    logger.info("predicted %s at %.4g Hz on %d angles", mech.name, excitation.frequency, n_points)
    return ds


def _summaries(angle: np.ndarray, rate: np.ndarray, *, tip: str, tip_y: np.ndarray,
               tip_acceleration: np.ndarray, support: np.ndarray, torque: np.ndarray,
               power: np.ndarray) -> dict[str, Any]:
    """Return the peak, range, RMS and cycle-work variables of a prediction.

    ``rate`` is the cycle coordinate's rate, rad/s. The work ``integral P dt`` is taken over the
    uniform coordinate grid as ``integral P / rate d angle`` (the periodic trapezoid rule, which
    converges spectrally for a smooth periodic integrand).
    """
    data: dict[str, Any] = {}
    data["tip_vertical_range"] = ((), float(np.max(tip_y) - np.min(tip_y)), {
        "units": "m", "long_name": f"vertical range of the path of {tip} over a cycle"})
    peak, where = _peak(tip_acceleration, angle)
    data["tip_acceleration_peak"] = ((), float(peak), {
        "units": "m s-2", "long_name": f"peak absolute acceleration of {tip}"})
    data["tip_acceleration_peak_angle"] = ((), float(where), {"units": "rad"})
    components = np.concatenate([support, np.hypot(support[..., 0], support[..., 1])[..., None]],
                                axis=-1)
    peak, where = _peak(components, angle)
    data["support_force_peak"] = (("support", "component"), peak, {
        "units": "N", "long_name": "peak absolute support force on the frame"})
    data["support_force_peak_angle"] = (("support", "component"), where, {
        "units": "rad", "long_name": "main-drive angle of the peak support force"})
    peak, where = _peak(torque, angle)
    data["torque_peak"] = (("driver",), peak, {"units": "N m",
                                               "long_name": "peak absolute torque"})
    data["torque_peak_angle"] = (("driver",), where, {"units": "rad"})
    data["torque_rms"] = (("driver",), _time_rms(torque, rate), {
        "units": "N m", "long_name": "RMS drive torque over a cycle (time average)"})
    work = 2.0 * math.pi * float(np.mean(power.sum(axis=1) / rate))
    data["cycle_work"] = ((), work, {
        "units": "J", "long_name": "net work of all drives over a cycle (0 without losses)"})
    return data


def _time_rms(values: np.ndarray, rate: np.ndarray) -> np.ndarray:
    """Return the time RMS over a cycle of values on a uniform grid of a coordinate of ``rate``.

    Each sample stands for ``d angle / rate`` of time, so the samples are weighted by
    ``1 / rate`` (rad/s): on the main-drive angle grid the drive's speed ripple would otherwise
    bias the RMS towards the fast part of the cycle.
    """
    weights = 1.0 / rate
    return np.sqrt(weights @ values**2 / weights.sum())


def _law_descriptions(excitation: Excitation) -> list[str]:
    lines = [f"cycle frequency {excitation.frequency:.6g} Hz, main drive {excitation.main}"]
    for name, law in excitation.laws:
        text = (f"{name}: theta0 {law.theta0:.6g} rad, ratio {law.ratio:g}, phase "
                f"{law.phase:.6g} rad, {len(law.harmonics)} harmonics, from {law.source}")
        if law.error is not None:
            err = law.error.at(excitation.omega)
            text += (f"; stated error {err[0]:.3g} rad, {err[1]:.3g} rad/s, {err[2]:.3g} rad/s2"
                     f" ({law.error.order} harmonics fitted to {law.error.samples} samples)")
        lines.append(text)
    return lines


# ---------------------------------------------------------------------------------------------
# Sweeps


@dataclass(frozen=True)
class _Parameter:
    """A sweep parameter: its name, what it changes (``frequency``, ``path``, ``inertia``)."""

    name: str
    kind: str
    values: np.ndarray


_HARMONIC = re.compile(r"h(\d+)\.(amplitude|phase|order)")


def _classify(name: str, mechanism: Mechanism, excitation: Excitation) -> str:
    """Return what a parameter changes, checking that it names something that exists."""
    if name == "frequency":
        return "frequency"
    head, _, rest = name.partition(".")
    if head in excitation.names:
        match = _HARMONIC.fullmatch(rest)
        if rest in ("phase", "ratio", "theta0") or match:
            if match and not 1 <= int(match.group(1)) <= len(excitation.law(head).harmonics):
                raise ConfigError(f"drive {head!r} has no harmonic {match.group(1)}",
                                  where={"parameter": name},
                                  hint="number harmonics from 1 in the order of the law")
            return "path"
    if head in mechanism.body_names and rest in ("mass", "inertia"):
        return "inertia"
    raise ConfigError(
        f"cannot sweep {name!r}", where={"parameter": name},
        hint="sweep 'frequency' (Hz), '<drive>.phase|ratio|theta0' (rad), "
             "'<drive>.h<k>.amplitude|phase|order', or '<body>.mass|inertia' (kg, kg m2); "
             f"drives: {', '.join(excitation.names)}")


def _apply(name: str, value: float, mechanism: Mechanism, excitation: Excitation
           ) -> tuple[Mechanism, Excitation]:
    """Return mechanism and excitation with parameter ``name`` set to ``value``."""
    if name == "frequency":
        return mechanism, excitation.with_frequency(value)
    head, _, rest = name.partition(".")
    if head in excitation.names and (match := _HARMONIC.fullmatch(rest)) is not None:
        law = excitation.law(head)
        k = int(match.group(1)) - 1
        terms = list(law.harmonics)
        terms[k] = dataclasses.replace(terms[k], **{match.group(2): float(value)})
        return mechanism, excitation.with_law(head, dataclasses.replace(
            law, harmonics=tuple(terms), error=None))
    if head in excitation.names:
        law = dataclasses.replace(excitation.law(head), **{rest: float(value)})
        return mechanism, excitation.with_law(head, law)
    bodies = tuple(dataclasses.replace(b, **{rest: float(value)}) if b.name == head else b
                   for b in mechanism.bodies)
    return dataclasses.replace(mechanism, bodies=bodies), excitation


@dataclass(frozen=True)
class _Needs:
    """Which model outputs a sweep summary needs."""

    position: bool
    acceleration: bool
    forces: bool

    @classmethod
    def of(cls, summary: Sequence[str]) -> _Needs:
        return cls(position="tip_vertical_range" in summary,
                   acceleration="tip_acceleration_peak" in summary,
                   forces=bool(_FORCE_SUMMARIES & set(summary)))

    def outputs(self) -> tuple[str, ...]:
        names = []
        if self.position:
            names.append("point_position")
        if self.acceleration:
            names.append("point_acceleration")
        if self.forces:
            names += ["support_force", "driver_torque"]
        return tuple(names)


@dataclass
class _Basis:
    """Model outputs along one tip path, split so that any frequency and inertia follow exactly.

    ``tip_y`` (n,) does not depend on frequency or inertia; the tip acceleration is
    ``scale * tip_accel`` with ``scale = (f / f0)**2``; support forces (n, pins, 2) and torques
    (n, drivers), flattened to (n, m), are ``constant + sum_j dp_j constant_per_unit[j] +
    scale * (quadratic + sum_j dp_j quadratic_per_unit[j])``, ``dp_j`` the change of swept
    inertia ``j``. With the frequency swept, ``constant`` is the gravity part and ``quadratic``
    the inertial part; otherwise ``constant`` holds everything. ``rate`` (n,) is the cycle
    coordinate's rate at ``frequency`` (rad/s), the time weights of the RMS.
    """

    frequency: float
    rate: np.ndarray
    tip_y: np.ndarray | None
    tip_accel: np.ndarray | None
    constant: np.ndarray | None
    quadratic: np.ndarray | None
    constant_per_unit: dict[str, np.ndarray]
    quadratic_per_unit: dict[str, np.ndarray]


def _support(result: xr.Dataset, pins: Sequence[str]) -> np.ndarray:
    """Return the model's support forces ON THE FRAME at the ground pins, (n, pins, axis), N."""
    if not pins:
        return np.zeros((result.sizes["time"], 0, len(_AXES)))
    return result["support_force"].sel(support=list(pins), axis=list(_AXES)).values


def _flat_forces(result: xr.Dataset, pins: Sequence[str], drivers: Sequence[str]) -> np.ndarray:
    support = _support(result, pins)
    torque = result["driver_torque"].sel(driver=list(drivers)).values
    return np.concatenate([support.reshape(support.shape[0], -1), torque], axis=1)


def _force_parts(result: xr.Dataset, pins: Sequence[str], drivers: Sequence[str], *,
                 split_speed: bool, with_statics: bool) -> tuple[np.ndarray, np.ndarray]:
    """Return the constant and speed-squared parts of support forces and torques of a solve.

    With ``split_speed`` the parts are the static gravity forces (the odd rows of a solve
    ``with_statics``, see :func:`_solve`; zero without gravity) and the inertial rest at the
    excitation's frequency. Without it the frequency is fixed and everything is constant.
    """
    forces = _flat_forces(result, pins, drivers)
    if not split_speed:
        return forces, np.zeros_like(forces)
    if not with_statics:
        return np.zeros_like(forces), forces
    static = forces[1::2]
    return static, forces[0::2] - static


def _basis(mechanism: Mechanism, excitation: Excitation, t: np.ndarray, rate: np.ndarray, *,
           tip: str, pins: Sequence[str], needs: _Needs, split_speed: bool,
           inertia: Sequence[str]) -> tuple[_Basis, int]:
    """Solve the model along one path as often as the superposition needs; return the solves."""
    drivers = mechanism.driver_names
    with_statics = split_speed and needs.forces and mechanism.gravity != (0.0, 0.0)
    result = _solve(mechanism, excitation, t, outputs=needs.outputs(), points=[tip], joints=[],
                    with_statics=with_statics)
    solves = 1
    moving = result.isel(time=slice(None, None, 2)) if with_statics else result
    tip_y = moving["point_position"].sel(point=tip, axis="y").values if needs.position else None
    tip_accel = (moving["point_acceleration"].sel(point=tip, axis=list(_AXES)).values
                 if needs.acceleration else None)
    basis = _Basis(excitation.frequency, rate, tip_y, tip_accel, None, None, {}, {})
    if not needs.forces:
        return basis, solves
    basis.constant, basis.quadratic = _force_parts(result, pins, drivers, split_speed=split_speed,
                                                   with_statics=with_statics)
    for name in inertia:
        reference = _body_value(mechanism, name)
        step = max(abs(reference), 1.0)
        changed, _ = _apply(name, reference + step, mechanism, excitation)
        changed_result = _solve(changed, excitation, t,
                                outputs=("support_force", "driver_torque"), points=[], joints=[],
                                with_statics=with_statics)
        solves += 1
        constant, quadratic = _force_parts(changed_result, pins, drivers,
                                           split_speed=split_speed, with_statics=with_statics)
        basis.constant_per_unit[name] = (constant - basis.constant) / step
        basis.quadratic_per_unit[name] = (quadratic - basis.quadratic) / step
    return basis, solves


def _body_value(mechanism: Mechanism, name: str) -> float:
    """Return the mass or inertia that ``<body>.mass|inertia`` names."""
    body_name, _, attribute = name.partition(".")
    return float(next(getattr(b, attribute) for b in mechanism.bodies if b.name == body_name))


def sweep(mechanism: Mechanism | str | Path, parameters: Mapping[str, npt.ArrayLike], *,
          drives: DriveSpec = None, summary: Sequence[str] = tuple(SUMMARIES),
          n_points: int = 180, tip: str | None = None, main: str | None = None,
          base_dir: Path | None = None) -> xr.Dataset:
    """Evaluate summary quantities over a grid of one or two parameters.

    Parameters are ``frequency`` (Hz, the cycle frequency: main-drive revolutions per second),
    ``<drive>.phase``, ``<drive>.ratio``, ``<drive>.theta0`` (rad), ``<drive>.h<k>.amplitude``,
    ``<drive>.h<k>.phase`` (rad), ``<drive>.h<k>.order``, and ``<body>.mass`` (kg) or
    ``<body>.inertia`` (kg m2).

    Only what the summary needs is computed, and the model is solved once per distinct tip path,
    not once per point. Along a path, positions at a given phase do not depend on the frequency
    ``f``, velocities scale with ``f`` and accelerations with ``f**2``; the inverse dynamics
    ``C_e^T lambda = Q - M e''`` is linear in the masses, inertias and gravity. So with the forces
    at a reference frequency ``f0`` split into a static gravity part and an inertial part (the
    same solve evaluates a zero-speed copy of every step, see ``_solve``), and one more solve per
    swept mass or inertia, every point follows exactly as ``gravity + (f/f0)**2 inertial``, each
    part linear in the swept inertias.

    Parameters
    ----------
    mechanism : Mechanism, str or pathlib.Path
        The mechanism (see :func:`resolve_mechanism`).
    parameters : mapping of str to array_like
        One or two parameter names and their values (the grid is their outer product).
    drives : Excitation, sequence of str, xarray.Dataset or None
        The base excitation (see :func:`make_excitation`).
    summary : sequence of str
        Quantities to evaluate, keys of :data:`SUMMARIES`.
    n_points : int
        Grid points per cycle.
    tip : str, optional
        The tip point; default :func:`default_tip`.
    main : str, optional
        Main drive.
    base_dir : pathlib.Path, optional
        Folder relative profile and law paths are resolved against.

    Returns
    -------
    xarray.Dataset
        One dim per parameter; per point ``tip_vertical_range`` (m), ``tip_acceleration_peak``
        (m s-2), ``support_force_peak`` (support; N, magnitude), ``torque_peak`` and
        ``torque_rms`` (driver; N m), as asked. Attributes ``model_solves``, ``points``,
        ``elapsed_s``.
    """
    started = time.perf_counter()
    mech = resolve_mechanism(mechanism)
    base = make_excitation(mech, drives, main=main, base_dir=base_dir)
    tip = default_tip(mech) if tip is None else tip
    _check_names("point", [tip], mech.point_names)
    unknown = sorted(set(summary) - set(SUMMARIES))
    if unknown or not summary:
        raise ConfigError(f"unknown or empty sweep summary {unknown or list(summary)}",
                          where={"option": "summary"}, hint=f"choose from {', '.join(SUMMARIES)}")
    if not 1 <= len(parameters) <= 2:
        raise ConfigError(f"a sweep varies one or two parameters, got {len(parameters)}",
                          where={"option": "parameters"}, hint="give one or two --sweep options")
    params = []
    for name, values in parameters.items():
        array = np.atleast_1d(np.asarray(values, dtype=float))
        if array.ndim != 1 or array.size == 0 or not np.all(np.isfinite(array)):
            raise ConfigError(f"sweep values of {name!r} must be a non-empty list of numbers",
                              where={"parameter": name}, hint="e.g. 0.5:1.5:11")
        kind = _classify(name, mech, base)
        for value in array if kind == "frequency" else ():
            base.with_frequency(float(value))   # ConfigError outside (0, 1e6] Hz
        if kind == "inertia" and np.any(array < 0):
            raise ConfigError(f"sweep values of {name!r} must not be negative",
                              where={"parameter": name}, hint="give masses in kg, inertias in "
                                                              "kg m2")
        params.append(_Parameter(name, kind, array))
    needs = _Needs.of(summary)
    pins = ground_pins(mech)
    drivers = list(mech.driver_names)
    split_speed = any(p.kind == "frequency" for p in params)
    inertia = [p.name for p in params if p.kind == "inertia"]
    path_params = [p for p in params if p.kind == "path"]
    shape = tuple(p.values.size for p in params)
    out = {name: np.full(shape + _summary_shape(name, pins, drivers), np.nan)
           for name in summary}
    bases: dict[tuple[float, ...], _Basis] = {}
    solves = 0
    for index in itertools.product(*(range(n) for n in shape)):
        values = {p.name: float(p.values[i]) for p, i in zip(params, index, strict=True)}
        key = tuple(values[p.name] for p in path_params)
        if key not in bases:
            path_mech, path_exc = mech, base
            for p in path_params:
                path_mech, path_exc = _apply(p.name, values[p.name], path_mech, path_exc)
            _, t, rate, _ = _cycle_grid(path_exc, n_points)
            bases[key], count = _basis(path_mech, path_exc, t, rate, tip=tip, pins=pins,
                                       needs=needs, split_speed=split_speed, inertia=inertia)
            solves += count
        _fill(out, index, bases[key], values, base, mech, needs, pins)
    ds = xr.Dataset(coords={p.name: (p.name, p.values, _parameter_attrs(p)) for p in params}
                    | {"support": list(pins), "driver": drivers})
    dims = tuple(p.name for p in params)
    for name, data in out.items():
        extra = () if data.ndim == len(dims) else (("support",) if "support" in name
                                                  else ("driver",))
        unit, text = SUMMARIES[name]
        ds[name] = (dims + extra, data, {"units": unit, "long_name": text})
    elapsed = time.perf_counter() - started
    ds.attrs.update({
        "title": f"rigval sweep: {mech.name}", "mechanism": mech.name,
        "mechanism_source": mech.source, "tip_point": tip, "n_points": n_points,
        "points": int(np.prod(shape)), "model_solves": solves, "elapsed_s": elapsed,
        "drive_laws": "\n".join(_law_descriptions(base)),
    })
    logger.info("swept %d points with %d model solves in %.3g s", int(np.prod(shape)), solves,
                elapsed)
    return ds


def _summary_shape(name: str, pins: Sequence[str], drivers: Sequence[str]) -> tuple[int, ...]:
    if name == "support_force_peak":
        return (len(pins),)
    if name in ("torque_peak", "torque_rms"):
        return (len(drivers),)
    return ()


def _parameter_attrs(param: _Parameter) -> dict[str, str]:
    if param.kind == "frequency":
        return {"units": "Hz", "long_name": "cycle frequency (main-drive revolutions per s)"}
    if param.kind == "inertia":
        return {"units": "kg" if param.name.endswith("mass") else "kg m2",
                "long_name": param.name}
    unit = "1" if param.name.endswith(("ratio", "order")) else "rad"
    return {"units": unit, "long_name": param.name}


def _fill(out: dict[str, np.ndarray], index: tuple[int, ...], basis: _Basis,
          values: Mapping[str, float], base: Excitation, mechanism: Mechanism, needs: _Needs,
          pins: Sequence[str]) -> None:
    """Compute one sweep point's summaries from its path's basis."""
    frequency = values.get("frequency", base.frequency)
    scale = (frequency / basis.frequency) ** 2
    if "tip_vertical_range" in out and basis.tip_y is not None:
        out["tip_vertical_range"][index] = np.max(basis.tip_y) - np.min(basis.tip_y)
    if "tip_acceleration_peak" in out and basis.tip_accel is not None:
        out["tip_acceleration_peak"][index] = scale * np.max(np.hypot(basis.tip_accel[:, 0],
                                                                      basis.tip_accel[:, 1]))
    if not needs.forces or basis.constant is None or basis.quadratic is None:
        return
    constant, quadratic = basis.constant.copy(), basis.quadratic.copy()
    for name, per_unit in basis.constant_per_unit.items():
        change = values[name] - _body_value(mechanism, name)
        constant += change * per_unit
        quadratic += change * basis.quadratic_per_unit[name]
    forces = constant + scale * quadratic
    n_support = 2 * len(pins)
    support = forces[:, :n_support].reshape(forces.shape[0], len(pins), 2)
    torque = forces[:, n_support:]
    if "support_force_peak" in out:
        out["support_force_peak"][index] = np.max(np.hypot(support[..., 0], support[..., 1]),
                                                  axis=0)
    if "torque_peak" in out:
        out["torque_peak"][index] = np.max(np.abs(torque), axis=0)
    if "torque_rms" in out:
        out["torque_rms"][index] = _time_rms(torque, basis.rate)


def parse_sweep_option(text: str) -> tuple[str, np.ndarray]:
    """Parse a ``NAME=START:STOP:COUNT[UNIT]`` or ``NAME=V1,V2,...[UNIT]`` sweep option.

    ``START:STOP:COUNT`` gives ``COUNT`` evenly spaced values including both ends. ``UNIT`` is
    one of ``rad``, ``deg``, ``Hz``, ``rev/s``, ``rpm``, ``kg``, ``kgm2`` (default SI: rad, Hz),
    anything else is an error;
    values are returned in SI units (rad, Hz).

    Parameters
    ----------
    text : str
        The option, e.g. ``frequency=0.5:1.5:11`` or ``theta_H.phase=0:330:12deg``.

    Returns
    -------
    name : str
        The parameter name.
    values : numpy.ndarray
        The values, SI units.
    """
    name, sep, spec = (part.strip() for part in text.partition("="))
    hint = "write e.g. frequency=0.5:1.5:11 or theta_H.phase=0:330:12deg or A.mass=300,400"
    if not sep or not name or not spec:
        raise ConfigError(f"cannot read the sweep option {text!r}", where={"option": text},
                          hint=hint)
    unit = next((u for u in sorted(_SWEEP_UNITS, key=len, reverse=True)
                 if u and spec.lower().endswith(u)), "")
    numbers = spec[:len(spec) - len(unit)].strip()
    try:
        if ":" in numbers:
            start, stop, count = numbers.split(":")
            if int(count) < 1:
                raise ValueError(count)
            values = np.linspace(float(start), float(stop), int(count))
        else:
            values = np.array([float(v) for v in numbers.split(",")])
        if not np.all(np.isfinite(values)):
            raise ValueError(numbers)
    except ValueError:
        raise ConfigError(f"cannot read the values of sweep option {text!r} (units: "
                          f"{', '.join(u for u in _SWEEP_UNITS if u)})",
                          where={"option": text}, hint=hint) from None
    return name, values * _SWEEP_UNITS[unit]
