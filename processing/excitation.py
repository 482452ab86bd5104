"""Drive angles and their first and second derivatives from encoder counts, with an error estimate.

Raw counts are never differenced: a central second difference of an angle quantised to ``q =
2 pi / CPR`` has a noise of ``sqrt(6) q / sqrt(12) / dt^2`` (thousands of rad/s^2 at 5 kHz). Two
estimators (docs/processing.md; [Schafer] in docs/references.md):

``"butterworth"`` (default, any motion)
    Per gap-free run: remove a least-squares Fourier trend of a few harmonics (as below), filter
    the remainder forward and backward with a Butterworth low-pass (order 8 by default, so the
    pass band is flat to 1.5e-5 at half the corner) padded with ``6 fs / f_c`` samples, add the
    trend back, then central differences (analytic ones for the trend). What the trend does not
    capture (speed changes, non-periodic motion) still passes the filter, so the method works
    for any motion; the trend only shrinks the filter's edge transients (8.8 rad/s^2 at the
    record ends without it, 0.01 with it). The corner sets the trade-off: noise on the
    acceleration grows as ``f_c^2.5``, bias falls once the corner is well above the highest
    harmonic the model needs.
``"fourier"`` (strictly periodic operation)
    ``theta(t) = c0 + W t + sum_k a_k cos(k W t) + b_k sin(k W t)`` by least squares, with the
    fundamental W the mean speed (a periodic motion advances 2 pi per period; the period by
    Gauss-Newton on the residual, :mod:`rigval.processing.periodic_fit`); derivatives analytic.

Both report the noise that quantisation alone leaves on angle, speed and acceleration, computed
from the estimator's own response to ``q^2 / 12`` white noise, and the rms
difference between the raw and the smoothed angle (about ``q / sqrt(12)`` when the corner is
right; larger means the corner cuts real motion). Quantisation of a turning shaft is not white:
measured errors were 0.4-0.5 times the Butterworth estimate but 1.7-2.8 times the Fourier one
(``benchmarks/bench_processing.py``).

Memory: a run is smoothed in pieces; :func:`drive_excitation_at` samples the outputs at given
times piece by piece (never the whole record's outputs), and :func:`mean_drive_cycle` averages
a phi_F grid's revolutions as the pieces come, handing on whole revolutions as soon as no later
piece touches them (never the outputs on the whole grid).
"""

from __future__ import annotations

import hashlib
import logging
import math
import threading
from collections import OrderedDict
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from rigval.acquisition.errors import ConfigError, DataError
from rigval.acquisition.sample_times import (
    SampleTimes,
    sample_times,
    time_coordinate,
    times_of,
    times_window,
)
from rigval.acquisition.schema import append_history
from rigval.processing.arrays import FloatArray, IntArray, never_decreasing
from rigval.processing.encoder import (
    CountAngle,
    count_angle,
    counts_to_angle,
    remove_index_resets,
    unwrap_counts,
)
from rigval.processing.errors import DriveRateError
from rigval.processing.filters import (
    DEFAULT_CHUNK,
    PadType,
    butter_sos,
    contiguous_runs,
    default_padlen,
    filtfilt_pieces,
)
from rigval.processing.periodic_fit import PeriodicFit, fit_periodic, refine_period
from rigval.processing.row_mean import RowMean
from rigval.processing.scipy_signal import sosfreqz

__all__ = ["DriveAngle", "drive_angle", "drive_excitation", "drive_excitation_at",
           "mean_drive_cycle", "quantisation_noise"]

logger = logging.getLogger(__name__)

_Triple = tuple[FloatArray, FloatArray, FloatArray]
Method = Literal["butterworth", "fourier"]


@dataclass(frozen=True)
class DriveAngle:
    """A smoothed drive angle with its derivatives and their error estimate.

    Attributes
    ----------
    time : numpy.ndarray or SampleTimes
        Sample times in s (as given to :func:`drive_angle`).
    angle, velocity, acceleration : numpy.ndarray
        Angle (rad, unwrapped), angular velocity (rad/s), angular acceleration (rad/s^2); NaN where
        a run was too short or samples were invalid.
    angle_noise, velocity_noise, acceleration_noise : float
        Rms noise quantisation alone leaves on each output (rad, rad/s, rad/s^2).
    residual_rms : float
        Rms of raw minus smoothed angle in rad.
    method : str
        ``"butterworth"`` or ``"fourier"``.
    parameters : dict
        Corner, order or harmonics used.
    """

    time: FloatArray | SampleTimes
    angle: FloatArray
    velocity: FloatArray
    acceleration: FloatArray
    angle_noise: float
    velocity_noise: float
    acceleration_noise: float
    residual_rms: float
    method: str
    parameters: dict[str, float]


