"""Resonances in a residual's non-synchronous spectrum: frequency, damping and amplitude.

A structural mode rung by broadband forcing leaves a peak in the residual's non-synchronous
spectrum (:mod:`~rigval.validation.diagnosis.spectra`), whose shape is that of one degree of
freedom, ``|H(f)|^2 = 1 / ((1 - r^2)^2 + (2 zeta r)^2)``, ``r = f / f_n``. Each candidate peak is
fitted in a window around it by maximum likelihood:

* model: a floor ``exp(a + b (f - f_c))`` plus ``A (2 zeta)^2 |H(f)|^2`` (``A``: the peak's height
  above the floor), smeared by the Welch window's spectral kernel (Hann, the segment length);
* likelihood: each Welch estimate is the model times a chi-square of ``dof`` degrees of freedom
  over ``dof`` (a Gamma law), so ``-log L = dof/2 sum (log M + P / M)``;
* detection: the likelihood ratio against the floor alone, ``2 (log L1 - log L0)``, above
  :data:`DETECTION_LR` (set over no-mode runs of the virtual rig, docs/diagnosis.md), a
  damping ratio within :data:`DAMPING_RANGE`, the frequency inside its window;
* uncertainties: the inverse of the likelihood's Hessian (numerical), times
  :data:`BIN_CORRELATION` for the Hann window's correlation of neighbouring bins.

The mode's variance is the fitted peak's integral, ``A pi zeta f_n``, its amplitude
``sqrt(2 variance)``.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import quad
from scipy.optimize import minimize, minimize_scalar

from rigval.processing.arrays import FloatArray
from rigval.validation.diagnosis.spectra import Spectrum

__all__ = ["DAMPING_RANGE", "DETECTION_LR", "Resonance", "find_resonances", "fit_resonance"]

logger = logging.getLogger(__name__)

#: Likelihood ratio statistic a peak must reach to be reported (set on the virtual rig's
#: no-mode runs: docs/diagnosis.md, benchmarks/diagnosis_modes.py).
DETECTION_LR = 60.0
#: Damping ratios a reported resonance may have (1): narrower is a line, wider is the floor.
DAMPING_RANGE = (0.002, 0.2)
#: Variance inflation of the fitted parameters for the Hann window's correlation of
#: neighbouring Welch bins (equivalent noise bandwidth 1.5 bins).
BIN_CORRELATION = 1.5
#: Candidate peaks fitted per spectrum, the highest above their running median first.
MAX_CANDIDATES = 4
#: A candidate peak (3-bin mean) stands at least this many times above the median of the
#: spectrum over ``max(4 Hz, f / 2)`` around it.
CANDIDATE_RATIO = 2.0
#: Share of :data:`DETECTION_LR` a candidate must reach with only its height fitted (at the
#: first guesses of frequency and damping) to be fitted in full.
SCREEN_SHARE = 0.3


@dataclass(frozen=True)
class Resonance:
    """One resonance found in a residual spectrum, with standard uncertainties.

    Parameters
    ----------
    frequency_hz, u_frequency_hz : float
        Natural frequency and its standard uncertainty in Hz.
    damping, u_damping : float
        Damping ratio and its standard uncertainty (1).
    amplitude, u_amplitude : float
        Amplitude ``sqrt(2 variance)`` of the resonant response, signal units.
    variance : float
        Variance of the resonant response, signal units squared.
    likelihood_ratio : float
        ``2 (log L1 - log L0)`` against the floor alone.
    order : float
        ``frequency_hz / speed``: where it sits among the main shaft's orders.
    """

    frequency_hz: float
    u_frequency_hz: float
    damping: float
    u_damping: float
    amplitude: float
    u_amplitude: float
    variance: float
    likelihood_ratio: float
    order: float

    @property
    def peak_psd(self) -> float:
        """Height of the peak above the floor, signal units squared per Hz."""
        return self.variance / (np.pi * self.damping * self.frequency_hz)

    def variance_below(self, upper_hz: float) -> float:
        """Return the resonance's variance between 0 and ``upper_hz`` (signal units squared).

        The fitted peak's integral over that band; :attr:`variance` is its integral over all
        frequencies (the two differ by the tail above ``upper_hz``).
        """
        value, _ = quad(lambda f: float(_resonance_shape(np.array(f), self.frequency_hz,
                                                         self.damping)),
                        0.0, upper_hz, points=[min(self.frequency_hz, upper_hz)], limit=200)
        return self.peak_psd * value

    def order_response(self, curve: FloatArray, speed_rev_s: float) -> FloatArray:
        """Return what this mode adds to a periodic load: ``(H - 1)`` applied to its orders.

        A mode of unit static gain driven by one revolution's load ``curve`` (uniform grid over
        phi_F) adds ``(H(k f_rot) - 1)`` times each order k: the signature of the mode in the
        revolution mean (for the attribution of :mod:`~rigval.validation.diagnosis`).
        """
        coef = np.fft.rfft(curve)
        r = np.arange(coef.size) * speed_rev_s / self.frequency_hz
        h = 1.0 / (1.0 - r**2 + 2j * self.damping * r)
        return np.fft.irfft(coef * (h - 1.0), n=curve.size)


def _kernel(segment_s: float) -> tuple[FloatArray, FloatArray]:
    """Offsets (Hz) and weights of the Hann window's power kernel over its main lobe and more."""
    # in bins over +-3 (the sidelobes beyond hold 1e-3 of the power), never exactly on the
    # removable singular points +-1
    x = (np.arange(-12, 12) + 0.5) / 4.0
    weight = (np.sinc(x) / (1.0 - x**2)) ** 2
    return x / segment_s, weight / weight.sum()


