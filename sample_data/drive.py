"""The true drive motion of the virtual rig: both drive angles as smooth, analytic laws of time.

The main shaft turns at a set speed with a slow, random wander (so no two cycles last exactly as
long) and a ripple that repeats with the shaft angle. Both drives follow one *base phase*

``psi(t) = Omega t + Omega sum_j eps_j (cos(phi_j) - cos(w_j t + phi_j)) / w_j``

whose speed is ``Omega (1 + sum_j eps_j sin(w_j t + phi_j))``; the drive angles are

``theta_F = theta_F0 + psi + sum_k a_k sin(k psi + p_k)``,
``theta_H = theta_H0 + 2 psi + sum_k c_k sin(k psi + q_k)``

(the lifting shaft turns twice per main revolution). With no wander and one harmonic each this is
exactly the harmonic law of ``pendulum.toml``. Every derivative is analytic, so the model sees
the exact velocities and accelerations of the motion the encoders count.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from rigval.model.laws import DriveLaw, Harmonic
from rigval.processing.arrays import FloatArray

__all__ = ["DriveMotion", "Harmonic", "SpeedWander"]

logger = logging.getLogger(__name__)

_TWO_PI = 2.0 * np.pi


@dataclass(frozen=True)
class SpeedWander:
    """One slow component ``rel_amplitude sin(omega t + phase)`` of the relative speed wander.

    Parameters
    ----------
    omega : float
        Angular frequency in rad/s (incommensurate with the shaft speed).
    rel_amplitude : float
        Relative speed amplitude (1), e.g. 0.004 for 0.4 %.
    phase : float
        Phase in rad.
    """

    omega: float
    rel_amplitude: float
    phase: float


@dataclass(frozen=True)
class DriveMotion:
    """True motion of the main (theta_F) and lifting (theta_H) drives.

    Parameters
    ----------
    speed : float
        Mean main-shaft speed in rev/s.
    theta_f0, theta_h0 : float
        Drive angles at ``psi = 0`` in rad (the reference position of each shaft).
    ripple_f, ripple_h : tuple of Harmonic
        Angle ripple of each drive, periodic in psi (:class:`rigval.model.laws.Harmonic`, orders
        of the base phase psi).
    wander : tuple of SpeedWander
        Slow relative speed wander (makes cycles slightly uneven).
    """

    speed: float
    theta_f0: float
    theta_h0: float
    ripple_f: tuple[Harmonic, ...]
    ripple_h: tuple[Harmonic, ...]
    wander: tuple[SpeedWander, ...] = ()

    @property
    def omega(self) -> float:
        """Mean main-shaft angular speed Omega in rad/s."""
        return _TWO_PI * self.speed

    def law(self, drive: str) -> DriveLaw:
        """Return a drive's angle as a law of the base phase psi (rad).

        Parameters
        ----------
        drive : {"theta_F", "theta_H"}
            Which drive: the main shaft turns once per unit of psi / (2 pi), the lifting shaft
            twice.
        """
        if drive == "theta_F":
            return DriveLaw(self.theta_f0, ratio=1.0, harmonics=self.ripple_f, source="rig")
        return DriveLaw(self.theta_h0, ratio=2.0, harmonics=self.ripple_h, source="rig")

    def base_phase(self, t: ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Return psi (rad), its rate (rad/s) and its acceleration (rad/s^2) at true times t (s)."""
        t = np.asarray(t, dtype=np.float64)
        psi = self.omega * t
        rate = np.full_like(t, self.omega)
        acc = np.zeros_like(t)
        for w in self.wander:
            arg = w.omega * t + w.phase
            psi += self.omega * w.rel_amplitude * (np.cos(w.phase) - np.cos(arg)) / w.omega
            rate += self.omega * w.rel_amplitude * np.sin(arg)
            acc += self.omega * w.rel_amplitude * w.omega * np.cos(arg)
        return psi, rate, acc

    def angles(self, t: ArrayLike) -> dict[str, tuple[FloatArray, FloatArray, FloatArray]]:
        """Return each drive's angle (rad), speed (rad/s) and acceleration (rad/s^2) at times t.

        Parameters
        ----------
        t : array_like
            True times in s.

        Returns
        -------
        dict
            ``{"theta_F": (angle, speed, acceleration), "theta_H": (...)}``.
        """
        psi, rate, acc = self.base_phase(t)
        out = {}
        for name in ("theta_F", "theta_H"):
            theta, slope, curvature = self.law(name).at_phase(psi)
            out[name] = (theta, rate * slope, acc * slope + rate**2 * curvature)
        return out

    def crossing_times(self, drive: str, angles: ArrayLike) -> FloatArray:
        """Return the true times (s) at which a drive angle passes the given values.

        Both laws are strictly increasing (ripple slopes are far below the gear ratio), so each
        value is passed once: the law is inverted for psi
        (:meth:`~rigval.model.laws.DriveLaw.phase_at`), then psi(t) by Newton's method on t, to
        1e-13 s.

        Parameters
        ----------
        drive : {"theta_F", "theta_H"}
            Which drive.
        angles : array_like
            Unwrapped drive angles in rad.

        Returns
        -------
        numpy.ndarray
            Times in s, same shape as ``angles``.
        """
        psi = self.law(drive).phase_at(angles)
        t = psi / self.omega
        for _ in range(60):
            value, rate, _ = self.base_phase(t)
            step = (value - psi) / rate
            t -= step
            if np.all(np.abs(step) < 1e-13 * np.maximum(1.0, np.abs(t))):
                break
        return t