def quantisation_noise(step_rad: float, fs: float, sos: NDArray[np.float64] | None = None,
                       ) -> tuple[float, float, float]:
    """Return the rms noise on angle, speed and acceleration from angle quantisation.

    White noise of variance ``step^2 / 12`` passes the zero-phase filter (``|H|^2``) and the
    central first and second differences (``j sin w / dt``, ``(2 cos w - 2) / dt^2``).

    Parameters
    ----------
    step_rad : float
        Quantisation step in rad (``2 pi / CPR``).
    fs : float
        Sampling rate in Hz.
    sos : numpy.ndarray, optional
        The smoothing filter (second-order sections); None for raw differences.

    Returns
    -------
    (float, float, float)
        Noise rms in rad, rad/s and rad/s^2.
    """
    w = np.linspace(0.0, np.pi, 1 << 14)
    power = np.ones_like(w) if sos is None else np.abs(sosfreqz(sos, worN=w)[1]) ** 4
    variance = step_rad**2 / 12.0
    dt = 1.0 / fs
    gains = (np.ones_like(w), np.sin(w) / dt, (2.0 - 2.0 * np.cos(w)) / dt**2)
    return tuple(float(np.sqrt(variance * np.trapezoid(power * g**2, w) / np.pi))
                 for g in gains)


#: Most samples a Fourier trend is fitted to (evenly thinned beyond that: bounded memory).
_FIT_SAMPLES = 200_000
#: Most samples the Butterworth method's trend is fitted to.
_TREND_SAMPLES = 50_000
#: Samples smoothed at once in a long run (bounded memory; pieces overlap by 24 fs / f_c).
_PIECE = DEFAULT_CHUNK


