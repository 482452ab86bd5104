"""Residual spectra of one comparison: synchronous orders, non-synchronous and whole, in Hz.

The residual (measured minus model, :mod:`~rigval.validation.diagnosis.residual`) splits into

* its **synchronous** part, the mean over whole revolutions as a function of phi_F: what
  repeats every revolution (a wrong parameter, a gain, a lag, an order a mode amplifies); its
  spectrum is in orders of the main shaft (the Fourier series of one revolution);
* its **non-synchronous** part, the rest: what changes from revolution to revolution (a mode
  rung by broadband forcing, noise, speed wander); its spectrum is in Hz.

Spectra in Hz are Welch estimates (:func:`scipy.signal.welch`, Hann window, 50 % overlap)
averaged over the gap-free stretches of the record, after a zero-phase decimation
(:func:`scipy.signal.decimate`) to an analysis rate of at least ``4 upper_hz``.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from rigval.acquisition.errors import DataError
from rigval.processing.arrays import FloatArray
from rigval.processing.scipy_signal import welch
from rigval.processing.stretch_decimation import decimated_runs
from rigval.validation.diagnosis.residual import ResidualSeries

__all__ = ["OrderSpectrum", "ResidualParts", "ResidualSpectra", "Spectrum", "residual_parts",
           "residual_spectra", "shared_residual_spectra", "welch_runs"]

logger = logging.getLogger(__name__)

#: Complex order coefficients.
ComplexArray = NDArray[np.complex128]

#: Longest Welch segment in s (a frequency resolution of 0.125 Hz, Hann main lobe 0.25 Hz).
SEGMENT_S = 8.0
#: Equivalent degrees of freedom of one Hann segment at 50 % overlap, per segment (Welch 1967:
#: 2 K / (1 + 2 c^2) with the overlap correlation c = 0.167 of the Hann window).
DOF_PER_SEGMENT = 2.0 / (1.0 + 2.0 * 0.167**2)


@dataclass(frozen=True)
class Spectrum:
    """A one-sided power spectral density.

    Parameters
    ----------
    frequency : numpy.ndarray
        Frequencies in Hz.
    psd : numpy.ndarray
        Power spectral density, signal units squared per Hz.
    dof : float
        Equivalent degrees of freedom of each estimate (chi-square), for its scatter.
    resolution_hz : float
        Bin spacing in Hz.
    segment_s : float
        Length of a Welch segment in s (its Hann window sets the smearing).
    """

    frequency: FloatArray
    psd: FloatArray
    dof: float
    resolution_hz: float
    segment_s: float

    def variance(self, low: float = 0.0, high: float = np.inf) -> float:
        """Return the variance between two frequencies (Hz), signal units squared."""
        band = (self.frequency >= low) & (self.frequency < high)
        return float(np.sum(self.psd[band]) * self.resolution_hz)


@dataclass(frozen=True)
class OrderSpectrum:
    """Amplitudes of the orders of the main shaft in one revolution's curve.

    Parameters
    ----------
    order : numpy.ndarray
        Orders 0, 1, 2, ... (per revolution).
    amplitude : numpy.ndarray
        Amplitude of each order (order 0: the mean), signal units.
    """

    order: np.ndarray
    amplitude: FloatArray


@dataclass(frozen=True)
class ResidualSpectra:
    """One comparison's residual split and its spectra.

    Parameters
    ----------
    name, units : str
        Comparison and signal unit.
    speed_rev_s : float
        Mean main-shaft speed (rev/s): order k sits at ``k speed_rev_s`` Hz.
    upper_hz : float
        Upper end of the analysis band in Hz.
    synchronous : numpy.ndarray
        Residual averaged over whole revolutions on the run's phi_F grid, signal units.
    orders : OrderSpectrum
        Its orders.
    measured, residual, nonsynchronous : Spectrum
        In Hz: the measured signal, the residual, and the residual less its synchronous part.
    variance_measured, variance_residual, variance_synchronous, variance_nonsynchronous : float
        Variances below ``upper_hz`` (synchronous: of the revolution mean), units squared.
    """

    name: str
    units: str
    speed_rev_s: float
    upper_hz: float
    synchronous: FloatArray
    orders: OrderSpectrum
    measured: Spectrum
    residual: Spectrum
    nonsynchronous: Spectrum
    variance_measured: float
    variance_residual: float
    variance_synchronous: float
    variance_nonsynchronous: float

    @property
    def explained(self) -> float:
        """Share of the measured variance below ``upper_hz`` the model explains (1)."""
        return 1.0 - self.variance_residual / self.variance_measured


def welch_runs(values: FloatArray, run: np.ndarray, fs: float,
               segment_s: float = SEGMENT_S) -> Spectrum:
    """Return the Welch PSD of a signal averaged over its gap-free stretches.

    Parameters
    ----------
    values : numpy.ndarray
        Samples (NaN-free), signal units.
    run : numpy.ndarray
        Index of the gap-free stretch of each sample.
    fs : float
        Sample rate in Hz.
    segment_s : float, default :data:`SEGMENT_S`
        Longest segment in s; shorter (down to 2 s) so that the longest stretch holds about
        2.5 segments.

    Raises
    ------
    DataError
        If no stretch is 2 s long.
    """
    stretches = [values[run == k] for k in np.unique(run)]
    longest = max(s.size for s in stretches) / fs
    if longest < 2.0:
        raise DataError(f"the longest gap-free stretch lasts {longest:.2f} s; the residual "
                        "spectra need 2 s", hint="record longer or with fewer gaps")
    nperseg = int(float(np.clip(longest / 2.5, 2.0, segment_s)) * fs)
    total, segments = np.zeros(nperseg // 2 + 1), 0
    frequency = np.fft.rfftfreq(nperseg, 1.0 / fs)
    for stretch in stretches:
        if stretch.size < nperseg:
            continue
        _, psd = welch(stretch, fs=fs, nperseg=nperseg, noverlap=nperseg // 2,
                       detrend="linear")
        n = (stretch.size - nperseg) // (nperseg // 2) + 1
        total += psd * n
        segments += n
    return Spectrum(frequency, total / segments, DOF_PER_SEGMENT * segments,
                    float(frequency[1] - frequency[0]), nperseg / fs)


#: Samples per block of the order fit: its design rows of a block (2 K + 3 columns, 22 MiB at
#: K = 40) are built, used and let go before the next (docs/performance.md, long records).
ORDER_FIT_BLOCK = 2**15


def _blocks(n: int, size: int = ORDER_FIT_BLOCK) -> range:
    """Return the first sample of each block of ``size`` samples of ``n``."""
    return range(0, n, size)


def _design(phi: FloatArray, k: np.ndarray, centre: float, span: float) -> FloatArray:
    """Design rows at ``phi`` (rad): cos and sin of the orders ``k``, and the slow trend.

    Each column block is made in place in the rows (memory: the rows alone, no product or
    cos/sin temporaries beside them), the values of ``cos(outer(phi, k))`` and so on.
    """
    design = np.empty((phi.size, 2 * k.size + 1))
    cosine, sine = design[:, :k.size], design[:, k.size:2 * k.size - 1]
    np.cos(np.multiply.outer(phi, k, out=cosine), out=cosine)
    np.sin(np.multiply.outer(phi, k[1:], out=sine), out=sine)
    u = design[:, -2]
    np.divide(phi - centre, span, out=u)
    np.square(u, out=design[:, -1])
    return design


def _order_fit(phi: FloatArray, values: Sequence[FloatArray], max_order: int
               ) -> list[ComplexArray]:
    """Least-squares Fourier coefficients of each of ``values`` over phi_F, orders 0 ... max_order.

    Returns, per signal, complex coefficients ``c_k`` with ``values ~ Re(sum c_k exp(i k phi))``.
    A slow trend (a bridge's thermal drift, quadratic in phi_F) is fitted beside them and left
    out: over whole revolutions a ramp would otherwise leak into every order as a sawtooth. The
    normal equations are summed block by block (:data:`ORDER_FIT_BLOCK` samples), so that the
    design matrix of the whole record is never built; equal to the whole-matrix sums up to their
    summation order. Signals at the same ``phi`` (one measurement against several models) share
    each block's design rows and the normal matrix; each signal's coefficients are those it
    would get alone, to the bit.
    """
    k = np.arange(max_order + 1)
    centre, span = phi.mean(), np.ptp(phi)
    columns = 2 * max_order + 3
    normal = np.zeros((columns, columns))
    rights = [np.zeros(columns) for _ in values]
    for start in _blocks(phi.size):
        design = _design(phi[start:start + ORDER_FIT_BLOCK], k, centre, span)
        normal += design.T @ design
        for right, signal in zip(rights, values, strict=True):
            right += design.T @ signal[start:start + ORDER_FIT_BLOCK]
    # normal equations: the columns are near orthogonal over whole revolutions (fast, stable)
    coefs = [np.linalg.solve(normal, right)[:2 * max_order + 1] for right in rights]
    return [np.concatenate([[c[0]], c[1:max_order + 1] - 1j * c[max_order + 1:]])
            for c in coefs]


def _orders_at(coefs: Sequence[ComplexArray], phi: FloatArray) -> list[FloatArray]:
    """Return each order series ``Re(sum c_k exp(i k phi))`` at ``phi`` (rad), block by block.

    The series share each block's ``exp(i k phi)`` (the coefficient sets have one length),
    made in place (memory: one complex array of the block, the values of
    ``np.exp(1j * np.outer(phi, k))``).
    """
    k = np.arange(coefs[0].size)
    out = [np.empty(phi.size) for _ in coefs]
    for start in _blocks(phi.size):
        block = phi[start:start + ORDER_FIT_BLOCK]
        basis = np.zeros((block.size, k.size), dtype=np.complex128)
        np.multiply.outer(block, k, out=basis.imag)
        basis.imag += 0.0  # a zero's sign as 1j * x gives it (-0.0 becomes 0.0): the same bits
        np.exp(basis, out=basis)
        for values, coef in zip(out, coefs, strict=True):
            values[start:start + block.size] = np.real(basis @ coef)
    return out


@dataclass(frozen=True)
class ResidualParts:
    """A residual decimated to its analysis rate and split at the orders.

    Parameters
    ----------
    fs : float
        Analysis rate in Hz.
    residual, nonsynchronous : numpy.ndarray
        The residual and the residual less its synchronous part, signal units.
    measured : numpy.ndarray
        The measured signal at the same samples.
    run : numpy.ndarray
        Gap-free stretch of each sample.
    coefficients : numpy.ndarray
        Complex order coefficients of the synchronous part, orders 0 ... K.
    """

    fs: float
    residual: FloatArray
    nonsynchronous: FloatArray
    measured: FloatArray
    run: np.ndarray
    coefficients: FloatArray


def residual_parts(series: Sequence[ResidualSeries], upper_hz: float) -> list[ResidualParts]:
    """Decimate residuals to at least ``4 upper_hz`` and split off their orders up to ``upper_hz``.

    The synchronous part is the least-squares Fourier series of the residual over phi_F,
    orders 0 ... ``upper_hz / speed`` (the revolution mean, gaps allowed); the non-synchronous
    part is the rest.

    Parameters
    ----------
    series : sequence of ResidualSeries
        Residuals at the first's samples (:meth:`ResidualSeries.same_samples`): the
        comparisons of one stream, one comparison against several models. They share the order
        fit's design rows; a measured signal two of them have (one comparison, two models) is
        decimated once, and their parts hold the same array.
    upper_hz : float
        Upper end of the band analysed (Hz).

    Returns
    -------
    list of ResidualParts
        Per series, what :func:`residual_spectra` takes its spectra of; each as the series
        alone gives it, to the bit.

    Raises
    ------
    ValueError
        If a series is not at the first's samples.
    """
    first = series[0]
    if not all(first.same_samples(other) for other in series[1:]):
        raise ValueError("residual parts of several series need the same samples")
    q = max(int(first.fs // (4.0 * upper_hz)), 1)
    source = _measurements(series)
    measured = {i: decimated_runs(series[i].measured, series[i].run, q)
                for i in sorted(set(source))}
    _, run, index = measured[0]
    residuals = [decimated_runs(s.residual, s.run, q)[0] for s in series]
    phi = first.phi[index]
    coefs = _order_fit(phi, residuals, max(int(upper_hz / first.speed_rev_s), 1))
    parts = []
    for i, (residual, coef, nonsynchronous) in enumerate(
            zip(residuals, coefs, _orders_at(coefs, phi), strict=True)):
        np.subtract(residual, nonsynchronous, out=nonsynchronous)
        parts.append(ResidualParts(first.fs / q, residual, nonsynchronous,
                                   measured[source[i]][0], run, coef))
    return parts


def _measurements(series: Sequence[ResidualSeries]) -> list[int]:
    """Return, per series at one set of samples, the first series of its measured signal.

    Series of one comparison (name and unit) with equal measured values share it.
    """
    first: list[int] = []
    for i, s in enumerate(series):
        first.append(next((j for j in range(i) if first[j] == j and series[j].name == s.name
                           and series[j].units == s.units
                           and np.array_equal(series[j].measured, s.measured)), i))
    return first


def residual_spectra(series: ResidualSeries, upper_hz: float = 40.0) -> ResidualSpectra:
    """Split a comparison's residual into its synchronous and non-synchronous parts, with spectra.

    Parameters
    ----------
    series : ResidualSeries
        The comparison's residual in time.
    upper_hz : float, default 40
        Upper end of the band analysed (Hz); at most ``0.25 fs``.

    Returns
    -------
    ResidualSpectra
        The parts (:func:`residual_parts`) and their spectra.
    """
    return shared_residual_spectra([series], upper_hz)[0]


def shared_residual_spectra(series: Sequence[ResidualSeries], upper_hz: float = 40.0
                            ) -> list[ResidualSpectra]:
    """Return the residual spectra of several series at the same samples, sharing the work.

    What :func:`residual_spectra` returns for each series, to the bit, with the work that
    depends on the samples alone done once (the order fit's design rows and normal matrix, the
    orders' basis) and that on a measured signal once per signal (its decimation and spectrum):
    the comparisons of one stream, and ``rigval identify``'s nominal and identified model of
    one comparison.

    Parameters
    ----------
    series : sequence of ResidualSeries
        The series, each at the first's samples (:meth:`ResidualSeries.same_samples`).
    upper_hz : float, default 40
        Upper end of the band analysed (Hz); at most ``0.25 fs``.

    Returns
    -------
    list of ResidualSpectra
        In the order of ``series``.
    """
    first = series[0]
    upper_hz = min(upper_hz, 0.25 * first.fs)
    parts = residual_parts(series, upper_hz)
    measured: list[tuple[FloatArray, Spectrum]] = []
    for p in parts:  # parts of one measured signal hold the same array
        if not any(signal is p.measured for signal, _ in measured):
            measured.append((p.measured, welch_runs(p.measured, p.run, p.fs)))
    coefs = [p.coefficients for p in parts]
    return [_spectra(s, upper_hz, p, next(sp for signal, sp in measured if signal is p.measured),
                     synchronous)
            for s, p, synchronous in zip(series, parts, _orders_at(coefs, first.angle),
                                         strict=True)]


def _spectra(series: ResidualSeries, upper_hz: float, parts: ResidualParts, measured: Spectrum,
             synchronous: FloatArray) -> ResidualSpectra:
    """Return one series' spectra from its parts, its measured spectrum and synchronous curve."""
    amplitude = np.abs(parts.coefficients)
    residual, nonsynchronous = (welch_runs(x, parts.run, parts.fs)
                                for x in (parts.residual, parts.nonsynchronous))
    return ResidualSpectra(series.name, series.units, series.speed_rev_s, upper_hz, synchronous,
                           OrderSpectrum(np.arange(amplitude.size), amplitude),
                           measured, residual, nonsynchronous,
                           measured.variance(0.0, upper_hz), residual.variance(0.0, upper_hz),
                           float(np.sum(amplitude[1:] ** 2) / 2.0),
                           nonsynchronous.variance(0.0, upper_hz))
