"""Drive laws: one harmonic term, one drive's law, and the laws of all drives of a mechanism.

Every drive angle is written against the cycle phase ``tau = Omega t`` of the main drive, where
``Omega = 2 pi f`` and ``f`` is the cycle frequency (Hz, main-drive revolutions per second):

    theta(t) = theta0 + phase + ratio * tau + sum_k amplitude_k sin(order_k tau + phase_k)

``ratio`` is the drive's speed ratio to the main drive (1 for the main drive itself, 2 for the
pendulum's lifting drive), ``phase`` (rad) shifts the drive's angle against the main drive, and the
harmonic orders count multiples of the cycle frequency. Because the law is written against the
phase, changing the frequency keeps the shape of every profile over a cycle.

This module evaluates a law (:meth:`DriveLaw.at_phase`, :meth:`DriveLaw.evaluate`), inverts it
(:meth:`DriveLaw.phase_at`) and decides whether it turns steadily (:meth:`DriveLaw.slowest_rate`);
the mechanism file's drivers (:mod:`rigval.model.mechanism`), prediction
(:mod:`rigval.model.predict`) and the virtual rig (:mod:`rigval.sample_data.drive`) all use it.
Reading laws from tables, profiles and measured runs is :mod:`rigval.model.drive_laws`.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from rigval.acquisition.errors import ChannelNotFoundError, ConfigError
from rigval.model.errors import ModelError

if TYPE_CHECKING:
    import xarray as xr

__all__ = [
    "MAX_FREQUENCY_HZ",
    "DriveLaw",
    "Excitation",
    "FitUncertainty",
    "Harmonic",
    "check_frequency",
    "cycle_rate",
    "excitation_from_drivers",
    "law_from_rates",
]

logger = logging.getLogger(__name__)

#: Largest cycle frequency accepted, Hz: far beyond any machine a rigid-body model describes, and
#: small enough that speeds and accelerations (2 pi f)**2 stay far from overflow.
MAX_FREQUENCY_HZ = 1e6

#: Newton iterations of :meth:`DriveLaw.phase_at`; quadratic convergence needs about 5 from the
#: start it takes, the rest is a margin for steep harmonics.
_NEWTON_STEPS = 50
#: Grid points per cycle of :meth:`DriveLaw.slowest_rate` at most (refined 4x per round).
_MAX_RATE_GRID = 1 << 20


@dataclass(frozen=True)
class Harmonic:
    """One harmonic term ``amplitude sin(order tau + phase)`` of a drive law.

    Parameters
    ----------
    amplitude : float
        Amplitude, rad.
    order : float
        Frequency as a multiple of the cycle frequency (1 = once per main-drive revolution).
    phase : float
        Phase at tau = 0, rad.
    """

    amplitude: float
    order: float
    phase: float = 0.0


@dataclass(frozen=True)
class FitUncertainty:
    """Stated error of a law fitted to samples, per unit of cycle phase.

    The error of the angle, speed and acceleration at frequency ``Omega`` (rad/s) is ``angle``,
    ``speed * Omega`` and ``acceleration * Omega**2``. Each is the maximum over the cycle of
    :data:`rigval.model.drive_laws.NOISE_COVERAGE` standard deviations of the sample noise
    propagated through the least-squares fit, plus the truncation estimate (what the next
    harmonics above the fitted order add) and floating-point round-off.

    Parameters
    ----------
    angle : float
        Error of the angle, rad.
    speed : float
        Error of ``d theta / d tau``, rad per rad of cycle phase.
    acceleration : float
        Error of ``d2 theta / d tau2``, rad per rad**2 of cycle phase.
    residual_rms : float
        Root mean square of the fit residual, rad (the estimated sample noise).
    order : int
        Number of harmonics kept.
    samples : int
        Number of samples fitted.
    """

    angle: float
    speed: float
    acceleration: float
    residual_rms: float
    order: int
    samples: int

    def at(self, omega: float) -> tuple[float, float, float]:
        """Return the errors of angle (rad), speed (rad/s) and acceleration (rad/s**2) at ``omega``.

        Parameters
        ----------
        omega : float
            Cycle angular frequency, rad/s.
        """
        return self.angle, self.speed * abs(omega), self.acceleration * omega**2


@dataclass(frozen=True)
class DriveLaw:
    """The angle of one drive over the cycle (see the module docstring for the formula).

    Parameters
    ----------
    theta0 : float
        Angle offset of the law, rad.
    ratio : float
        Constant speed as a multiple of the cycle angular frequency (1 for the main drive).
    phase : float
        Angle added to the whole law, rad: shifts this drive against the main drive.
    harmonics : tuple of Harmonic
        Harmonic terms.
    source : str
        Where the law came from (``"mechanism file"``, a CSV path, ``"command line"``, ...).
    error : FitUncertainty, optional
        Stated error when the law was fitted to samples; None for an exact law.
    """

    theta0: float
    ratio: float = 1.0
    phase: float = 0.0
    harmonics: tuple[Harmonic, ...] = ()
    source: str = "mechanism file"
    error: FitUncertainty | None = None

    def at_phase(self, tau: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return the angle (rad) and its first and second derivatives in the cycle phase.

        Parameters
        ----------
        tau : array_like
            Cycle phase, rad.

        Returns
        -------
        theta, dtheta, ddtheta : numpy.ndarray
            ``theta(tau)`` (rad), ``d theta / d tau`` (1) and ``d2 theta / d tau2`` (rad-1).
        """
        tau = np.asarray(tau, dtype=float)
        theta = self.theta0 + self.phase + self.ratio * tau
        slope = np.full_like(tau, self.ratio)
        curvature = np.zeros_like(tau)
        for term in self.harmonics:
            arg = term.order * tau + term.phase
            sin, cos = np.sin(arg), np.cos(arg)
            theta = theta + term.amplitude * sin
            slope = slope + term.amplitude * term.order * cos
            curvature = curvature - term.amplitude * term.order**2 * sin
        return theta, slope, curvature

    def evaluate(self, t: npt.ArrayLike, omega: float
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return angle (rad), speed (rad/s) and acceleration (rad/s**2) at times ``t``.

        Parameters
        ----------
        t : array_like
            Times, s.
        omega : float
            Cycle angular frequency, rad/s (the phase is ``tau = omega t``).
        """
        theta, slope, curvature = self.at_phase(omega * np.asarray(t, dtype=float))
        return theta, slope * omega, curvature * omega**2

    def phase_at(self, angles: npt.ArrayLike) -> np.ndarray:
        """Invert the law: the cycle phases tau (rad) at which ``theta(tau) = angles``.

        Newton's method from ``(angle - theta0 - phase) / ratio``; the law must turn steadily
        (:meth:`slowest_rate` > 0), so each angle is reached once.

        Parameters
        ----------
        angles : array_like
            Unwrapped angles, rad.

        Returns
        -------
        numpy.ndarray
            Phases, rad, same shape as ``angles``, accurate to a few ulp of the phase.

        Raises
        ------
        ModelError
            If the iteration does not settle (a law that stops or reverses).
        """
        target = np.asarray(angles, dtype=float)
        if self.ratio == 0.0:
            raise ModelError("a drive law without a constant speed (ratio 0) cannot be inverted",
                             where={"source": self.source},
                             hint="invert the main drive, which turns once per cycle")
        tau = (target - self.theta0 - self.phase) / self.ratio
        for _ in range(_NEWTON_STEPS):
            theta, slope, _ = self.at_phase(tau)
            step = (theta - target) / slope
            tau = tau - step
            # 4 ulp of the phase: the step has reached the rounding of theta itself.
            if np.all(np.abs(step) <= 4e-16 * np.maximum(1.0, np.abs(tau))):
                return tau
        worst = float(np.max(np.abs(step)))
        if not worst <= 1e-9 * max(1.0, float(np.max(np.abs(tau)))):
            raise ModelError(f"inverting the drive law did not converge (last step {worst:.3g} "
                             "rad of phase)", where={"source": self.source},
                             hint="the drive must turn steadily: keep its harmonics' slope "
                                  "below its speed ratio")
        return tau

    def slowest_rate(self) -> float:
        """Return a lower bound of the slowest ``|d theta / d tau|`` over one cycle (1).

        The rate is evaluated on a grid of step ``h`` over ``[0, 2 pi]``; between grid points it
        can dip at most ``h / 2 * sum |amplitude| order**2`` (its slope's bound) below the grid's
        minimum. The grid is refined until the bound is positive or a grid value is not; a
        positive result guarantees that the drive neither stops nor reverses, so that
        :meth:`phase_at` has one solution per angle. (A bound from the harmonics alone,
        ``|ratio| > sum |amplitude| order``, refuses steady laws whose harmonics never peak
        together; a grid alone can miss a narrow dip between its points.)

        Returns
        -------
        float
            Lower bound of the slowest rate in the turning direction; <= 0 where the law stops or
            reverses, or comes within the rounding of it.
        """
        if not self.harmonics:
            return abs(self.ratio)
        direction = math.copysign(1.0, self.ratio) if self.ratio else 1.0
        slope_bound = sum(abs(h.amplitude) * h.order**2 for h in self.harmonics)
        highest = max(abs(h.order) for h in self.harmonics)
        n = max(256, 16 * math.ceil(highest))
        while True:
            _, slope, _ = self.at_phase(np.linspace(0.0, 2.0 * math.pi, n + 1))
            lowest = float(np.min(direction * slope))
            bound = lowest - math.pi / n * slope_bound
            if lowest <= 0.0:
                return lowest
            if bound > 0.0 or n >= _MAX_RATE_GRID:
                return bound
            n *= 4


@dataclass(frozen=True)
class Excitation:
    """The laws of every drive of a mechanism, sharing one cycle frequency.

    Parameters
    ----------
    frequency : float
        Cycle frequency, Hz (main-drive revolutions per second for a main drive of ratio 1).
    laws : tuple of (str, DriveLaw)
        Drive name and its law, in the mechanism's driver order.
    main : str
        Name of the main drive, whose angle is the cycle's reference (phi_F).
    """

    frequency: float
    laws: tuple[tuple[str, DriveLaw], ...]
    main: str

    def __post_init__(self) -> None:
        # (2 pi f)**2 of a frequency beyond the maximum overflows, or nearly, in the solver
        check_frequency(self.frequency, "frequency")

    @property
    def omega(self) -> float:
        """Cycle angular frequency, rad/s."""
        return 2.0 * math.pi * self.frequency

    @property
    def period(self) -> float:
        """Cycle period, s."""
        return 1.0 / self.frequency

    @property
    def names(self) -> tuple[str, ...]:
        """Drive names in order."""
        return tuple(name for name, _ in self.laws)

    def law(self, name: str) -> DriveLaw:
        """Return the law of drive ``name`` (ChannelNotFoundError when there is none)."""
        for law_name, law in self.laws:
            if law_name == name:
                return law
        raise ChannelNotFoundError(f"no drive named {name!r}", where={"drive": name},
                                   hint="use one of the mechanism's driver names",
                                   available=list(self.names))

    def with_law(self, name: str, law: DriveLaw) -> Excitation:
        """Return a copy with drive ``name``'s law replaced."""
        self.law(name)
        laws = tuple((n, law if n == name else old) for n, old in self.laws)
        return dataclasses.replace(self, laws=laws)

    def with_frequency(self, frequency: float) -> Excitation:
        """Return a copy running at cycle frequency ``frequency`` (Hz), profiles unchanged."""
        check_frequency(frequency, "frequency")
        return dataclasses.replace(self, frequency=float(frequency))

    def with_main(self, name: str) -> Excitation:
        """Return the same motion written against drive ``name``'s cycle.

        The cycle rate becomes that drive's ``|ratio|`` (else its first harmonic's order) times
        the present one; every ratio and order is divided by it, so all angles at every time stay
        the same (exactly so when the rate does not change).

        Raises
        ------
        ConfigError
            If drive ``name`` does not move (ratio 0 and no harmonics).
        """
        law = self.law(name)
        rate = abs(law.ratio) or next((abs(h.order) for h in law.harmonics if h.order), 0.0)
        if rate == 0.0:
            raise ConfigError(f"the main drive {name!r} does not move (omega 0, no harmonics)",
                              where={"key": f"drivers.{name}.omega"},
                              hint="give the main drive a constant speed")
        if rate == 1.0:
            return dataclasses.replace(self, main=name)
        laws = tuple((n, dataclasses.replace(
            old, ratio=old.ratio / rate,
            harmonics=tuple(dataclasses.replace(h, order=h.order / rate) for h in old.harmonics)))
            for n, old in self.laws)
        return Excitation(frequency=self.frequency * rate, laws=laws, main=name)

    def evaluate(self, t: npt.ArrayLike) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """Return, per drive, angle (rad), speed (rad/s), acceleration (rad/s**2) at ``t`` (s)."""
        return {name: law.evaluate(t, self.omega) for name, law in self.laws}

    def to_dataset(self, t: npt.ArrayLike) -> xr.Dataset:
        """Return the drive angles and derivatives at times ``t`` (s) as a Dataset.

        Variables ``<drive>`` (rad), ``<drive>_dot`` (rad s-1) and ``<drive>_ddot``
        (rad s-2) along dim ``time``: the form processing identifies from encoders, and the form
        :func:`rigval.model.drive_laws.excitation_from_measured` reads.
        """
        import xarray as xr

        t = np.asarray(t, dtype=float)
        data: dict[str, Any] = {}
        for name, (theta, speed, accel) in self.evaluate(t).items():
            data[name] = ("time", theta, {"units": "rad", "long_name": f"{name} drive angle"})
            data[f"{name}_dot"] = ("time", speed, {"units": "rad s-1",
                                                     "long_name": f"{name} angular speed"})
            data[f"{name}_ddot"] = ("time", accel, {
                "units": "rad s-2", "long_name": f"{name} angular acceleration"})
        coords = {"time": ("time", t, {"units": "s", "long_name": "time from cycle start"})}
        return xr.Dataset(data, coords=coords)

    def cycle_times(self, n_points: int) -> tuple[np.ndarray, np.ndarray]:
        """Return the times (s) at which the main drive has turned ``2 pi j / n_points``.

        Parameters
        ----------
        n_points : int
            Number of grid points over one cycle (the end point 2 pi is left out).

        Returns
        -------
        angle : ndarray
            Main-drive angle from its position at t = 0, rad, in [0, 2 pi).
        time : ndarray
            Times at which the main drive reaches ``angle``, s.

        Raises
        ------
        ConfigError
            If the main drive stops or reverses within the cycle, so that its angle cannot serve as
            the cycle coordinate.
        """
        if n_points < 4:
            raise ConfigError(f"a cycle needs at least 4 points, got {n_points}",
                              where={"option": "n_points"}, hint="use 360 or more points")
        law = self.law(self.main)
        if not self.turns_steadily():
            slowest = law.slowest_rate() * self.omega if abs(law.ratio) == 1.0 else 0.0
            raise ConfigError(
                f"the main drive {self.main!r} must turn once per cycle without stopping "
                f"(ratio {law.ratio:g}, slowest speed {slowest:.4g} rad/s)",
                where={"drive": self.main},
                hint="choose as main drive one that turns continuously, with harmonic "
                     "amplitudes small enough that its speed stays positive")
        angle = 2.0 * math.pi * np.arange(n_points) / n_points
        start = float(law.at_phase(np.zeros(1))[0][0])
        tau = law.phase_at(start + math.copysign(1.0, law.ratio) * angle)
        return angle, tau / self.omega

    def turns_steadily(self) -> bool:
        """Return whether the main drive turns once per cycle without stopping or reversing.

        Only then can its angle serve as the cycle coordinate (:meth:`cycle_times`); the test is
        :meth:`DriveLaw.slowest_rate`.
        """
        law = self.law(self.main)
        return abs(law.ratio) == 1.0 and law.slowest_rate() > 0.0


def check_frequency(value: Any, key: str) -> float:
    """Return a cycle frequency (Hz) after checking it: positive, finite, at most the maximum.

    Raises
    ------
    ConfigError
        Naming ``key`` when the value is not a number in (0, :data:`MAX_FREQUENCY_HZ`].
    """
    if not isinstance(value, int | float) or isinstance(value, bool) or not value > 0 \
            or not math.isfinite(value) or value > MAX_FREQUENCY_HZ:
        raise ConfigError(f"the cycle frequency must be a positive number of Hz up to "
                          f"{MAX_FREQUENCY_HZ:g}, got {value!r}",
                          where={"key": key}, hint="give main-drive turns per second, e.g. 1.0")
    return float(value)


def excitation_from_drivers(drivers: Iterable[tuple[str, float, float,
                                                    Sequence[tuple[float, float, float]]]],
                            *, main: str | None = None) -> Excitation:
    """Return the excitation of a mechanism file's ``harmonic`` drivers.

    Parameters
    ----------
    drivers : iterable of (name, theta0, omega, harmonics)
        Per driver: name, ``theta0`` (rad), constant speed ``omega`` (rad/s) and harmonics as
        ``(amplitude rad, omega rad/s, phase rad)``, i.e.
        ``theta(t) = theta0 + omega t + sum amplitude sin(omega_k t + phase)``.
    main : str, optional
        Name of the main drive; default the first driver.

    Returns
    -------
    Excitation
        The same laws written against the main drive's cycle (exact, no refit).

    Raises
    ------
    ConfigError
        If the main drive has neither a constant speed nor a harmonic (no cycle to speak of).
    """
    drivers = list(drivers)
    if not drivers:
        raise ConfigError("the mechanism has no drivers", hint="add a [[drivers]] table")
    main = drivers[0][0] if main is None else main
    rows = {name: (omega, harmonics) for name, _theta0, omega, harmonics in drivers}
    if main not in rows:
        raise ChannelNotFoundError(f"no driver named {main!r}", where={"drive": main},
                                   hint="name one of the mechanism's drivers as main",
                                   available=list(rows))
    cycle_omega = cycle_rate(*rows[main])
    if cycle_omega == 0.0:
        raise ConfigError(f"the main drive {main!r} does not move (omega 0, no harmonics)",
                          where={"key": f"drivers.{main}.omega"},
                          hint="give the main drive a constant speed")
    laws = tuple((name, law_from_rates(theta0, omega, harmonics, cycle_omega))
                 for name, theta0, omega, harmonics in drivers)
    return Excitation(frequency=cycle_omega / (2.0 * math.pi), laws=laws, main=main)


def cycle_rate(omega: float, harmonics: Sequence[tuple[float, float, float]]) -> float:
    """Return the cycle angular frequency (rad/s) a main drive sets.

    That is ``|omega|``, else the first harmonic's ``|omega_k|``, else 0 (a drive that does not
    move).
    """
    return abs(omega) or next((abs(h[1]) for h in harmonics if h[1]), 0.0)


def law_from_rates(theta0: float, omega: float, harmonics: Sequence[tuple[float, float, float]],
                   cycle_omega: float) -> DriveLaw:
    """Return ``theta0 + omega t + sum amplitude sin(omega_k t + phase)`` as a cycle law.

    Parameters
    ----------
    theta0 : float
        Angle at t = 0 without the harmonics, rad.
    omega : float
        Constant speed, rad/s.
    harmonics : sequence of (amplitude, omega_k, phase)
        rad, rad/s, rad.
    cycle_omega : float
        Cycle angular frequency the law is written against, rad/s (> 0).
    """
    terms = tuple(Harmonic(float(a), float(w) / cycle_omega, float(p)) for a, w, p in harmonics)
    return DriveLaw(theta0=float(theta0), ratio=float(omega) / cycle_omega, harmonics=terms)