def _fourier_fit(t: FloatArray | SampleTimes, theta: FloatArray | CountAngle, harmonics: int,
                 max_samples: int = _FIT_SAMPLES) -> PeriodicFit:
    """Return the mean-speed Fourier series of an angle record (module docstring).

    The fundamental W is the mean speed: the period ``2 pi / W`` starts from the straight line
    through the record and is refined by Gauss-Newton on the fit's residual
    (:func:`~rigval.processing.periodic_fit.refine_period`). At most ``max_samples`` evenly
    thinned samples are fitted (bounded time). A record fitted lately (the same samples and
    harmonics: a run's main drive is smoothed for its phi_F and again for its mean cycle) gets
    the fit it got then (:func:`_recent_fit`).
    """
    thin = max(1, t.size // max_samples)
    t, theta = t[::thin], theta[::thin]
    key = _record_key(t, theta, harmonics)
    fit = _recent_fit(key)
    if fit is None:
        slope = float(np.polyfit(t - t.mean(), theta, 1)[0])
        period = refine_period(t, theta, 2.0 * np.pi / abs(slope), harmonics)
        fit = fit_periodic(t, theta, period, harmonics)
        fit.coef.setflags(write=False)  # shared by the calls that find it
    _keep_fit(key, fit)
    return fit


#: Fourier fits of the records fitted last (:func:`_fourier_fit`), the most recent last.
_RECENT_FITS: OrderedDict[bytes, PeriodicFit] = OrderedDict()
#: Fits :data:`_RECENT_FITS` holds at most.
_FITS_KEPT = 4
_RECENT_FITS_LOCK = threading.Lock()


def _record_key(t: FloatArray, theta: FloatArray, harmonics: int) -> bytes:
    """Return a digest of an angle record's samples and a fit's harmonics (SHA-256)."""
    digest = hashlib.sha256()
    for samples in (t, theta):
        data = np.ascontiguousarray(samples, dtype=np.float64)
        digest.update(np.int64(data.size).tobytes())
        digest.update(data)
    digest.update(np.int64(harmonics).tobytes())
    return digest.digest()


def _recent_fit(key: bytes) -> PeriodicFit | None:
    """Return the fit kept under ``key`` (:func:`_record_key`), or None."""
    with _RECENT_FITS_LOCK:
        return _RECENT_FITS.get(key)


def _keep_fit(key: bytes, fit: PeriodicFit) -> None:
    """Keep ``fit`` under ``key`` as the most recent; drop the oldest beyond :data:`_FITS_KEPT`."""
    with _RECENT_FITS_LOCK:
        _RECENT_FITS.pop(key, None)
        _RECENT_FITS[key] = fit
        while len(_RECENT_FITS) > _FITS_KEPT:
            _RECENT_FITS.popitem(last=False)


def _butterworth_pieces(t: FloatArray | SampleTimes, theta: FloatArray | CountAngle, fs: float,
                        cutoff_hz: float, order: int, trend_harmonics: int, padtype: PadType,
                        derivatives: bool = True
                        ) -> Iterator[tuple[int | FloatArray, ...]]:
    """Smooth one gap-free run piece by piece: yield ``lo, hi, angle, velocity, acceleration``.

    The run is filtered in the pieces of :func:`~rigval.processing.filters.filtfilt_pieces`
    (bounded memory); each piece's differences use the filtered samples one beyond its ends,
    which its read window holds, so they equal the whole run's to rounding. Without
    ``derivatives`` only ``lo, hi, angle`` (the same angle; memory). A piece's arrays are let
    go before the next is smoothed.
    """
    # The trend's harmonics lie inside the pass band, so its own noise is filtered like the
    # data's: a thinned fit is enough.
    trend = _fourier_fit(t, theta, trend_harmonics, max_samples=_TREND_SAMPLES)
    sos = butter_sos(cutoff_hz, fs, order=order)
    n = t.size
    dt = 1.0 / fs

    window: dict[tuple[int, int], _Triple] = {}  # the trend over the last piece read

    def remainder(a: int, b: int) -> FloatArray:
        window.clear()
        window[a, b] = trend(t[a:b])
        return theta[a:b] - window[a, b][0]

    for lo, hi, keep_lo, keep_hi, y in filtfilt_pieces(
            remainder, n, sos, default_padlen(cutoff_hz, fs), padtype, _PIECE):
        ext_lo, ext_hi = max(keep_lo - 1, lo), min(keep_hi + 1, hi)
        smooth = y[ext_lo - lo:ext_hi - lo]
        inner = slice(keep_lo - ext_lo, keep_lo - ext_lo + keep_hi - keep_lo)
        # the trend's parts copied where kept, the rest of the trend let go (memory)
        parts = [part[keep_lo - lo:keep_hi - lo].copy()
                 for part in window.pop((lo, hi))[:3 if derivatives else 1]]
        parts[0] += smooth[inner]
        if derivatives:
            parts[1] += np.gradient(smooth, dt)[inner]
            parts[2] += _second_difference(smooth, dt)[inner]
        yield keep_lo, keep_hi, *parts
        del parts  # let go before the next piece is smoothed (memory)


def _second_difference(smooth: FloatArray, dt: float) -> FloatArray:
    """Return the central second difference of samples ``dt`` s apart, one-sided at the ends.

    Units of ``smooth`` per s^2.
    """
    scratch = smooth[2:] + smooth[:-2]
    scratch -= 2.0 * smooth[1:-1]
    scratch /= dt**2
    return np.concatenate((scratch[:1], scratch, scratch[-1:]))


def _counter_angle(raw: np.ndarray, counts_per_rev: float, *, gear_ratio: float = 1.0,
                   direction: float = 1.0, index_reset: bool = False
                   ) -> FloatArray | CountAngle:
    """Return a counter's unwrapped angle (rad), made piece by piece where it can be.

    Without index reloads the angle is a :class:`~rigval.processing.encoder.CountAngle`
    (memory: no whole-record counts or angle); with them the whole record's, as
    :func:`~rigval.processing.encoder.counts_to_angle` makes it.
    """
    if not index_reset:
        return count_angle(raw, counts_per_rev, gear_ratio=gear_ratio, direction=direction)
    counts, _ = remove_index_resets(unwrap_counts(raw), counts_per_rev * gear_ratio,
                                    overwrite=True)
    return counts_to_angle(counts, counts_per_rev, gear_ratio=gear_ratio, direction=direction,
                           overwrite=True)


def _run(theta: FloatArray | CountAngle, start: int, stop: int) -> FloatArray | CountAngle:
    """Return samples ``start ... stop - 1`` of an angle (a lazy one stays lazy)."""
    return theta.window(start, stop) if isinstance(theta, CountAngle) else theta[start:stop]


def drive_angle(time: ArrayLike | SampleTimes, angle: ArrayLike, *, fs: float, step_rad: float,
                method: Method = "butterworth", cutoff_hz: float | None = None, order: int = 8,
                harmonics: int = 8, trend_harmonics: int = 4, padtype: PadType = "line",
                segment: ArrayLike | None = None,
                valid: ArrayLike | None = None, derivatives: bool = True) -> DriveAngle:
    """Smooth a quantised drive angle and differentiate it twice.

    Parameters
    ----------
    time : array_like or SampleTimes
        Sample times in s (a lazy axis's computed piece by piece).
    angle : array_like or CountAngle
        Unwrapped raw angle in rad (e.g. :func:`~rigval.processing.encoder.counts_to_angle`),
        increasing (turn the sign with ``direction`` there if needed); a
        :class:`~rigval.processing.encoder.CountAngle` is read piece by piece (memory).
    fs : float
        Sampling rate in Hz.
    step_rad : float
        Angle quantisation step in rad (``2 pi / CPR``), for the error estimate.
    method : {"butterworth", "fourier"}
        Estimator (module docstring).
    cutoff_hz : float, optional
        Butterworth corner in Hz. Default: 8 times the mean revolution rate (twice the 4th
        harmonic).
    order : int, default 8
        Butterworth order of one pass.
    harmonics : int, default 8
        Harmonics of the mean-speed Fourier series of ``"fourier"``.
    trend_harmonics : int, default 4
        Harmonics of the Fourier trend removed before the Butterworth filter (0: a straight
        line); it keeps the filter's edge transients small. Few: the trend's own noise is not
        filtered, so keep ``trend_harmonics * rate`` inside the pass band.
    padtype : {"line", "zero", "odd", "even"}, default "line"
        Edge extension of the remainder (see :func:`~rigval.processing.filters.zero_phase`):
        ``"line"`` works whether or not real motion is left in the remainder (speed changes);
        ``"zero"`` is slightly better when the remainder is pure noise about the trend.
    segment, valid : array_like, optional
        Stream ``segment`` and ``valid`` variables: each gap-free run is processed on its own.
    derivatives : bool, default True
        False: the velocity and acceleration are not kept (empty arrays; memory).

    Returns
    -------
    DriveAngle
        Angle, velocity, acceleration and their error estimate.
    """
    t = times_of(time)  # a lazy axis stays lazy: its times are computed piece by piece (memory)
    theta = angle if isinstance(angle, CountAngle) else np.asarray(angle, dtype=np.float64)
    if t.shape != theta.shape:
        raise DataError(f"angle has {theta.size} samples but time has {t.size}")
    runs = contiguous_runs(t.size, segment, valid)
    if not runs:
        raise DataError("no valid samples to compute a drive angle from")
    out = [np.full(t.size if derivatives or i == 0 else 0, np.nan) for i in range(3)]
    longest = max(runs, key=lambda r: r[1] - r[0])
    rate = (theta[longest[1] - 1] - theta[longest[0]]) / (t[longest[1] - 1] - t[longest[0]])
    params: dict[str, float] = {"harmonics": float(harmonics)}
    if method == "butterworth":
        if cutoff_hz is None:
            cutoff_hz = 8.0 * abs(rate) / (2 * np.pi)
            if cutoff_hz < 8.0 / (t[longest[1] - 1] - t[longest[0]]):
                raise DataError(f"the drive turns at {rate:.3g} rad/s on average, too slowly to "
                                "choose a filter corner from its speed",
                                hint="pass cutoff_hz explicitly (Hz)")
            if cutoff_hz >= fs / 2:
                raise DriveRateError(
                    f"cut-off {cutoff_hz} Hz (8 harmonics of the drive's {rate:.4g} rad/s) must "
                    f"lie between 0 and fs/2 = {fs / 2} Hz", where={"key": "cutoff_hz"},
                    hint="check the encoder's counts per revolution and the sampling rate",
                    corner_hz=float(cutoff_hz), fs=float(fs), rate_rad_s=float(rate))
        sos = butter_sos(cutoff_hz, fs, order=order)
        params = {"cutoff_hz": float(cutoff_hz), "order": float(order),
                  "trend_harmonics": float(trend_harmonics)}
        noise = quantisation_noise(step_rad, fs, sos)
        shortest = max(3 * (2 * sos.shape[0] + 1), 4 * trend_harmonics + 4)
    elif method == "fourier":
        # Each of the 2 K harmonic coefficients has variance 2 sigma^2 / n (white noise).
        sigma2 = step_rad**2 / 12.0 / sum(b - a for a, b in runs)
        kw = np.arange(1, harmonics + 1) * rate
        noise = (float(np.sqrt(sigma2 * (2 * harmonics + 2))),
                 float(np.sqrt(2 * sigma2 * np.sum(kw**2))),
                 float(np.sqrt(2 * sigma2 * np.sum(kw**4))))
        shortest = 4 * harmonics + 4
    else:
        raise ConfigError(f"method must be 'butterworth' or 'fourier', got {method!r}",
                          where={"key": "method"})
    squares, count = 0.0, 0
    for start, stop in runs:
        if stop - start <= shortest:
            continue
        if method == "butterworth":
            for lo, hi, *values in _butterworth_pieces(
                    times_window(t, start, stop), _run(theta, start, stop), fs, cutoff_hz, order,
                    trend_harmonics, padtype, derivatives):
                for target, value in zip(out, values, strict=False):
                    target[start + lo:start + hi] = value
                del values  # let go before the next piece is smoothed (memory)
        else:
            views = (out[0][start:stop], *(o[start:stop] if derivatives else np.empty(stop - start)
                                           for o in out[1:]))
            times = t[start:stop]
            _fourier_fit(times, theta[start:stop], harmonics)(times, out=views)
        for lo in range(start, stop, _PIECE):  # a piece at a time (memory)
            residual = theta[lo:min(lo + _PIECE, stop)] - out[0][lo:min(lo + _PIECE, stop)]
            squares += float(np.dot(residual, residual))
        count += stop - start
    rms = math.sqrt(squares / count) if count else math.nan
    return DriveAngle(t, out[0], out[1], out[2], *noise, rms, method, params)


def drive_excitation(stream: xr.Dataset, channel: str, *, counts_per_rev: float,
                     name: str = "theta", direction: float = 1.0, gear_ratio: float = 1.0,
                     method: Method = "butterworth", cutoff_hz: float | None = None,
                     order: int = 8, harmonics: int = 8, index_reset: bool = False,
                     derivatives: bool = True) -> xr.Dataset:
    """Return a drive angle and its derivatives from an encoder counter channel of a stream.

    Parameters
    ----------
    stream : xarray.Dataset
        A stream or an aligned stream (the result keeps its ``time``).
    channel : str
        Counter channel holding the raw (possibly wrapping) counts.
    counts_per_rev : float
        Counts per revolution (8192 for 2048 lines X4).
    name : str, default "theta"
        Prefix of the output variables ``<name>``, ``<name>_dot``, ``<name>_ddot``.
    direction, gear_ratio : float
        As in :func:`~rigval.processing.encoder.counts_to_angle`.
    method, cutoff_hz, order, harmonics
        As in :func:`drive_angle`.
    index_reset : bool, default False
        The counter reloads at the Z index (undone with
        :func:`~rigval.processing.encoder.remove_index_resets`).
    derivatives : bool, default True
        False: only ``<name>`` (memory).

    Returns
    -------
    xarray.Dataset
        Variables ``<name>`` (rad), ``<name>_dot`` (rad s-1), ``<name>_ddot`` (rad s-2) on the
        stream's ``time``, with the noise estimates as attributes (``noise_rms``) and a history
        line.
    """
    fs = float(stream.attrs["fs_nominal"])
    raw = _counter_angle(stream[channel].to_numpy(), counts_per_rev, gear_ratio=gear_ratio,
                         direction=direction, index_reset=index_reset)
    result = drive_angle(sample_times(stream), raw, fs=fs,
                         step_rad=2 * np.pi / (counts_per_rev * gear_ratio), method=method,
                         cutoff_hz=cutoff_hz, order=order, harmonics=harmonics,
                         segment=stream["segment"].to_numpy(), valid=stream["valid"].to_numpy(),
                         derivatives=derivatives)
    source = stream[channel].attrs.get("source_channel", channel)
    common = {"source_channel": source, "method": method,
              **result.parameters,
              "residual_rms_rad": result.residual_rms}
    variables = {name: ("time", result.angle, {**common, "units": "rad",
                                               "long_name": f"drive angle {name}",
                                               "noise_rms": result.angle_noise})}
    if derivatives:
        variables[f"{name}_dot"] = ("time", result.velocity, {
            **common, "units": "rad s-1", "long_name": f"angular velocity of {name}",
            "noise_rms": result.velocity_noise})
        variables[f"{name}_ddot"] = ("time", result.acceleration, {
            **common, "units": "rad s-2", "long_name": f"angular acceleration of {name}",
            "noise_rms": result.acceleration_noise})
    out = xr.Dataset(variables, coords=time_coordinate(stream), attrs=dict(stream.attrs))
    append_history(out, f"processing.drive_excitation {channel} -> {name} ({method}, "
                        f"{result.parameters})")
    return out


def _in_time_order(flat: FloatArray
                   ) -> tuple[FloatArray, Callable[[int, int], slice | IntArray]]:
    """Return times in increasing order and where the ``a:b``-th of them sit in ``flat``.

    A stable sort; times already in order (a grid's rows one revolution after the other) are
    taken as they are, without the sort's index and copy (memory; the same order).
    """
    if never_decreasing(flat):
        return flat, slice
    index = np.argsort(flat, kind="stable")
    return flat[index], lambda a, b: index[a:b]


@dataclass
class _RunEnds:
    """The first and the last smoothed sample of each gap-free run met so far, in time order.

    Times outside every run take the values linear between them, clamped at the record's ends.
    """

    times: list[float] = field(default_factory=list)
    values: list[FloatArray] = field(default_factory=list)

    def add(self, time: float, values: FloatArray) -> None:
        """Add a run's end: its time (s) and its angle, speed and acceleration."""
        self.times.append(time)
        self.values.append(values)

    def fill(self, at: FloatArray, values: FloatArray) -> None:
        """Give the times ``at`` outside every run (NaN in ``values[0]``) their values, in place.

        ``values``: (3, at.size), angle, speed and acceleration at ``at``.
        """
        rest = np.isnan(values[0])
        ends = np.asarray(self.values)
        for k in range(3):
            values[k, rest] = np.interp(at[rest], np.asarray(self.times), ends[:, k])


def _sampled_pieces(stream: xr.Dataset, channel: str, ordered: FloatArray, ends: _RunEnds, *,
                    counts_per_rev: float, direction: float, cutoff_hz: float | None,
                    order: int, index_reset: bool
                    ) -> Iterator[tuple[int, int, FloatArray, float]]:
    """Smooth a drive piece by piece and yield its values at the times each piece covers.

    Each gap-free run is smoothed in the pieces of :func:`_butterworth_pieces`; a piece's
    outputs are interpolated linearly over its sample times (``time`` less the channel's
    ``input_delay_s``) at the times ``ordered`` (increasing) it covers, and between the last
    sample of the piece before and its first; each run's end samples go to ``ends``.

    Yields
    ------
    (int, int, numpy.ndarray, float)
        ``a, b, values, settled_s``: the angle (rad), speed (rad/s) and acceleration (rad/s^2)
        at ``ordered[a:b]``, (3, b - a); no later item is at a time before ``settled_s`` (s)
        when the stream's times increase.

    Raises
    ------
    DataError
        When no run is long enough to smooth (after the last item).
    """
    fs = float(stream.attrs["fs_nominal"])
    delay = float(stream[channel].attrs.get("input_delay_s", 0.0))
    theta = _counter_angle(stream[channel].to_numpy(), counts_per_rev, direction=direction,
                           index_reset=index_reset)
    t = sample_times(stream)  # a lazy axis's times computed piece by piece (memory)
    runs = contiguous_runs(t.size, stream["segment"].to_numpy(), stream["valid"].to_numpy())
    if not runs:
        raise DataError(f"no valid samples of {channel} to compute a drive angle from")
    if cutoff_hz is None:
        start, stop = max(runs, key=lambda r: r[1] - r[0])
        rate = (theta[stop - 1] - theta[start]) / (t[stop - 1] - t[start])
        cutoff_hz = 8.0 * abs(rate) / (2 * np.pi)
        if cutoff_hz < 8.0 / (t[stop - 1] - t[start]):
            raise DataError(f"the drive turns at {rate:.3g} rad/s on average, too slowly to "
                            "choose a filter corner from its speed",
                            hint="pass cutoff_hz explicitly (Hz)")
    trend_harmonics = 4  # drive_angle's default
    shortest = max(3 * (2 * butter_sos(cutoff_hz, fs, order=order).shape[0] + 1),
                   4 * trend_harmonics + 4)
    for start, stop in runs:
        if stop - start <= shortest:
            continue
        previous: tuple[float, FloatArray] | None = None
        for lo, hi, *piece in _butterworth_pieces(times_window(t, start, stop),
                                                  _run(theta, start, stop), fs, cutoff_hz, order,
                                                  trend_harmonics, "line"):
            times = t[start + lo:start + hi] - delay
            first = np.array([p[0] for p in piece])
            if previous is None:
                ends.add(float(times[0]), first)
            else:  # between the last sample of the piece before and this piece's first
                a = np.searchsorted(ordered, previous[0], side="left")
                b = np.searchsorted(ordered, times[0], side="right")
                yield a, b, np.array([np.interp(ordered[a:b], [previous[0], times[0]],
                                                [previous[1][k], first[k]])
                                      for k in range(3)]), previous[0]
            a = np.searchsorted(ordered, times[0], side="left")
            b = np.searchsorted(ordered, times[-1], side="right")
            # later items start at this piece's last sample (the interpolation to the next)
            yield a, b, np.array([np.interp(ordered[a:b], times, piece[k])
                                  for k in range(3)]), float(times[-1])
            previous = (float(times[-1]), np.array([p[-1] for p in piece]))
            del times, piece  # let go before the next piece is smoothed (memory)
        if previous is not None:
            ends.add(*previous)
    if not ends.times:
        raise DataError(f"no run of {channel} is long enough to smooth "
                        f"(> {shortest} samples)")


def drive_excitation_at(stream: xr.Dataset, channel: str, at: ArrayLike, *,
                        counts_per_rev: float, direction: float = 1.0,
                        cutoff_hz: float | None = None, order: int = 8,
                        index_reset: bool = False) -> _Triple:
    """Return a drive's angle, speed and acceleration at given times, in bounded memory.

    The same as :func:`drive_excitation` (method ``"butterworth"``) followed by linear
    interpolation of each output over its finite samples at the channel's sample times
    (``time`` less the channel's ``input_delay_s``), clamped at the record's ends and bridging
    gaps linearly, but the outputs are never held for the whole record: each piece of each
    gap-free run is smoothed, differentiated, sampled at the times it covers and dropped.
    Equal to the whole-record path to rounding (``tests/processing/test_excitation_filters.py``).

    Parameters
    ----------
    stream : xarray.Dataset
        A stream or an aligned stream.
    channel : str
        Counter channel holding the raw (possibly wrapping) counts.
    at : array_like
        Times in s (any shape) on the stream's clock.
    counts_per_rev, direction, cutoff_hz, order, index_reset
        As in :func:`drive_excitation`.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray, numpy.ndarray)
        Angle (rad), speed (rad/s) and acceleration (rad/s^2), each shaped like ``at``.

    Raises
    ------
    DataError
        When no run is long enough to smooth.
    """
    targets = np.asarray(at, dtype=np.float64)
    flat = targets.ravel()
    ordered, order_index = _in_time_order(flat)
    values = np.full((3, flat.size), np.nan)
    ends = _RunEnds()
    for a, b, piece, _ in _sampled_pieces(stream, channel, ordered, ends,
                                          counts_per_rev=counts_per_rev, direction=direction,
                                          cutoff_hz=cutoff_hz, order=order,
                                          index_reset=index_reset):
        values[:, order_index(a, b)] = piece
    ends.fill(flat, values)
    return tuple(v.reshape(targets.shape) for v in values)


class _PendingRows:
    """A grid's drive values from its first row not handed on yet, handed on in whole rows.

    The grid's times ``at`` (flattened, row after row, increasing) are written piece by piece
    (:func:`_sampled_pieces`); a row is handed on once no later piece writes it and its times
    outside every run lie before the last run end met (so the ends on both sides of them are
    known), its values then equal to :func:`drive_excitation_at`'s.
    """

    def __init__(self, at: FloatArray, columns: int) -> None:
        self._at = at
        self._columns = columns
        self._start = 0  # the first time held
        self._values = np.empty((3, 0))

    def write(self, a: int, b: int, values: FloatArray) -> None:
        """Write the values (3, b - a) at the times ``at[a:b]`` (none handed on yet)."""
        self._hold(b)
        self._values[:, a - self._start:b - self._start] = values

    def settled(self, before: int, ends: _RunEnds) -> FloatArray | None:
        """Hand on the whole rows before time ``before`` that are final, (3, rows, columns).

        None when there is none.
        """
        stop = self._start + (before - self._start) // self._columns * self._columns
        self._hold(stop)
        # A time outside every run (NaN) takes the run ends on both sides of it: the row of
        # the first such time at or after the last end met waits, with the rows after it, for
        # the next end (``ends`` holds the first run's start once anything is written).
        outside = np.flatnonzero(np.isnan(self._values[0, :stop - self._start]))
        open_times = self._at[self._start + outside] >= ends.times[-1]
        if open_times.any():
            first = int(outside[np.argmax(open_times)])
            stop = self._start + first // self._columns * self._columns
        return self._handed_on(stop, ends)

    def rest(self, ends: _RunEnds) -> FloatArray | None:
        """Hand on every row left, once every piece is written, (3, rows, columns)."""
        self._hold(self._at.size)
        return self._handed_on(self._at.size, ends)

    def _hold(self, stop: int) -> None:
        """Hold the times up to ``stop`` (NaN until written)."""
        held = self._start + self._values.shape[1]
        if stop > held:
            self._values = np.concatenate((self._values, np.full((3, stop - held), np.nan)),
                                          axis=1)

    def _handed_on(self, stop: int, ends: _RunEnds) -> FloatArray | None:
        """Fill the times up to ``stop`` outside every run, let them go and return them."""
        if stop <= self._start:
            return None
        count = stop - self._start
        block = self._values[:, :count]
        ends.fill(self._at[self._start:stop], block)
        self._values = self._values[:, count:].copy()  # the rows handed on let go (memory)
        self._start = stop
        return block.reshape(3, count // self._columns, self._columns)


def _streamable(stream: xr.Dataset, times: FloatArray) -> bool:
    """Return True when a grid's drive values can be handed on row by row (:class:`_PendingRows`).

    Rows of at least two columns (:class:`~rigval.processing.row_mean.RowMean`) whose times come
    in order, on a stream whose times increase (so later pieces are later in time).
    """
    return (times.ndim == 2 and times.shape[0] > 0 and times.shape[1] >= 2
            and never_decreasing(times.ravel())
            and never_decreasing(sample_times(stream), strictly=True))  # chunk by chunk


def _drive_rows(stream: xr.Dataset, channel: str, times: FloatArray, *, counts_per_rev: float,
                direction: float, index_reset: bool) -> Iterator[FloatArray]:
    """Yield a drive's angle, speed and acceleration on a grid, blocks of whole rows in order.

    Each block is (3, rows, n_angle): the values :func:`drive_excitation_at` takes at those
    rows of ``times`` (n_cycle, n_angle), a grid that can be handed on row by row
    (:func:`_streamable`).
    """
    settings = {"counts_per_rev": counts_per_rev, "direction": direction,
                "index_reset": index_reset}
    flat = times.ravel()
    ends = _RunEnds()
    pending = _PendingRows(flat, times.shape[1])
    for a, b, values, settled_s in _sampled_pieces(stream, channel, flat, ends, cutoff_hz=None,
                                                   order=8, **settings):
        pending.write(a, b, values)
        block = pending.settled(int(np.searchsorted(flat, settled_s, side="left")), ends)
        if block is not None:
            yield block
    block = pending.rest(ends)
    if block is not None:
        yield block


class _CycleMean:
    """A drive's mean over revolutions per grid angle, fed blocks of whole rows in order.

    Each row's angle is counted from ``angle_at_reference`` at the first row's first point
    and brought to that branch (whole turns removed); the rows are averaged as
    :class:`~rigval.processing.row_mean.RowMean` does, so the means equal those of the whole
    grid's arrays bit for bit.
    """

    def __init__(self, columns: int, angle_at_reference: float) -> None:
        self._angle_at_reference = angle_at_reference
        self._first: np.float64 | None = None  # the first row's first angle, as sampled
        self._zero: np.float64 | None = None   # and as counted
        self._means = tuple(RowMean(columns) for _ in range(3))

    def add(self, theta: FloatArray, omega: FloatArray, alpha: FloatArray) -> None:
        """Add rows (n_rows, n_angle) of angle (rad), speed (rad/s), acceleration (rad/s^2)."""
        if self._first is None:
            self._first = theta[0, 0]
        theta = theta - self._first + self._angle_at_reference
        if self._zero is None:
            self._zero = theta[0, 0]
        theta -= 2.0 * np.pi * np.round((theta[:, :1] - self._zero) / (2.0 * np.pi))
        for mean, rows in zip(self._means, (theta, omega, alpha), strict=True):
            mean.add(rows)

    def means(self) -> _Triple:
        """Return the mean angle, speed and acceleration per grid angle, (n_angle,) each."""
        theta, omega, alpha = (mean.mean() for mean in self._means)
        return theta, omega, alpha


def mean_drive_cycle(stream: xr.Dataset, channel: str, times: ArrayLike, *,
                     counts_per_rev: float, direction: float = 1.0, index_reset: bool = False,
                     angle_at_reference: float = 0.0) -> _Triple:
    """Return a drive's angle, speed and acceleration averaged over revolutions per grid angle.

    Each is sampled at the reference times of a phi_F grid, one row per revolution (the values
    of :func:`drive_excitation_at`), then averaged over the rows. The angle is counted from
    ``angle_at_reference`` at the first revolution's first grid point, each revolution brought
    to the same branch (whole turns removed) before averaging. The rows are averaged as their
    pieces are smoothed, a block of revolutions at a time, never held for the whole grid
    (memory: 3 x 8 bytes a grid point); the means equal those of the whole grid's samples bit
    for bit (``numpy.mean``). A grid whose times are not in order (or of one column, or on a
    stream whose times do not increase) is sampled whole.

    Parameters
    ----------
    stream : xarray.Dataset
        The aligned stream holding the drive's encoder.
    channel : str
        The encoder's counter channel.
    times : array_like
        Times of the grid on the stream's clock, (n_cycle, n_angle), s.
    counts_per_rev, direction, index_reset
        As in :func:`drive_excitation`.
    angle_at_reference : float, default 0
        The drive's angle at the first grid point of the first revolution, rad.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray, numpy.ndarray)
        Mean angle (rad), speed (rad/s) and acceleration (rad/s^2) per grid angle, (n_angle,).
    """
    times = np.asarray(times, dtype=np.float64)
    if not _streamable(stream, times):
        theta, omega, alpha = drive_excitation_at(stream, channel, times,
                                                  counts_per_rev=counts_per_rev,
                                                  direction=direction, index_reset=index_reset)
        theta = theta - theta[0, 0] + angle_at_reference
        theta -= 2.0 * np.pi * np.round((theta[:, :1] - theta[0, 0]) / (2.0 * np.pi))
        return theta.mean(axis=0), omega.mean(axis=0), alpha.mean(axis=0)
    mean = _CycleMean(times.shape[1], angle_at_reference)
    for theta, omega, alpha in _drive_rows(stream, channel, times,
                                           counts_per_rev=counts_per_rev, direction=direction,
                                           index_reset=index_reset):
        mean.add(theta, omega, alpha)
    return mean.means()
