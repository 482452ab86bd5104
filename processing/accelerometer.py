"""Charge accelerometer chain: acceleration -> charge -> amplifier volts, and back.

Chain (PCB 357B40 + charge amplifier): ``q [pC] = S_q [pC/g] a / g0``, ``V = G_amp [mV/pC] q /
1000``, followed by the amplifier's first-order high-pass ``H(s) = s / (s + 2 pi f_c)``
(``f_c = 1 / (2 pi R_f C_f)``). A charge amplifier does not pass DC: the inverse recovers the
acceleration up to a constant.

The high-pass is discretised exactly for an input that is linear between samples (first-order
hold): with ``z`` the low-pass state (``y = x - z``, ``z' = w_c (x - z)``), ``E = exp(-w_c h)`` and
``c1 = 1 - (1 - E) / (w_c h)``::

    z[n+1] = E z[n] + (1 - E - c1) x[n] + c1 x[n+1]

Its inverse is the running sum ``z[n+1] = z[n] + ((1 - E - c1) y[n] + c1 y[n+1]) / (1 - c1)``, so
forward and inverse round-trip to rounding error. The virtual rig synthesises with
:func:`charge_chain_voltage`; :func:`acceleration_from_voltage` converts measurements.
"""

from __future__ import annotations

import logging

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigval.acquisition.errors import ConfigError
from rigval.processing.arrays import FloatArray
from rigval.processing.scipy_signal import lfilter

__all__ = [
    "STANDARD_GRAVITY",
    "acceleration_from_voltage",
    "apply_highpass",
    "charge_chain_voltage",
    "highpass_response",
    "invert_highpass",
]

logger = logging.getLogger(__name__)

#: Standard gravity g0 in m s-2 (the "g" of pC/g sensitivities).
STANDARD_GRAVITY = 9.80665


def _coefficients(fs: float, corner_hz: float) -> tuple[float, float]:
    if fs <= 0 or corner_hz <= 0:
        raise ConfigError(f"fs and the high-pass corner must be positive, got fs={fs} Hz, "
                          f"corner={corner_hz} Hz", where={"key": "highpass_hz"})
    wh = 2.0 * np.pi * corner_hz / fs
    decay = float(np.exp(-wh))
    c1 = float(1.0 - (-np.expm1(-wh)) / wh)
    return decay, c1


def highpass_response(frequency: ArrayLike, corner_hz: float) -> NDArray[np.complex128]:
    """Return the complex response ``j f / (j f + f_c)`` of the first-order high-pass (1).

    Parameters
    ----------
    frequency : array_like
        Frequencies in Hz.
    corner_hz : float
        Corner frequency f_c in Hz.
    """
    jf = 1j * np.asarray(frequency, dtype=np.float64)
    return jf / (jf + corner_hz)


def apply_highpass(x: ArrayLike, fs: float, corner_hz: float,
                   initial_state: float | None = None) -> FloatArray:
    """Apply the first-order high-pass exactly for an input linear between samples.

    Parameters
    ----------
    x : array_like
        Input samples (any unit), uniformly sampled.
    fs : float
        Sampling rate in Hz.
    corner_hz : float
        Corner frequency f_c in Hz.
    initial_state : float, optional
        Low-pass state z at the first sample. Default ``x[0]``: the input was constant before
        the record (steady state, output starts at 0).

    Returns
    -------
    numpy.ndarray
        High-passed samples, same unit.
    """
    x = np.asarray(x, dtype=np.float64)
    if x.size == 0:
        return x.copy()
    decay, c1 = _coefficients(fs, corner_hz)
    z0 = float(x[0]) if initial_state is None else float(initial_state)
    b = np.array([c1, 1.0 - decay - c1])
    a = np.array([1.0, -decay])
    # Transposed direct form: the filter state before x[1] carries E z0 + (1 - E - c1) x[0].
    zi = np.array([decay * z0 + b[1] * x[0]])
    z = np.empty_like(x)
    z[0] = z0
    if x.size > 1:
        z[1:], _ = lfilter(b, a, x[1:], zi=zi)
    return x - z


