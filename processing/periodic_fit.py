"""Least-squares Fourier series of a periodic angle record: the one periodic fit of rigval.

An angle that turns ``ratio`` times per period ``P`` is written against the phase
``tau = 2 pi (t - t0) / P``:

    theta(t) = ratio * tau + c_0 + sum_k (c_{2k-1} cos k tau + c_{2k} sin k tau)

The coefficients come from the normal equations of the Fourier design, built in blocks (bounded
memory) and solved by Cholesky: the design is nearly orthogonal over whole periods, so squaring its
condition number costs nothing. :func:`refine_period` finds the period by Gauss-Newton on the fit's
residual. Callers: the ``"fourier"`` drive-angle estimator and the Butterworth trend
(:mod:`rigval.processing.excitation`), and fitted drive laws with their stated error
(:func:`rigval.model.drive_laws.fit_periodic_profile`).

The fits run with one BLAS thread (:func:`~rigval.acquisition.threads.single_blas_thread`): their
products are thin blocks, which OpenBLAS's threads only slow down on a busy machine
(docs/performance.md, *Speed as installed*).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from rigval.acquisition.threads import single_blas_thread
from rigval.processing.arrays import FloatArray

__all__ = ["PeriodicFit", "fit_periodic", "fourier_basis", "fourier_normal_equations",
           "refine_period"]

logger = logging.getLogger(__name__)

#: Rows of the design built at once.
_CHUNK_ROWS = 8192
#: Gauss-Newton steps of :func:`refine_period` at most (it converges in two or three).
_PERIOD_STEPS = 4

_Triple = tuple[FloatArray, FloatArray, FloatArray]


def _harmonics(tau: np.ndarray, order: int) -> tuple[np.ndarray, np.ndarray]:
    """Return ``cos k tau`` and ``sin k tau`` for k = 1..order, shape (n, order).

    By repeated products of ``exp(j tau)``: one complex exponential per sample instead of
    ``2 order`` trigonometric calls; the products add about ``k`` ulp of rounding to harmonic k.
    They are taken a column at a time, as the cumulative product along each row took them
    (numpy's complex product on strided columns; with two harmonics the one product is
    numpy's on whole arrays, as ``np.cumprod`` takes a single product): the same values to the
    bit at half the time.
    """
    first = np.exp(1j * tau)
    phasor = np.empty((tau.size, order), dtype=first.dtype)
    phasor[:, :1] = first[:, None]  # none without harmonics
    if order == 2:
        phasor[:, 1] = first * first
    else:
        for k in range(1, order):
            np.multiply(phasor[:, k - 1], first, out=phasor[:, k])
    return phasor.real, phasor.imag


def fourier_basis(tau: np.ndarray, order: int, derivative: int = 0) -> np.ndarray:
    """Return the Fourier design ``[1, cos tau, sin tau, cos 2 tau, ...]`` or its derivative.

    Parameters
    ----------
    tau : numpy.ndarray
        Phases, rad, shape (n,).
    order : int
        Number of harmonics K (``2 K + 1`` columns).
    derivative : {0, 1, 2}
        Derivative with respect to tau.
    """
    return _design(*_harmonics(tau, order), derivative)


def _design(cos: np.ndarray, sin: np.ndarray, derivative: int = 0) -> np.ndarray:
    """Return the Fourier design (:func:`fourier_basis`) from the harmonics of its phases.

    Parameters
    ----------
    cos, sin : numpy.ndarray
        ``cos k tau`` and ``sin k tau`` for k = 1..K, shape (n, K) (:func:`_harmonics`).
    derivative : {0, 1, 2}
        Derivative with respect to tau.
    """
    size, order = cos.shape
    k = np.arange(1, order + 1)
    columns = np.empty((size, 2 * order + 1))
    columns[:, 0] = 1.0 if derivative == 0 else 0.0
    if derivative == 0:
        columns[:, 1::2], columns[:, 2::2] = cos, sin
    elif derivative == 1:
        columns[:, 1::2], columns[:, 2::2] = -k * sin, k * cos
    else:
        columns[:, 1::2], columns[:, 2::2] = -(k**2) * cos, -(k**2) * sin
    return columns


def fourier_normal_equations(tau: np.ndarray, y: np.ndarray, order: int
                             ) -> tuple[np.ndarray, np.ndarray]:
    """Return ``A^T A`` and ``A^T y`` of the Fourier design of ``order`` harmonics, in blocks."""
    p = 2 * order + 1
    gram, rhs = np.zeros((p, p)), np.zeros(p)
    for start in range(0, tau.size, _CHUNK_ROWS):
        block = fourier_basis(tau[start:start + _CHUNK_ROWS], order)
        gram += block.T @ block
        rhs += block.T @ y[start:start + _CHUNK_ROWS]
    return gram, rhs


@dataclass(frozen=True)
class PeriodicFit:
    """A fitted periodic angle (module docstring).

    Attributes
    ----------
    t0 : float
        Time of phase 0, s.
    period : float
        Period, s.
    ratio : float
        Whole turns per period (the constant-speed part ``ratio * tau``).
    coef : numpy.ndarray
        ``(2 K + 1,)`` coefficients ``c_0, c_1, c_2, ...``, rad.
    """

    t0: float
    period: float
    ratio: float
    coef: np.ndarray

    @property
    def order(self) -> int:
        """Number of harmonics K."""
        return (self.coef.size - 1) // 2

    @property
    def omega(self) -> float:
        """Phase rate ``2 pi / period``, rad/s."""
        return 2.0 * math.pi / self.period

    def phase(self, t: np.ndarray) -> np.ndarray:
        """Return the phase tau (rad) at times ``t`` (s)."""
        return self.omega * (np.asarray(t, dtype=float) - self.t0)

    def __call__(self, t: np.ndarray, out: _Triple | None = None) -> _Triple:
        """Return angle (rad), angular speed (rad/s) and acceleration (rad/s^2) at times ``t``.

        ``out`` receives the three results in place when given (bounded memory).
        """
        t = np.asarray(t, dtype=float)
        n, w = self.order, self.omega
        k = np.arange(1, n + 1)
        a, b = self.coef[1::2], self.coef[2::2]
        angle, speed, acceleration = out or (np.empty(t.size), np.empty(t.size),
                                             np.empty(t.size))
        for lo in range(0, t.size, _CHUNK_ROWS):
            tau = self.phase(t[lo:lo + _CHUNK_ROWS])
            cos, sin = _harmonics(tau, n)
            part = slice(lo, lo + tau.size)
            angle[part], speed[part] = self.angle_and_speed(tau, cos, sin)
            acceleration[part] = w**2 * (cos @ (-(k**2) * a) + sin @ (-(k**2) * b))
        return angle, speed, acceleration

    def angle_and_speed(self, tau: np.ndarray, cos: np.ndarray, sin: np.ndarray
                        ) -> tuple[np.ndarray, np.ndarray]:
        """Return angle (rad) and angular speed (rad/s) at phases ``tau`` from their harmonics.

        Parameters
        ----------
        tau : numpy.ndarray
            Phases, rad, shape (n,) (:meth:`phase`).
        cos, sin : numpy.ndarray
            ``cos k tau`` and ``sin k tau`` for k = 1..K, shape (n, K) (:func:`_harmonics`).
        """
        k = np.arange(1, self.order + 1)
        a, b = self.coef[1::2], self.coef[2::2]
        angle = self.ratio * tau + self.coef[0] + cos @ a + sin @ b
        speed = self.omega * (self.ratio + sin @ (-k * a) + cos @ (k * b))
        return angle, speed


def turns_per_period(t: np.ndarray, theta: np.ndarray, period: float) -> float:
    """Return the whole turns per period nearest the record's mean speed."""
    span = t[-1] - t[0]
    return float(round((theta[-1] - theta[0]) / span * period / (2.0 * math.pi)))


@single_blas_thread()
def fit_periodic(t: np.ndarray, theta: np.ndarray, period: float, order: int, *,
                 t0: float | None = None, ratio: float | None = None) -> PeriodicFit:
    """Fit ``order`` harmonics of a given period to an angle record by least squares.

    Parameters
    ----------
    t : numpy.ndarray
        Times, s, at least ``2 order + 1`` of them spread over the phase.
    theta : numpy.ndarray
        Angles, rad (unwrapped).
    period : float
        Period, s.
    order : int
        Number of harmonics.
    t0 : float, optional
        Time of phase 0, s; default ``t[0]``.
    ratio : float, optional
        Whole turns per period; default :func:`turns_per_period`.

    Returns
    -------
    PeriodicFit
    """
    t = np.asarray(t, dtype=float)
    theta = np.asarray(theta, dtype=float)
    t0 = float(t[0]) if t0 is None else float(t0)
    ratio = turns_per_period(t, theta, period) if ratio is None else float(ratio)
    tau = 2.0 * math.pi * (t - t0) / period
    gram, rhs = fourier_normal_equations(tau, theta - ratio * tau, order)
    coef = scipy.linalg.cho_solve(scipy.linalg.cho_factor(gram), rhs)
    return PeriodicFit(t0=t0, period=float(period), ratio=ratio, coef=coef)


@single_blas_thread()
def refine_period(t: np.ndarray, theta: np.ndarray, period: float, order: int, *,
                  t0: float | None = None) -> float:
    """Refine a period estimate (s) by Gauss-Newton on the residual of the periodic fit.

    The fitted angle depends on the period through the phase ``2 pi (t - t0) / period``; its
    derivative with respect to the period is ``s = -((t - t0) / period) d theta / dt``. With the
    Fourier columns ``A`` of the fit and its residual ``r`` (orthogonal to ``A``), the
    Gauss-Newton step is ``s^T r / (s^T s - b^T (A^T A)^-1 b)``, ``b = A^T s``. Steps stop at
    1e-13 of the period or after four; a step that is not finite (a record without a period)
    leaves the estimate.

    Parameters
    ----------
    t, theta : numpy.ndarray
        Times (s) and angles (rad).
    period : float
        Starting estimate, s.
    order : int
        Harmonics of the fit.
    t0 : float, optional
        Time of phase 0, s; default ``t[0]``.
    """
    t = np.asarray(t, dtype=float)
    theta = np.asarray(theta, dtype=float)
    t0 = float(t[0]) if t0 is None else float(t0)
    for _ in range(_PERIOD_STEPS):
        fit = fit_periodic(t, theta, period, order, t0=t0)
        model, sensitivity, gram, projection = _period_sensitivity(fit, t)
        explained = float(projection @ scipy.linalg.solve(gram, projection, assume_a="pos"))
        step = float(sensitivity @ (theta - model)) / (float(sensitivity @ sensitivity)
                                                        - explained)
        if not math.isfinite(step) or abs(step) >= 0.5 * period:
            logger.debug("period refinement stopped: step %r s at period %r s", step, period)
            break
        period += step
        if abs(step) <= 1e-13 * period:
            break
    return period


def _period_sensitivity(fit: PeriodicFit, t: np.ndarray
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Return a fit's angle at ``t`` and its derivative by the period, with their normal equations.

    The derivative is ``s = -((t - t0) / period) d theta / dt`` (:func:`refine_period`); the
    normal equations are ``A^T A`` and ``A^T s`` of the fit's Fourier design ``A`` at ``t``. One
    pass over blocks of rows: each block's harmonics serve the angle, the speed and the design,
    which ``fit(t)`` and :func:`fourier_normal_equations` would each compute again (the same
    operations in the same order: the results are the same to the bit).

    Parameters
    ----------
    fit : PeriodicFit
        The periodic fit.
    t : numpy.ndarray
        Times, s, shape (n,).

    Returns
    -------
    (numpy.ndarray, numpy.ndarray, numpy.ndarray, numpy.ndarray)
        Angle (rad) and ``s`` (rad/s) at ``t``, shape (n,); ``A^T A`` (``2 K + 1`` square) and
        ``A^T s``.
    """
    p = 2 * fit.order + 1
    angle, sensitivity = np.empty(t.size), np.empty(t.size)
    gram, projection = np.zeros((p, p)), np.zeros(p)
    for lo in range(0, t.size, _CHUNK_ROWS):
        tau = fit.phase(t[lo:lo + _CHUNK_ROWS])
        cos, sin = _harmonics(tau, fit.order)
        part = slice(lo, lo + tau.size)
        angle[part], speed = fit.angle_and_speed(tau, cos, sin)
        sensitivity[part] = -(t[part] - fit.t0) / fit.period * speed
        block = _design(cos, sin)
        gram += block.T @ block
        projection += block.T @ sensitivity[part]
    return angle, sensitivity, gram, projection