def _resonance_shape(f: FloatArray, fn: float, zeta: float) -> FloatArray:
    r = f / fn
    return (2.0 * zeta) ** 2 / ((1.0 - r**2) ** 2 + (2.0 * zeta * r) ** 2)


class _Window:
    """The Gamma negative log-likelihood of a spectrum's window under floor (+ resonance)."""

    def __init__(self, spectrum: Spectrum, low: float, high: float, centre: float,
                 known: tuple[tuple[float, float, float], ...] = ()) -> None:
        band = (spectrum.frequency >= low) & (spectrum.frequency <= high)
        self.f = spectrum.frequency[band]
        self.p = spectrum.psd[band]
        self.dof = spectrum.dof
        self.centre = centre
        self.scale = float(np.median(self.p))
        offsets, self.weights = _kernel(spectrum.segment_s)
        self.grid = self.f[:, None] + offsets[None, :]
        # resonances found before, fixed: their tails are not floor
        self.known = sum((peak * _resonance_shape(self.grid, fn, zeta) @ self.weights
                          for fn, zeta, peak in known), np.zeros(self.f.size))
        # what every evaluation of the optimisers takes from the window, made once
        self._offset = self.f - self.centre
        self._half_dof = 0.5 * self.dof

    def model(self, theta: FloatArray) -> FloatArray:
        floor = np.exp(theta[0] + theta[1] * self._offset)
        floor *= self.scale
        floor += self.known
        if theta.size == 2:
            return floor
        fn, zeta, height = np.exp(theta[2:5])
        peak = _resonance_shape(self.grid, fn, zeta) @ self.weights
        peak *= height * self.scale
        peak += floor
        return peak

    def nll(self, theta: FloatArray) -> float:
        m = self.model(theta)
        terms = np.divide(self.p, m)
        terms += np.log(m, out=m)
        return float(self._half_dof * np.add.reduce(terms))


def _hessian(fun, x: FloatArray, step: float = 1e-3) -> FloatArray:
    n = x.size
    h = np.zeros((n, n))
    eye = np.eye(n) * step
    for i in range(n):
        for j in range(i, n):
            h[i, j] = h[j, i] = (fun(x + eye[i] + eye[j]) - fun(x + eye[i] - eye[j])
                                 - fun(x - eye[i] + eye[j]) + fun(x - eye[i] - eye[j])) / (
                4.0 * step**2)
    return h


