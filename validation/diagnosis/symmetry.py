"""Planarity and symmetry evidence: shares of a symmetric pair, and axial against bending.

A symmetric planar model treats some channels as equal shares of one load: the two shafts of a
drive each carry half of its torque; a gauge on each face of a rod sees the same axial stress.
:func:`pair_shares` measures how the pair really shares it, revolution by revolution;
:func:`axial_bending` splits an opposite-face gauge pair into its axial part (what the rigid
planar model predicts) and its bending part (which a two-force member of a rigid planar model
does not carry).

Both take the pair's signals on the phi_F grid over the same whole revolutions, constant parts
removed (bridge zeros are unknown), and the pair's stated relative calibration uncertainty:
a gain error of one channel against the other is the one thing besides the machine that
makes a pair unequal, so each statement says whether the calibration allows what is seen.
docs/diagnosis.md gives the formulas.
"""

from __future__ import annotations

import dataclasses
import logging
import math

import numpy as np
import scipy.special

from rigval.acquisition.errors import DataError
from rigval.validation.metrics.core import Scores

__all__ = ["AxialBending", "PairShares", "axial_bending", "pair_shares"]

logger = logging.getLogger(__name__)


@dataclasses.dataclass(frozen=True)
class PairShares(Scores):
    """How two channels of a symmetric pair share their sum.

    Attributes
    ----------
    share : float
        The first channel's share of the pair's sum (1): ``<a, a + b> / <a + b, a + b>`` of the
        mean curves, constant parts removed; the second's is ``1 - share``.
    u_share : float
        Its standard uncertainty: the revolution-to-revolution scatter (the per-revolution
        shares' standard deviation over ``sqrt(n)``) and the calibration
        (``u_calibration``) in quadrature.
    u_scatter, u_calibration : float
        The two parts. The calibration part is ``s (1 - s) sqrt(u_a^2 + u_b^2 - 2 u_common^2)``:
        a gain error ``g`` of the first channel moves the share by ``s (1 - s) g``; the part of
        the calibration common to both cancels.
    k : float
        Coverage factor of the 95 % interval (Student's t with the Welch-Satterthwaite degrees
        of freedom of ``u_share``).
    lower, upper : float
        The 95 % interval of ``share``.
    nominal : float
        The share the symmetric model assumes (0.5).
    asymmetric : bool
        ``|share - nominal| > k u_share``: the pair is less symmetric than the calibration and
        the scatter allow.
    lag : float
        Phase lag of the second channel behind the first, rad of phi_F: ``b(phi) = p a(phi -
        lag)`` fitted to first order on the mean curves.
    u_lag : float
        Its standard uncertainty from the per-revolution lags' scatter, rad.
    lag_s, u_lag_s : float
        ``lag`` and ``u_lag`` over the main-shaft speed, s (NaN without a speed).
    n_cycles : int
        Revolutions used.
    """

    share: float
    u_share: float
    u_scatter: float
    u_calibration: float
    k: float
    lower: float
    upper: float
    nominal: float
    asymmetric: bool
    lag: float
    u_lag: float
    lag_s: float
    u_lag_s: float
    n_cycles: int


@dataclasses.dataclass(frozen=True)
class AxialBending(Scores):
    """An opposite-face gauge pair as axial and bending parts (signal units, e.g. Pa).

    Attributes
    ----------
    axial_rms : float
        RMS over phi_F of the axial part ``(a + b) / 2`` of the mean curves.
    bending_rms : float
        RMS of the bending part ``(a - b) / 2`` (positive where the first face is stretched).
    bending_peak : float
        Largest ``|bending|`` of the mean curve.
    ratio : float
        ``bending_rms / axial_rms`` (1).
    u_bending : float
        RMS over phi_F of the bending part's standard uncertainty when the rod does not bend:
        the gain mismatch the calibration allows, ``sqrt(u_a^2 + u_b^2 - 2 u_common^2) / 2``
        times ``|axial|``, and the revolution-to-revolution scatter of the mean, in quadrature.
    k : float
        Coverage factor (2).
    bending : bool
        ``bending_rms > k u_bending``: the pair sees bending beyond what a gain mismatch and the
        scatter explain (a two-force member of a rigid planar model carries none).
    n_cycles : int
        Revolutions used.
    """

    axial_rms: float
    bending_rms: float
    bending_peak: float
    ratio: float
    u_bending: float
    k: float
    bending: bool
    n_cycles: int


def _centred(first: np.ndarray, second: np.ndarray, what: str
             ) -> tuple[np.ndarray, np.ndarray]:
    a, b = np.asarray(first, dtype=float), np.asarray(second, dtype=float)
    if a.ndim != 2 or a.shape != b.shape:
        raise DataError(f"{what}: the pair's cycles must have one shape (n_cycles, n), got "
                        f"{a.shape} and {b.shape}", where={"key": what},
                        hint="give both channels over the same whole revolutions")
    if a.shape[0] < 3:
        raise DataError(f"{what}: needs 3 whole revolutions in both channels, got {a.shape[0]}",
                        where={"key": what}, hint="record longer")
    return a - a.mean(axis=1, keepdims=True), b - b.mean(axis=1, keepdims=True)


def _calibration(u_first: float, u_second: float, u_common: float) -> float:
    """Return the standard uncertainty of the gain of one channel against the other (1)."""
    return math.sqrt(max(u_first**2 + u_second**2 - 2.0 * u_common**2, 0.0))


