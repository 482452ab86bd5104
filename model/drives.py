"""Drive angles and their first and second time derivatives on the solve times.

A driver prescribes its body's absolute angle: by the file's law (evaluated by
:class:`~rigval.model.laws.DriveLaw`), or by sampled angles with their derivatives that a caller
passes (what processing identifies from the encoders).
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

__all__ = ["DriveSamples", "cycle_period", "drive_motion", "law_angles_at_reference"]

logger = logging.getLogger(__name__)

#: A driver given as samples: (theta [rad], omega [rad/s], alpha [rad/s2]) on the solve times.
SampledDrive = Sequence[np.ndarray] | np.ndarray


@dataclass(frozen=True)
class DriveSamples:
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


def drive_motion(mechanism: Mechanism, t: np.ndarray,
                 drives: Mapping[str, SampledDrive] | None = None) -> DriveSamples:
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
    DriveSamples
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
            columns.append(driver.motion(t))
    if not columns:
        empty = np.zeros((t.shape[0], 0))
        return DriveSamples(empty, empty, empty)
    theta, omega, alpha = (np.stack([c[i] for c in columns], axis=-1) for i in range(3))
    return DriveSamples(theta, omega, alpha)


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
    name = mechanism.drivers[0].name if mechanism.drivers and driver is None else driver
    if name is not None and name not in mechanism.driver_names:
        raise ChannelNotFoundError(f"no driver named {name!r}", where={"key": "driver"},
                                   available=list(mechanism.driver_names))
    excitation = mechanism.excitation(name)
    main = mechanism.drivers[mechanism.driver_names.index(excitation.main)]
    law = excitation.law(main.name)
    slowest = law.slowest_rate() * excitation.omega
    if law.ratio != 1.0 or slowest <= 0.0:
        raise ConfigError(
            f"driver {main.name!r} does not turn steadily forward (omega {main.omega} rad/s, "
            f"slowest speed {slowest:.4g} rad/s)",
            where={"file": mechanism.source, "key": f"drivers.{main.name}.omega"} if driver is None
            else {"key": "driver"},
            hint="choose a driver with positive mean speed larger than its harmonics' swing")
    period = 2.0 * math.pi / excitation.omega
    for other, other_law in excitation.laws:
        for label, turns in [("omega", other_law.ratio)] + [
                (f"harmonics[{i}].omega", h.order) for i, h in enumerate(other_law.harmonics)]:
            if abs(turns - round(turns)) > 1e-9 * max(1.0, abs(turns)):
                raise ConfigError(
                    f"driver {other!r} {label} = {turns * excitation.omega} rad/s does not repeat "
                    f"with one revolution of {main.name!r} ({period} s): {turns} turns per "
                    "revolution",
                    where={"file": mechanism.source, "key": f"drivers.{other}.{label}"},
                    hint="evaluate at the sample times with solve() instead of solve_cycle()")
    return main, period


def law_angles_at_reference(mechanism: Mechanism) -> dict[str, float]:
    """Each driver's law angle (rad, in [0, 2 pi)) when the main driver passes its ``theta0``.

    The estimate of ``angle_at_reference`` when the main reference pulse fires at the main
    driver's law origin (the rig's reference position is the mechanism file's t = 0 position);
    check it against the rig.

    Parameters
    ----------
    mechanism : Mechanism
        The mechanism (its first driver is the main one).

    Returns
    -------
    dict of str to float
        Driver name to its angle, rad; empty without drivers.
    """
    if not mechanism.drivers:
        return {}
    main = mechanism.drivers[0]
    t_ref = main.times_at(np.array([main.theta0]))
    return {d.name: float(np.mod(d.motion(t_ref)[0][0], 2.0 * math.pi))
            for d in mechanism.drivers}