def _half_power_damping(window: _Window, i: int) -> float:
    """First guess of the damping ratio from the half-power width around bin i (1)."""
    level = 0.5 * window.p[i]
    lo = i
    while lo > 0 and window.p[lo] > level:
        lo -= 1
    hi = i
    while hi < window.f.size - 1 and window.p[hi] > level:
        hi += 1
    return float(np.clip((window.f[hi] - window.f[lo]) / (2.0 * window.f[i]), 0.005, 0.1))


def _covariance(hessian: FloatArray) -> FloatArray | None:
    """Covariance of the fitted parameters, or of the resonance's three alone.

    When the floor is negligible beside the peak its parameters are undetermined (a singular
    Hessian); the resonance's uncertainties are then those with the floor held.
    """
    for part in (slice(None), slice(2, 5)):
        try:
            cov = np.linalg.inv(hessian[part, part])
        except np.linalg.LinAlgError:
            continue
        var = np.diag(cov)[-3:]
        if np.all(np.isfinite(var)) and np.all(var > 0):
            return cov[-3:, -3:] * BIN_CORRELATION
    return None


def fit_resonance(spectrum: Spectrum, guess_hz: float, speed_rev_s: float,
                  band: tuple[float, float], known: tuple[Resonance, ...] = ()
                  ) -> Resonance | None:
    """Fit one resonance near a frequency; None if it is not there.

    Parameters
    ----------
    spectrum : Spectrum
        A residual's (non-synchronous) spectrum.
    guess_hz : float
        Where the candidate peak is (Hz).
    speed_rev_s : float
        Main-shaft speed (rev/s), for the resonance's order.
    band : tuple of float
        Frequencies (Hz) a reported resonance must lie within.
    known : tuple of Resonance, optional
        Resonances found before, added to the floor as they are.

    Returns
    -------
    Resonance or None
        The fitted resonance when it passes the detection rules of the module docstring.
    """
    half = max(2.0, 0.25 * guess_hz)
    window = _Window(spectrum, guess_hz - half, guess_hz + half, guess_hz,
                     tuple((r.frequency_hz, r.damping, r.peak_psd) for r in known))
    if window.f.size < 12:
        return None
    null = minimize(window.nll, np.zeros(2), method="Nelder-Mead")
    i = int(np.argmin(np.abs(window.f - guess_hz)))
    height = max(float(window.p[i] / window.model(null.x)[i]) - 1.0, 0.5) * float(
        window.model(null.x)[i] / window.scale)
    start = np.array([*null.x, np.log(guess_hz), np.log(_half_power_damping(window, i)),
                      np.log(height)])
    # screen: the peak's height alone at the first guess; a candidate far below the bar there
    # is not worth the full fit (the full fit can raise the ratio, rarely threefold)
    trial = start.copy()

    def height_alone(h: float) -> float:
        trial[4] = h
        return window.nll(trial)

    quick = minimize_scalar(height_alone, bounds=(start[4] - 8.0, start[4] + 3.0),
                            method="bounded")
    if 2.0 * (null.fun - quick.fun) < SCREEN_SHARE * DETECTION_LR:
        return None
    best = minimize(window.nll, start, method="Nelder-Mead",
                    options={"maxiter": 3000, "xatol": 1e-4, "fatol": 1e-3})
    ratio = 2.0 * (null.fun - best.fun)
    fn, zeta, height = np.exp(best.x[2:5])
    if (ratio < DETECTION_LR or not DAMPING_RANGE[0] <= zeta <= DAMPING_RANGE[1]
            or not band[0] <= fn <= band[1] or abs(fn - guess_hz) > 0.8 * half):
        logger.debug("candidate at %.2f Hz rejected: LR %.1f, f %.2f Hz, zeta %.4f",
                     guess_hz, ratio, fn, zeta)
        return None
    cov = _covariance(_hessian(window.nll, best.x))
    if cov is None:
        return None
    var = np.diag(cov)
    variance = height * window.scale * np.pi * zeta * fn
    u_log_var = float(np.sqrt(max(np.sum(cov), 0.0)))  # d log(variance) / d theta = (1, 1, 1)
    amplitude = float(np.sqrt(2.0 * variance))
    return Resonance(float(fn), float(fn * np.sqrt(var[0])), float(zeta),
                     float(zeta * np.sqrt(var[1])), amplitude, 0.5 * amplitude * u_log_var,
                     float(variance), float(ratio), float(fn / speed_rev_s))