def invert_highpass(y: ArrayLike, fs: float, corner_hz: float,
                    initial_state: float = 0.0, *, out: FloatArray | None = None) -> FloatArray:
    """Undo :func:`apply_highpass` exactly (up to the unknown DC carried by the initial state).

    Parameters
    ----------
    y : array_like
        High-passed samples, uniformly sampled, gap-free.
    fs : float
        Sampling rate in Hz.
    corner_hz : float
        Corner frequency f_c in Hz.
    initial_state : float, default 0
        Low-pass state z at the first sample (``x[0] - y[0]``); unknown for measured data, where it
        only shifts the result by a constant.
    out : numpy.ndarray, optional
        A float64 array of ``y``'s size the result is written to; it may be ``y`` itself (memory:
        no second whole-record array), the values are the same.

    Returns
    -------
    numpy.ndarray
        The input of the high-pass, same unit (``out`` when given).
    """
    y = np.asarray(y, dtype=np.float64)
    decay, c1 = _coefficients(fs, corner_hz)
    if y.size == 0:
        return y.copy()
    # z = [z0, z0 + cumsum(((1 - d - c1) y[:-1] + c1 y[1:]) / (1 - c1))], returned as y + z:
    # a chunk at a time into the one output array (no whole-record temporary); the running
    # sum goes on from the last chunk's, added in the same order (identical values). A chunk
    # reads y[lo:hi + 1]: its last output waits until the next chunk has read y[hi], so that
    # ``out`` may be ``y`` itself.
    if out is None:
        out = np.empty(y.size)
    chunk, total = 1 << 20, None
    pending, pending_value = 0, initial_state + y[0]
    for lo in range(0, y.size - 1, chunk):
        hi = min(lo + chunk, y.size - 1)
        part = (1.0 - decay - c1) * y[lo:hi]
        part += c1 * y[lo + 1:hi + 1]
        part /= 1.0 - c1
        running = np.cumsum(part if total is None else np.concatenate(([total], part)))
        running = running if total is None else running[1:]
        total = running[-1]
        running += initial_state
        running += y[lo + 1:hi + 1]
        out[pending] = pending_value
        out[lo + 1:hi] = running[:-1]
        pending, pending_value = hi, running[-1]
    out[pending] = pending_value
    return out


def charge_chain_voltage(acceleration: ArrayLike, *, charge_sensitivity: float,
                         amplifier_gain: float, fs: float | None = None,
                         highpass_hz: float | None = None,
                         initial_state: float | None = None) -> FloatArray:
    """Forward model: amplifier output voltage (V) for an acceleration record (m s-2).

    Parameters
    ----------
    acceleration : array_like
        Acceleration in m s-2 along the sensor axis, uniformly sampled.
    charge_sensitivity : float
        Accelerometer charge sensitivity S_q in pC/g (calibration certificate).
    amplifier_gain : float
        Charge amplifier gain G_amp in mV/pC.
    fs : float, optional
        Sampling rate in Hz (needed with ``highpass_hz``).
    highpass_hz : float, optional
        The amplifier's first-order high-pass corner in Hz; None for an ideal DC-coupled chain.
    initial_state : float, optional
        High-pass state in V at the first sample (see :func:`apply_highpass`).

    Returns
    -------
    numpy.ndarray
        Output voltage in V.
    """
    volts = (np.asarray(acceleration, dtype=np.float64) / STANDARD_GRAVITY * charge_sensitivity
             * amplifier_gain * 1e-3)
    if highpass_hz is None:
        return volts
    if fs is None:
        raise ConfigError("the high-pass needs the sampling rate fs", where={"key": "fs"})
    return apply_highpass(volts, fs, highpass_hz, initial_state)


def acceleration_from_voltage(voltage: ArrayLike, *, charge_sensitivity: float,
                              amplifier_gain: float, fs: float | None = None,
                              highpass_hz: float | None = None,
                              initial_state: float = 0.0, overwrite: bool = False) -> FloatArray:
    """Convert charge amplifier output (V) to acceleration (m s-2).

    ``a = V / (S_q G_amp 1e-3) g0``; with ``highpass_hz`` the amplifier's high-pass is undone
    first (:func:`invert_highpass`). Remove the zero offset beforehand (mean over whole cycles):
    the corrected signal integrates any offset into a ramp. Give one gap-free segment at a time.

    Parameters
    ----------
    voltage : array_like
        Amplifier output in V.
    charge_sensitivity : float
        S_q in pC/g.
    amplifier_gain : float
        G_amp in mV/pC.
    fs : float, optional
        Sampling rate in Hz (needed with ``highpass_hz``).
    highpass_hz : float, optional
        Corner of the amplifier's high-pass in Hz to correct; None leaves it in.
    initial_state : float, default 0
        High-pass state in V at the first sample (sets the unknown DC).
    overwrite : bool, default False
        A writeable float64 ``voltage`` array of the caller's own becomes the acceleration
        (memory: no whole-record array of its own; the same values).

    Returns
    -------
    numpy.ndarray
        Acceleration in m s-2.
    """
    if charge_sensitivity <= 0 or amplifier_gain <= 0:
        raise ConfigError(f"sensitivity and gain must be positive, got {charge_sensitivity} pC/g "
                          f"and {amplifier_gain} mV/pC", where={"key": "charge_sensitivity"})
    volts = np.asarray(voltage, dtype=np.float64)
    own = overwrite and volts is voltage and volts.flags.writeable
    if highpass_hz is not None:
        if fs is None:
            raise ConfigError("the high-pass correction needs fs", where={"key": "fs"})
        volts = invert_highpass(volts, fs, highpass_hz, initial_state,
                                out=volts if own else None)
        volts /= charge_sensitivity * amplifier_gain * 1e-3  # its own array: in place (memory)
    else:
        volts = np.divide(volts, charge_sensitivity * amplifier_gain * 1e-3,
                          out=volts if own else None)
    volts *= STANDARD_GRAVITY
    return volts
