"""Linear filters run over a long record piece by piece, their state carried across the seams.

Each filter takes the record's consecutive pieces in order (:meth:`step`) and returns what one
call over the whole record returns: the state a piece ends in is where the next one starts, and
the recursion, its coefficients and their order of operations are those of the whole-record
call, so the pieces join to the last bit (a test checks them to 1e-12 of the signal's range).
"""

from __future__ import annotations

import logging
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from rigval.processing.accelerometer import _coefficients
from rigval.processing.arrays import FloatArray
from rigval.processing.scipy_signal import lfilter, lsim

__all__ = ["CarriedHighPass", "CarriedLsim"]

logger = logging.getLogger(__name__)


class CarriedLsim:
    """A continuous linear system (:func:`scipy.signal.lsim`, input linear between samples).

    Parameters
    ----------
    system : tuple
        ``(numerator, denominator)`` or any system :func:`scipy.signal.lsim` takes.
    dt : float
        Sample spacing in s; the whole record's first spacing ``t[1] - t[0]``, which is the
        step :func:`scipy.signal.lsim` discretises with.

    Notes
    -----
    The system starts at rest. A later piece is solved from the state the previous one ended
    in, its input preceded by the previous piece's last input sample (that step's output is
    dropped), so every step is the whole record's.
    """

    def __init__(self, system: Any, dt: float) -> None:
        self.system, self.dt = system, float(dt)
        self._state: FloatArray | None = None
        self._last_input = 0.0

    def step(self, u: ArrayLike) -> FloatArray:
        """Return the output for the record's next piece of input ``u`` (output per input unit)."""
        u = np.asarray(u, dtype=np.float64)
        first = self._state is None
        u_run = u if first else np.concatenate(([self._last_input], u))
        _, y, x = lsim(self.system, u_run, np.arange(u_run.size) * self.dt, X0=self._state)
        self._state = np.atleast_2d(x)[-1].copy()
        self._last_input = float(u[-1])
        y = np.atleast_1d(np.asarray(y, dtype=np.float64))  # lsim squeezes a single step
        return y if first else y[1:]


class CarriedHighPass:
    """The charge amplifier's first-order high-pass, exact for an input linear between samples.

    The same filter as :func:`rigval.processing.accelerometer.apply_highpass` with its default
    initial state (steady state at the first sample), run piece by piece.

    Parameters
    ----------
    fs : float
        Sampling rate in Hz.
    corner_hz : float
        Corner frequency in Hz.
    """

    def __init__(self, fs: float, corner_hz: float) -> None:
        decay, c1 = _coefficients(fs, corner_hz)
        self._decay = decay
        self._b = np.array([c1, 1.0 - decay - c1])
        self._a = np.array([1.0, -decay])
        self._zi: FloatArray | None = None

    def step(self, x: ArrayLike) -> FloatArray:
        """Return the high-passed next piece of the record ``x`` (same unit)."""
        x = np.asarray(x, dtype=np.float64)
        if x.size == 0:
            return x.copy()
        z = np.empty_like(x)
        if self._zi is None:  # the record's first sample: the low-pass state is the input
            z[0] = x[0]
            self._zi = np.array([self._decay * z[0] + self._b[1] * x[0]])
            if x.size > 1:
                z[1:], self._zi = lfilter(self._b, self._a, x[1:], zi=self._zi)
        else:
            z[:], self._zi = lfilter(self._b, self._a, x, zi=self._zi)
        return x - z