def _median(values: FloatArray) -> float:
    """Return ``np.median(values)`` (to the bit) of a non-empty 1-d array, without its overhead.

    The middle value, or the mean of the two middle values ``(a + b) / 2``; NaN if any value is.
    """
    n = values.size
    part = np.partition(values, [(n - 1) // 2, n // 2, n - 1])
    if np.isnan(part[-1]):
        return math.nan
    return float(part[n // 2]) if n % 2 else (float(part[n // 2 - 1]) + float(part[n // 2])) / 2.0


def default_band(speed_rev_s: float, upper_hz: float) -> tuple[float, float]:
    """Return the band searched for modes (Hz): above the low orders' speed-wander sidebands.

    The revolution-to-revolution residual below about 6 orders is the rigid model's own
    (speed wander modulating the strong low orders); the band starts above it (at least 4 Hz)
    and ends at ``0.9 upper_hz``, so that a fit's window does not lean on the edge of the
    decimated band.
    """
    return max(4.0, 6.0 * speed_rev_s), 0.9 * upper_hz


def find_resonances(spectrum: Spectrum, speed_rev_s: float,
                    band: tuple[float, float]) -> tuple[Resonance, ...]:
    """Find the resonances of a residual's non-synchronous spectrum within a band.

    Parameters
    ----------
    spectrum : Spectrum
        Non-synchronous residual spectrum (orders removed).
    speed_rev_s : float
        Main-shaft speed in rev/s.
    band : tuple of float
        Lowest and highest frequency searched (Hz), e.g. :func:`default_band`.

    Returns
    -------
    tuple of Resonance
        By frequency; two fits of the same peak (frequencies within 3 standard uncertainties)
        are reported once, the one of larger likelihood ratio.
    """
    f, p = spectrum.frequency, spectrum.psd
    inside = np.flatnonzero((f >= band[0]) & (f <= band[1]))
    if inside.size < 5:
        return ()
    smooth = np.convolve(p, np.ones(3) / 3.0, mode="same")
    middle = inside[1:-1]
    local = middle[(smooth[middle] >= smooth[middle - 1]) & (smooth[middle] >= smooth[middle + 1])]
    half = 0.5 * np.maximum(4.0, 0.5 * f[local])
    # the window f[i] +- half of ascending frequencies: samples lo ... hi - 1
    lo = np.searchsorted(f, f[local] - half, side="left")
    hi = np.searchsorted(f, f[local] + half, side="right")
    ratio = {int(i): smooth[i] / _median(p[a:b])
             for i, a, b in zip(local, lo.tolist(), hi.tolist(), strict=True)}
    peaks = sorted((i for i in ratio if ratio[i] >= CANDIDATE_RATIO), key=lambda i: -ratio[i])
    found: list[Resonance] = []
    for i in peaks[:MAX_CANDIDATES]:
        res = fit_resonance(spectrum, float(f[i]), speed_rev_s, band, tuple(found))
        if res is None:
            continue
        same = [r for r in found if abs(r.frequency_hz - res.frequency_hz)
                < 3.0 * max(r.u_frequency_hz, res.u_frequency_hz, spectrum.resolution_hz)]
        if same and same[0].likelihood_ratio >= res.likelihood_ratio:
            continue
        found = [r for r in found if r not in same] + [res]
    return tuple(sorted(found, key=lambda r: r.frequency_hz))