def pair_shares(first: np.ndarray, second: np.ndarray, *, u_first: float, u_second: float,
                u_common: float = 0.0, speed: float = 0.0, nominal: float = 0.5,
                what: str = "symmetry") -> PairShares:
    """Measure the two channels' shares of their sum, their lag and the asymmetry's evidence.

    Parameters
    ----------
    first, second : numpy.ndarray
        ``(n_cycles, n)`` each channel over the same whole revolutions on the phi_F grid, same
        unit.
    u_first, u_second : float
        Relative calibration standard uncertainty of each channel (a gain known to 1 %: 0.01).
    u_common : float
        The part of both that is common (one gauge lot, one drawing), at most either.
    speed : float
        Main-shaft speed, rad/s (turns the lag into seconds; 0: none).
    nominal : float
        The share the symmetric model assumes.
    what : str
        Name for messages (the scene's key path).

    Returns
    -------
    PairShares

    Raises
    ------
    DataError
        For cycles of two shapes, fewer than 3 revolutions or a pair whose sum is constant.
    """
    a, b = _centred(first, second, what)
    total = a + b
    power = np.einsum("ij,ij->i", total, total)
    if np.any(power <= 0.0):
        raise DataError(f"{what}: the pair's sum is constant over a revolution",
                        where={"key": what}, hint="pair two channels that carry a load")
    per_cycle = np.einsum("ij,ij->i", a, total) / power
    mean_a, mean_t = a.mean(axis=0), total.mean(axis=0)
    share = float(mean_a @ mean_t / (mean_t @ mean_t))
    n = a.shape[0]
    u_scatter = float(np.std(per_cycle, ddof=1) / math.sqrt(n))
    u_calibration = share * (1.0 - share) * _calibration(u_first, u_second, u_common)
    u_share = math.hypot(u_scatter, u_calibration)
    # Welch-Satterthwaite: the calibration part is known (infinite degrees of freedom)
    dof = (u_share**4 / (u_scatter**4 / (n - 1))) if u_scatter > 0.0 else math.inf
    # Student's t quantile (t.ppf)
    k = float(scipy.special.stdtrit(dof, 0.975)) if math.isfinite(dof) else 1.959963984540054
    lag, u_lag = _lag(a, b)
    result = PairShares(share=share, u_share=u_share, u_scatter=u_scatter,
                        u_calibration=u_calibration, k=k, lower=share - k * u_share,
                        upper=share + k * u_share, nominal=nominal,
                        asymmetric=bool(abs(share - nominal) > k * u_share), lag=lag, u_lag=u_lag,
                        lag_s=lag / speed if speed > 0.0 else math.nan,
                        u_lag_s=u_lag / speed if speed > 0.0 else math.nan, n_cycles=n)
    logger.debug("%s: share %.4f +- %.4f (scatter %.2g, calibration %.2g), lag %.3g rad",
                 what, share, u_share, u_scatter, u_calibration, lag)
    return result


def _lag(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """Lag of ``b`` behind ``a`` (rad): ``b = p a - p lag a'``, on the mean and per revolution."""
    n = a.shape[1]
    step = 2.0 * np.pi / n

    def fit(x: np.ndarray, y: np.ndarray) -> float:
        slope = (np.roll(x, -1, axis=-1) - np.roll(x, 1, axis=-1)) / (2.0 * step)
        design = np.stack([x, slope], axis=-1)
        p, q = np.linalg.lstsq(design, y, rcond=None)[0]
        return float(-q / p) if p != 0.0 else math.nan

    lag = fit(a.mean(axis=0), b.mean(axis=0))
    per_cycle = np.array([fit(x, y) for x, y in zip(a, b, strict=True)])
    return lag, float(np.std(per_cycle, ddof=1) / math.sqrt(a.shape[0]))


def axial_bending(first: np.ndarray, second: np.ndarray, *, u_first: float, u_second: float,
                  u_common: float = 0.0, k: float = 2.0, what: str = "symmetry"
                  ) -> AxialBending:
    """Split an opposite-face gauge pair into axial and bending parts and test the bending.

    Parameters
    ----------
    first, second : numpy.ndarray
        ``(n_cycles, n)`` the two faces' signals (stress or strain) over the same whole
        revolutions, same unit.
    u_first, u_second, u_common : float
        Relative calibration standard uncertainties, as for :func:`pair_shares`.
    k : float
        Coverage factor.
    what : str
        Name for messages.

    Returns
    -------
    AxialBending

    Raises
    ------
    DataError
        For cycles of two shapes or fewer than 3 revolutions.
    """
    a, b = _centred(first, second, what)
    axial, bending = 0.5 * (a + b), 0.5 * (a - b)
    mean_axial, mean_bending = axial.mean(axis=0), bending.mean(axis=0)
    n = a.shape[0]
    scatter = np.std(bending, axis=0, ddof=1) / math.sqrt(n)
    gain = 0.5 * _calibration(u_first, u_second, u_common) * np.abs(mean_axial)
    u_bending = float(np.sqrt(np.mean(scatter**2 + gain**2)))
    axial_rms = float(np.sqrt(np.mean(mean_axial**2)))
    bending_rms = float(np.sqrt(np.mean(mean_bending**2)))
    return AxialBending(axial_rms=axial_rms, bending_rms=bending_rms,
                        bending_peak=float(np.max(np.abs(mean_bending))),
                        ratio=bending_rms / axial_rms if axial_rms > 0.0 else math.inf,
                        u_bending=u_bending, k=float(k), bending=bool(bending_rms > k * u_bending),
                        n_cycles=n)
