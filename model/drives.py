"""Drive angles and their first and second time derivatives: analytic laws or sampled signals.

A driver prescribes its body's absolute angle. The file's law is
``theta(t) = theta0 + omega t + sum(a_k sin(omega_k t + phase_k))``; a caller may instead pass
sampled angles with their derivatives (what processing identifies from the encoders).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from rigval.acquisition.errors import ChannelNotFoundError, ConfigError, DataError

if TYPE_CHECKING:
    from rigval.model.mechanism import Driver, Mechanism

__all__ = ["DriveMotion", "cycle_period", "drive_motion", "law_motion", "times_at_angles"]

logger = logging.getLogger(__name__)

#: A driver given as samples: (theta [rad], omega [rad/s], alpha [rad/s2]) on the solve times.
SampledDrive = Sequence[np.ndarray] | np.ndarray


@dataclass(frozen=True)
class DriveMotion:
    """Driven angles and their derivatives at every time step, one column per driver.

    Attributes
    ----------
    theta : numpy.ndarray
        (n_times, n_drivers), rad.
    omega : numpy.ndarray
        (n_times, n_drivers), rad/s.
    alpha : numpy.ndarray
        (n_times, n_drivers), rad/s2.
    """

    theta: np.ndarray
    omega: np.ndarray
    alpha: np.ndarray


def law_motion(driver: Driver, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Evaluate a driver's analytic law and its derivatives.

    Parameters
    ----------
    driver : Driver
        The driver.
    t : numpy.ndarray
        Times, s.

    Returns
    -------
    theta, omega, alpha : numpy.ndarray
        Angle (rad), angular speed (rad/s) and angular acceleration (rad/s2) at ``t``.
    """
    theta = driver.theta0 + driver.omega * t
    omega = np.full_like(t, driver.omega)
    alpha = np.zeros_like(t)
    for term in driver.harmonics:
        arg = term.omega * t + term.phase
        sin, cos = np.sin(arg), np.cos(arg)
        theta = theta + term.amplitude * sin
        omega = omega + term.amplitude * term.omega * cos
        alpha = alpha - term.amplitude * term.omega**2 * sin
    return theta, omega, alpha


def drive_motion(mechanism: Mechanism, t: np.ndarray,
                 drives: Mapping[str, SampledDrive] | None = None) -> DriveMotion:
    """Driven angles and derivatives at ``t``: sampled where given, the file's law otherwise.

    Parameters
    ----------
    mechanism : Mechanism
        The mechanism.
    t : numpy.ndarray
        Times, s, shape (n,).
    drives : mapping, optional
        Driver name -> ``(theta, omega, alpha)``, each an array of shape (n,) on ``t`` (rad, rad/s,
        rad/s2). Drivers not named use the file's law.

    Returns
    -------
    DriveMotion
    """
    drives = dict(drives or {})
    unknown = sorted(set(drives) - set(mechanism.driver_names))
    if unknown:
        raise ChannelNotFoundError(f"no driver named {unknown[0]!r}",
                                   where={"file": mechanism.source, "key": "drives"},
                                   available=list(mechanism.driver_names))
    columns = []
    for driver in mechanism.drivers:
        if driver.name in drives:
            columns.append(_sampled(driver.name, drives[driver.name], t.shape[0]))
        else:
            columns.append(law_motion(driver, t))
    if not columns:
        empty = np.zeros((t.shape[0], 0))
        return DriveMotion(empty, empty, empty)
    theta, omega, alpha = (np.stack([c[i] for c in columns], axis=-1) for i in range(3))
    return DriveMotion(theta, omega, alpha)


def _sampled(name: str, value: SampledDrive, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Check a sampled drive: three finite float arrays of length n."""
    where = {"key": f"drives[{name!r}]"}
    if len(value) != 3:
        raise ConfigError(f"drive {name!r} must be (theta, omega, alpha), got {len(value)} arrays",
                          where=where, hint="pass angle, angular speed and acceleration arrays")
    arrays = tuple(np.asarray(v, dtype=float) for v in value)
    for label, array in zip(("theta", "omega", "alpha"), arrays, strict=True):
        if array.shape != (n,):
            raise DataError(f"drive {name!r} {label} has shape {array.shape}, expected ({n},)",
                            where=where, hint="sample every drive on the solve times t")
        if not np.all(np.isfinite(array)):
            bad = int(np.argmax(~np.isfinite(array)))
            raise DataError(f"drive {name!r} {label} is not finite at index {bad}", where=where,
                            hint="remove or fill invalid samples before solving")
    return arrays[0], arrays[1], arrays[2]


def cycle_period(mechanism: Mechanism, driver: str | None = None) -> tuple[Driver, float]:
    """Return the main driver and its period, checking that every drive law repeats with it.

    Parameters
    ----------
    mechanism : Mechanism
        The mechanism.
    driver : str, optional
        The main driver (default: the first one).

    Returns
    -------
    main : Driver
        The main driver.
    period : float
        Time of one revolution of the main driver, s.

    Raises
    ------
    ConfigError
        Unknown driver, a main drive that does not turn steadily in one direction, or drive laws
        that do not repeat with the main drive's revolution.
    """
    if not mechanism.drivers:
        raise ConfigError("the mechanism has no driver", where={"file": mechanism.source},
                          hint="a cycle is one revolution of a driver; add [[drivers]]")
    if driver is None:
        main = mechanism.drivers[0]
    else:
        matches = [d for d in mechanism.drivers if d.name == driver]
        if not matches:
            raise ChannelNotFoundError(f"no driver named {driver!r}", where={"key": "driver"},
                                       available=list(mechanism.driver_names))
        main = matches[0]
    swing = sum(abs(h.amplitude * h.omega) for h in main.harmonics)
    if main.omega <= swing:
        raise ConfigError(
            f"driver {main.name!r} does not turn steadily forward (omega {main.omega} rad/s, "
            f"harmonics can slow it by up to {swing} rad/s)", where={"key": "driver"},
            hint="choose a driver with positive mean speed larger than its harmonics' swing")
    period = 2.0 * math.pi / main.omega
    for other in mechanism.drivers:
        for label, freq in [("omega", other.omega)] + [
                (f"harmonics[{i}].omega", h.omega) for i, h in enumerate(other.harmonics)]:
            turns = freq * period / (2.0 * math.pi)
            if abs(turns - round(turns)) > 1e-9 * max(1.0, abs(turns)):
                raise ConfigError(
                    f"driver {other.name!r} {label} = {freq} rad/s does not repeat with one "
                    f"revolution of {main.name!r} ({period} s): {turns} turns per revolution",
                    where={"file": mechanism.source, "key": f"drivers.{other.name}.{label}"},
                    hint="evaluate at the sample times with solve() instead of solve_cycle()")
    return main, period


def times_at_angles(main: Driver, angles: np.ndarray, origin: float) -> np.ndarray:
    """Invert the main drive law: times t at which ``theta(t) = origin + angle``.

    Parameters
    ----------
    main : Driver
        A driver that turns steadily forward (see :func:`cycle_period`).
    angles : numpy.ndarray
        Angles past ``origin``, rad.
    origin : float
        Angle of the main driver's body at angle 0, rad.

    Returns
    -------
    numpy.ndarray
        Times, s, accurate to a few ulp.
    """
    target = origin + np.asarray(angles, dtype=float)
    t = (target - main.theta0) / main.omega
    for _ in range(50):
        theta, omega, _alpha = law_motion(main, t)
        step = (theta - target) / omega
        t = t - step
        if np.all(np.abs(step) <= 4e-16 * np.maximum(1.0, np.abs(t))):
            break
    return t
