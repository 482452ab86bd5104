"""Reference pulses: edges with hysteresis and sub-sample timing, missing and spurious pulses.

Detection (docs/processing.md): state levels from the histogram; a Schmitt trigger arms below
the low threshold (30 % by default) and fires above the high one (70 %); the edge time is the last
crossing of the 50 % mid level before the firing sample, interpolated linearly between the two
samples around it (0.03 sample rms for a band-limited step as a delta-sigma channel delivers it),
or, with ``refine="sinc"``, where the band-limited (windowed-sinc) reconstruction of the samples
crosses it (0.0014 sample rms at 60 dB SNR). Re-triggers within a hold-off are ignored
(debouncing). Detection never spans a gap, an invalid sample or a NaN.
:func:`stream_pulses` does all this for a stream channel, removes the module input delay and
classifies the edges per gap-free segment.

:func:`classify_pulses` checks the interval sequence against the local period: intervals near an
integer multiple m >= 2 of the period mean m - 1 missing pulses (their times are estimated);
pulses off the grid most of their neighbours share are flagged spurious; of two pulses that still
conflict, the one whose removal leaves the better interval goes.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Literal

import numpy as np
import xarray as xr
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import ArrayLike
from scipy.special import i0

from rigval.acquisition.errors import ChannelNotFoundError, ConfigError, DataError
from rigval.acquisition.sample_times import sample_times, times_of
from rigval.processing.arrays import BoolArray, FloatArray, IntArray
from rigval.processing.block_median import exact_median
from rigval.processing.clock_fit import input_delay
from rigval.processing.edge_shape import SYMMETRIC_BOUND, fit_edges
from rigval.processing.filters import contiguous_runs

__all__ = [
    "SYMMETRIC_BOUND",
    "EdgeTiming",
    "PulseTrain",
    "StreamPulses",
    "classify_pulses",
    "detect_edges",
    "state_levels",
    "stream_pulses",
    "time_edges",
]

logger = logging.getLogger(__name__)


#: Samples looked at once by :func:`state_levels` (bounded memory).
_LEVEL_CHUNK = 1 << 20
#: Half-length in samples and Kaiser beta of the windowed-sinc edge reconstruction.
_HALF_WINDOW = 32
_KAISER_BETA = 8.0


def state_levels(x: ArrayLike, bins: int = 100, *, mask: ArrayLike | None = None
                 ) -> tuple[float, float]:
    """Return the low and high state levels of a two-level signal (histogram modes, IEEE 181).

    Parameters
    ----------
    x : array_like
        Pulse signal samples (V or logic level); NaN ignored.
    bins : int, default 100
        Histogram bins between the minimum and maximum.
    mask : array_like of bool, optional
        Only these samples (``x[mask]``, without copying them).

    Returns
    -------
    (float, float)
        Low and high level in the unit of ``x``: the mean of the samples within two bins of the
        most populated bin of the lower and of the upper half of the range (the bin centre alone
        would bias the 50 % level by up to half a bin).
    """
    data = np.asarray(x, dtype=np.float64)
    keep = None if mask is None else np.asarray(mask, dtype=bool)

    def parts() -> Iterator[FloatArray]:  # the usable samples a chunk at a time (memory)
        for lo in range(0, data.size, _LEVEL_CHUNK):
            part = data[lo:lo + _LEVEL_CHUNK]
            ok = np.isfinite(part)
            if keep is not None:
                ok &= keep[lo:lo + _LEVEL_CHUNK]
            yield part if ok.all() else part[ok]

    low = high = None
    for part in parts():
        if part.size:
            low = part.min() if low is None else min(low, part.min())
            high = part.max() if high is None else max(high, part.max())
    if low is None or low == high:
        raise DataError("a pulse signal needs two distinct levels; the channel is constant or "
                        "empty", hint="check the channel name and the sensor wiring")
    edges = np.linspace(low, high, bins + 1)
    # bins of equal width: numpy's arithmetic binning, the same counts as searching ``edges``
    counts = sum(np.histogram(part, bins=bins, range=(low, high))[0] for part in parts())
    half = bins // 2
    levels = []
    for mode in (int(np.argmax(counts[:half])), half + int(np.argmax(counts[half:]))):
        lo, hi = edges[max(mode - 2, 0)], edges[min(mode + 3, bins)]
        total, number = 0.0, 0
        for part in parts():
            inside = part[(part >= lo) & (part <= hi)]
            total += float(inside.sum())
            number += inside.size
        levels.append(total / number)
    return levels[0], levels[1]


def _sinc_crossings(x: FloatArray, index: IntArray, mid: float, *, negate: bool = False
                    ) -> FloatArray:
    """Return the sub-sample indices where the band-limited reconstruction of x crosses ``mid``.

    The reconstruction is a Kaiser-windowed sinc (beta 8, +-32 samples) through the samples
    (of ``-x`` with ``negate``: only the samples around the edges are negated);
    each crossing between samples ``index`` and ``index + 1`` is found by the Illinois method
    (regula falsi that halves the retained end's value), all edges at once, to 1e-10 sample.
    NaN where the window leaves ``x`` or the reconstruction does not cross ``mid`` between the
    two samples.
    """
    out = np.full(index.size, np.nan)
    inside = (index - _HALF_WINDOW + 1 >= 0) & (index + _HALF_WINDOW + 1 <= x.size)
    if not inside.any():
        return out
    offsets = np.arange(-_HALF_WINDOW + 1, _HALF_WINDOW + 1)
    samples = x[index[inside, None] + offsets[None, :]]
    if negate:
        np.negative(samples, out=samples)
    norm = float(i0(_KAISER_BETA))

    def level(position: FloatArray, rows: IntArray) -> FloatArray:
        d = position[:, None] - offsets[None, :]
        window = i0(_KAISER_BETA * np.sqrt(np.clip(1.0 - (d / _HALF_WINDOW) ** 2, 0.0, None)))
        return np.sum(samples[rows] * np.sinc(d) * window, axis=1) / norm - mid

    every = np.arange(samples.shape[0])
    lo, hi = np.zeros(every.size), np.ones(every.size)
    f_lo, f_hi = level(lo, every), level(hi, every)
    bracketed = (f_lo <= 0) & (f_hi >= 0)
    root = np.where(f_lo == 0, 0.0, np.where(f_hi == 0, 1.0, np.nan))
    active = np.flatnonzero(bracketed & np.isnan(root))
    side = np.zeros(every.size, dtype=np.int8)  # end kept last time: -1 low, +1 high
    for _ in range(100):
        if active.size == 0:
            break
        a, b, fa, fb = lo[active], hi[active], f_lo[active], f_hi[active]
        c = (a * fb - b * fa) / (fb - fa)
        fc = level(c, active)
        low_side = fc < 0
        lo[active] = np.where(low_side, c, a)
        f_lo[active] = np.where(low_side, fc, fa)
        hi[active] = np.where(low_side, b, c)
        f_hi[active] = np.where(low_side, fb, fc)
        # Illinois: an end kept twice in a row has its value halved
        kept = np.where(low_side, 1, -1).astype(np.int8)
        again = side[active] == kept
        f_hi[active[again & low_side]] *= 0.5
        f_lo[active[again & ~low_side]] *= 0.5
        side[active] = kept
        done = (fc == 0) | (hi[active] - lo[active] < 1e-10) | (
            np.abs(c - np.where(low_side, a, b)) < 1e-10)
        root[active[done]] = c[done]
        active = active[~done]
    root[active] = 0.5 * (lo[active] + hi[active])
    out[np.flatnonzero(inside)] = index[inside] + root
    return out


def _trigger(run: FloatArray, low: float, high: float, mid: float, negate: bool
             ) -> tuple[IntArray, IntArray]:
    """Return where the Schmitt trigger fires in a gap-free run, and its upward mid crossings.

    The trigger arms at a sample ``<= low`` and fires at the next sample ``>= high`` (samples
    between the thresholds are passed over); an upward crossing ``j`` has sample ``j`` below
    ``mid`` and ``j + 1`` at or above it. Of ``-run`` with ``negate``. Worked a block of
    :data:`_LEVEL_CHUNK` samples at a time, the last armed state carried from block to block
    (memory: no whole-run state or index arrays); indices into the run.
    """
    fires, ups = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)]
    armed = np.int8(0)  # the state of the last sample outside the band; 0: none yet
    for lo in range(0, run.size, _LEVEL_CHUNK):
        hi = min(lo + _LEVEL_CHUNK, run.size)
        part = run[lo:min(hi + 1, run.size)]  # one sample more: the crossing at the block's end
        if negate:
            part = np.negative(part)
        state = np.zeros(hi - lo, dtype=np.int8)
        state[part[:hi - lo] <= low] = -1
        state[part[:hi - lo] >= high] = 1
        marked = np.flatnonzero(state)
        labels = state[marked]
        previous = np.concatenate(([armed], labels[:-1]))
        fires.append(lo + marked[(labels == 1) & (previous == -1)])
        if marked.size:
            armed = labels[-1]
        ups.append(lo + np.flatnonzero((part[:-1] < mid) & (part[1:] >= mid)))
    return np.concatenate(fires), np.concatenate(ups)


def detect_edges(x: ArrayLike, time: ArrayLike, *, low: float | None = None,
                 high: float | None = None, polarity: Literal["rising", "falling"] = "rising",
                 holdoff_s: float = 0.0, segment: ArrayLike | None = None,
                 valid: ArrayLike | None = None,
                 refine: Literal["linear", "sinc"] = "linear") -> FloatArray:
    """Return sub-sample times of the edges of a pulse signal.

    Parameters
    ----------
    x : array_like
        Pulse signal samples (V or logic level).
    time : array_like
        Sample times in s (device clock; may jump at gaps).
    low, high : float, optional
        Hysteresis thresholds in the unit of ``x``. Default: 30 % and 70 % between the state
        levels of :func:`state_levels`. The edge time is taken at ``(low + high) / 2``.
    polarity : {"rising", "falling"}
        Which edge to time.
    holdoff_s : float, default 0
        Edges closer than this to the previous accepted edge are ignored (debouncing), in s.
    segment, valid : array_like, optional
        Stream ``segment`` and ``valid`` variables; no edge is timed across a gap or an invalid
        sample.
    refine : {"linear", "sinc"}
        Linear interpolation between the two samples around the mid crossing (0.03 sample rms
        on a band-limited step), or the crossing of the band-limited reconstruction through
        +-32 samples (Kaiser-windowed sinc; for analog pulses from delta-sigma channels:
        3e-6 sample without noise, 0.0008 sample at 60 dB SNR). Falls back to linear near the
        ends of a run.

    Returns
    -------
    numpy.ndarray
        Edge times in s, increasing.
    """
    data = np.asarray(x, dtype=np.float64)
    t = times_of(time)
    if data.shape != t.shape:
        raise DataError(f"pulse signal has {data.size} samples but time has {t.size}")
    if refine not in ("linear", "sinc"):
        raise ConfigError(f"refine must be 'linear' or 'sinc', got {refine!r}",
                          where={"key": "refine"})
    if low is None or high is None:
        level_lo, level_hi = state_levels(data, mask=valid)
        span = level_hi - level_lo
        low = level_lo + 0.3 * span if low is None else low
        high = level_lo + 0.7 * span if high is None else high
    if not low < high:
        raise ConfigError(f"hysteresis thresholds need low < high, got {low} and {high}",
                          where={"key": "low"})
    # a falling edge is a rising edge of -x: the thresholds turn here, the samples a block
    # at a time (no negated copy of the record)
    negate = polarity == "falling"
    if negate:
        low, high = -high, -low
    elif polarity != "rising":
        raise ConfigError(f"polarity must be 'rising' or 'falling', got {polarity!r}",
                          where={"key": "polarity"})
    mid = 0.5 * (low + high)
    times: list[FloatArray] = []
    usable = np.isfinite(data) if valid is None else np.asarray(valid, bool) & np.isfinite(data)
    for start, stop in contiguous_runs(data.size, segment, usable):
        run = data[start:stop]
        fires, ups = _trigger(run, low, high, mid, negate)
        if fires.size == 0:
            continue
        j = ups[np.searchsorted(ups, fires) - 1]
        before, after = run[j], run[j + 1]
        if negate:
            before, after = -before, -after
        position = j + (mid - before) / (after - before)
        if refine == "sinc":
            refined = _sinc_crossings(run, j, mid, negate=negate)
            position = np.where(np.isnan(refined), position, refined)
        i = np.minimum(position.astype(np.int64), run.size - 2)
        times.append(t[start + i] + (position - i) * (t[start + i + 1] - t[start + i]))
    edges = np.concatenate(times) if times else np.zeros(0)
    if holdoff_s > 0 and edges.size:
        keep = np.ones(edges.size, dtype=bool)
        last = edges[0]
        for n in range(1, edges.size):
            if edges[n] - last < holdoff_s:
                keep[n] = False
            else:
                last = edges[n]
        edges = edges[keep]
    return edges


@dataclass(frozen=True)
class PulseTrain:
    """Detected pulses checked against their local period.

    Attributes
    ----------
    times : numpy.ndarray
        All detected pulse times in s.
    spurious : numpy.ndarray of bool
        True for pulses that break the periodic grid.
    missing_times : numpy.ndarray
        Estimated times in s of pulses that should have occurred but were not detected.
    period : numpy.ndarray
        Local period in s at each good pulse (median of neighbouring intervals).
    """

    times: FloatArray
    spurious: BoolArray
    missing_times: FloatArray
    period: FloatArray

    @property
    def good(self) -> FloatArray:
        """Times (s) of the pulses not flagged spurious."""
        return self.times[~self.spurious]


def _local_period(intervals: FloatArray, window: int, tolerance: float = 0.15) -> FloatArray:
    """Return the local pulse period (s) at each interval: the mode, not the median.

    Within ``window`` intervals around each one, the candidate interval that most others equal
    (within ``tolerance`` of it; ties to the longer) is the period's first guess; the period is
    then the median of the intervals that are whole multiples of it, each divided by its
    multiple. A spurious pulse
    splits one interval into two short ones and a missing pulse doubles one, so a plain running
    median is pulled off by two spurious pulses in eleven intervals; the mode holds as long as
    single-period intervals are the most common kind in the window.
    """
    half = window // 2
    padded = np.concatenate((np.full(half, np.nan), intervals, np.full(half, np.nan)))
    rows = sliding_window_view(padded, 2 * half + 1)
    with np.errstate(invalid="ignore"):
        ratio = rows[:, None, :] / rows[:, :, None]
        votes = np.sum(np.abs(ratio - 1.0) <= tolerance, axis=2)
    votes[np.isnan(rows)] = -1
    # Ties go to the longer candidate: spurious pulses shorten intervals more often than
    # missing ones lengthen them (the two halves of a split interval can agree with each other).
    longest = float(np.nanmax(rows)) if rows.size else 1.0
    best = np.argmax(votes + 0.5 * np.nan_to_num(rows) / longest, axis=1)
    guess = rows[np.arange(rows.shape[0]), best]
    with np.errstate(invalid="ignore"):
        cycles = rows / guess[:, None]
        whole = np.round(cycles)
        regular = (whole >= 1) & (np.abs(cycles - whole) <= tolerance)
    return np.nanmedian(np.where(regular, rows / np.where(whole >= 1, whole, 1.0), np.nan),
                        axis=1)


def classify_pulses(times: ArrayLike, *, tolerance: float = 0.15, window: int = 11,
                    period_s: float | None = None) -> PulseTrain:
    """Flag spurious pulses and locate missing ones from the interval sequence.

    Parameters
    ----------
    times : array_like
        Pulse times in s, increasing.
    tolerance : float, default 0.15
        Largest deviation of an interval from an integer multiple of the local period, as a
        fraction of the period, still called regular.
    window : int, default 11
        Intervals in the running median that estimates the local period.
    period_s : float, optional
        Known nominal period in s (overrides the running median).

    Returns
    -------
    PulseTrain
        Flags and missing-pulse times.
    """
    t = np.asarray(times, dtype=np.float64)
    if t.size < 3:
        raise DataError(f"{t.size} pulses are too few to check their period (need 3)",
                        hint="check the pulse thresholds and that the shaft turned")
    intervals = np.diff(t)
    if period_s is None:
        period_at = np.interp(t, t[:-1] + intervals / 2, _local_period(intervals, window))
    else:
        period_at = np.full(t.size, float(period_s))

    def badness(i: int | None, j: int | None) -> float:
        if i is None or j is None:
            return 0.5
        cycles = (t[j] - t[i]) / (0.5 * (period_at[i] + period_at[j]))
        m = round(cycles)
        return abs(cycles - m) if m >= 1 else 1.0

    # Support: share of the neighbours (up to 4 on each side) that sit on this pulse's grid.
    # Real pulses share one grid; a spurious pulse is off-grid to nearly all of them.
    # Periods elapsed since the first pulse, integrating the local period (speed may wander).
    phase = np.concatenate(([0.0], np.cumsum(intervals * 2.0 / (period_at[:-1] + period_at[1:]))))
    reach = 4
    support = np.zeros(t.size)
    for i in range(t.size):
        others = np.r_[max(i - reach, 0):i, i + 1:min(i + reach + 1, t.size)]
        cycles = phase[others] - phase[i]
        whole = np.round(cycles)
        support[i] = np.mean((np.abs(cycles - whole) <= tolerance) & (whole != 0))
    keep = [int(i) for i in np.flatnonzero(support >= 0.5)]
    n = 0
    while n < len(keep) - 1:
        if badness(keep[n], keep[n + 1]) <= tolerance:
            n += 1
            continue
        left = keep[n - 1] if n > 0 else None
        right = keep[n + 2] if n + 2 < len(keep) else None
        drop_left = badness(left, keep[n + 1])
        drop_right = badness(keep[n], right)
        if drop_left < drop_right:
            del keep[n]
            n = max(n - 1, 0)
        else:
            del keep[n + 1]
    spurious = np.ones(t.size, dtype=bool)
    spurious[keep] = False
    good = t[keep]
    missing: list[float] = []
    for a, b, pa, pb in zip(good[:-1], good[1:], period_at[keep][:-1], period_at[keep][1:],
                            strict=True):
        m = round((b - a) / (0.5 * (pa + pb)))
        if m >= 2:
            missing.extend(a + (b - a) * np.arange(1, m) / m)
    return PulseTrain(t, spurious, np.asarray(missing), period_at[keep])


@dataclass(frozen=True)
class StreamPulses:
    """Edges of one pulse channel of a stream, delay-corrected and classified per segment.

    Attributes
    ----------
    channel : str
        The pulse channel.
    polarity : str
        ``"rising"`` or ``"falling"``.
    times : numpy.ndarray
        Edge times in s on the stream's ``time`` axis minus the module input delay.
    segment : numpy.ndarray of int
        Gap-free segment of each edge.
    spurious : numpy.ndarray of bool
        Edges off the periodic grid (:func:`classify_pulses`, per segment).
    missing_times : numpy.ndarray
        Estimated times in s of missing pulses.
    delay_s : float
        The input delay that was subtracted, s.
    timing_bound_s : float, default 0
        Half a sample period (s) when the edges are sample-switched (the samples jump from one
        level to the other with nothing between: a digital line, or a sensor faster than the
        sample rate), so each edge is known only to +-0.5 sample; the largest of ``bounds_s``
        for first-order edges; 0 for band-limited edges.
    bounds_s : numpy.ndarray, optional
        Bound in s of each edge's error that is not random from edge to edge (first-order
        and ambiguous edges, :func:`time_edges`); None: ``timing_bound_s`` for every edge.
    shape : str, default ""
        Edge shape found by :func:`time_edges`: ``"switched"``, ``"first-order"`` (times are
        the onsets), ``"unresolved"``, ``"symmetric"`` or ``"ambiguous"``.
    """

    channel: str
    polarity: str
    times: FloatArray
    segment: IntArray
    spurious: BoolArray
    missing_times: FloatArray
    delay_s: float
    timing_bound_s: float = 0.0
    bounds_s: FloatArray | None = None
    shape: str = ""

    @property
    def good(self) -> FloatArray:
        """Edge times (s) not flagged spurious."""
        return self.times[~self.spurious]

    @property
    def good_bounds(self) -> FloatArray:
        """Bound (s) of each good edge's error that is not random from edge to edge."""
        if self.bounds_s is None:
            return np.full(int(np.count_nonzero(~self.spurious)), self.timing_bound_s)
        return self.bounds_s[~self.spurious]

    @property
    def good_segment(self) -> IntArray:
        """Segment of each good edge."""
        return self.segment[~self.spurious]


def stream_pulses(stream: xr.Dataset, channel: str, *,
                  polarity: Literal["rising", "falling"] = "rising",
                  refine: Literal["linear", "sinc"] = "sinc", holdoff_s: float = 0.01,
                  low: float | None = None, high: float | None = None,
                  tolerance: float = 0.15) -> StreamPulses:
    """Detect, delay-correct and classify the edges of a pulse channel of a stream.

    Parameters
    ----------
    stream : xarray.Dataset
        Stream (or aligned stream: the times are then on the reference clock).
    channel : str
        Pulse channel (analog or logic level).
    polarity, refine, holdoff_s, low, high
        As in :func:`detect_edges` (``holdoff_s`` in s debounces contact bounce; keep it well
        below the period, or a spurious pulse just before a real one hides the real one).
    tolerance : float, default 0.15
        As in :func:`classify_pulses`.

    Returns
    -------
    StreamPulses
        Edges with segment, spurious flags and missing-pulse times.
    """
    if channel not in stream:
        raise ChannelNotFoundError(f"no pulse channel {channel!r} in the stream",
                                   where={"file": stream.attrs.get("source_file")},
                                   available=[v for v in stream.data_vars
                                              if v not in ("valid", "segment")])
    time = sample_times(stream)  # looked up near the edges, never made whole
    segment = stream["segment"].to_numpy()
    valid = stream["valid"].to_numpy()
    fs = float(stream.attrs["fs_nominal"])
    delay = (float(stream[channel].attrs["input_delay_s"])
             if "input_delay_s" in stream[channel].attrs
             else input_delay(stream[channel].attrs, fs))
    edges = detect_edges(stream[channel].to_numpy(), time, low=low, high=high,
                         polarity=polarity, holdoff_s=holdoff_s, segment=segment, valid=valid,
                         refine=refine)
    edge_segment = segment[np.clip(np.searchsorted(time, edges) - 1, 0, time.size - 1)]
    spurious = np.zeros(edges.size, dtype=bool)
    missing: list[FloatArray] = []
    for s in np.unique(edge_segment):
        mine = edge_segment == s
        if mine.sum() < 3:
            logger.info("segment %d of %s has %d pulses: not classified", s, channel, mine.sum())
            continue
        train = classify_pulses(edges[mine], tolerance=tolerance)
        spurious[mine] = train.spurious
        missing.append(train.missing_times)
    if spurious.any():
        logger.info("%s: %d spurious pulses at %s s", channel, spurious.sum(), edges[spurious])
    timing = time_edges(stream[channel].to_numpy(), time, edges, fs=fs, polarity=polarity,
                        valid=valid)
    logger.info("%s: %s edges, bounds up to %.3g s", channel, timing.shape,
                float(timing.bounds_s.max(initial=0.0)))
    return StreamPulses(channel, polarity, timing.times - delay, edge_segment.astype(np.int64),
                        spurious, np.concatenate(missing) - delay if missing else np.zeros(0),
                        delay, float(timing.bounds_s.max(initial=0.0)),
                        timing.bounds_s if timing.shape in ("first-order", "ambiguous")
                        else None,
                        timing.shape)


@dataclass(frozen=True)
class EdgeTiming:
    """Edge times of a pulse channel with the bound of their correlated errors.

    Attributes
    ----------
    times : numpy.ndarray
        Edge times in s: the given crossings, or the onsets of first-order edges.
    bounds_s : numpy.ndarray
        Bound in s of each time's error that is not random from edge to edge.
    shape : str
        ``"switched"``, ``"first-order"``, ``"unresolved"``, ``"symmetric"`` or
        ``"ambiguous"`` (:class:`~rigval.processing.edge_shape.EdgeFit`).
    """

    times: FloatArray
    bounds_s: FloatArray
    shape: str


def time_edges(x: ArrayLike, time: ArrayLike, edges: ArrayLike, *, fs: float,
               polarity: Literal["rising", "falling"] = "rising",
               valid: ArrayLike | None = None) -> EdgeTiming:
    """Return edge times and the bound of their correlated errors from the edges' shape.

    Sample-switched edges (:func:`_sample_switched`) keep their crossings, each bounded by half a
    sample; otherwise a first-order rise, a symmetric and a band-limited edge are fitted to the
    samples around every edge (:func:`~rigval.processing.edge_shape.fit_edges`): when the
    first-order rise fits clearly better, the times become its onsets with their bounds; else
    the crossings stay, bounded by half a sample when the edge is narrower than the samples
    resolve (``"unresolved"``) and by :data:`SYMMETRIC_BOUND` sample otherwise (band-limited or
    symmetric edges, timed without bias by their mid crossing).

    Parameters
    ----------
    x : array_like
        Pulse signal samples.
    time : array_like
        Sample times in s.
    edges : array_like
        Crossing times in s (:func:`detect_edges`).
    fs : float
        Sampling rate in Hz.
    polarity : {"rising", "falling"}
        Which edges ``edges`` are.
    valid : array_like of bool, optional
        The stream's ``valid`` samples.

    Returns
    -------
    EdgeTiming
        Times, bounds in s and the shape found.
    """
    data = np.asarray(x, dtype=np.float64)
    t = times_of(time)
    given = np.asarray(edges, dtype=np.float64)
    ok = np.isfinite(data) if valid is None else np.asarray(valid, bool) & np.isfinite(data)
    if given.size == 0 or not ok.any():
        return EdgeTiming(given, np.zeros(given.size), "symmetric")
    if _sample_switched(data, t, given, polarity, ok):
        return EdgeTiming(given, np.full(given.size, 0.5 / fs), "switched")
    low, high = state_levels(data, mask=ok)
    if polarity == "falling":
        data, low, high = -data, -high, -low
    noise = _low_level_noise(data, ok, low, high)
    fit = fit_edges(data, t, given, fs=fs, low=low, high=high, noise=noise)
    return EdgeTiming(fit.times, fit.bounds_s, fit.shape)


def _low_level_noise(x: FloatArray, ok: BoolArray, low: float, high: float) -> float:
    """Return the robust noise rms (1.4826 MAD) of the usable samples near the low level.

    The samples within 10 % of the level span from ``low`` (unit of ``x``), taken a chunk at a
    time: both medians are :func:`~rigval.processing.block_median.exact_median` of the chunks
    (a digitised pulse level takes few distinct values), equal to those of the samples copied
    out, without the copy (memory: at 1 h of a 5 kS/s channel, nearly all its samples). 0
    without such samples.
    """
    band = 0.1 * (high - low)

    def near_low() -> Iterator[FloatArray]:
        for lo in range(0, x.size, _LEVEL_CHUNK):
            part = x[lo:lo + _LEVEL_CHUNK]
            yield part[ok[lo:lo + _LEVEL_CHUNK] & (np.abs(part - low) < band)]

    centre = exact_median(near_low())
    if np.isnan(centre):
        return 0.0
    return 1.4826 * exact_median(np.abs(part - centre) for part in near_low())


def _sample_switched(x: FloatArray, time: FloatArray, edges: FloatArray, polarity: str,
                     valid: BoolArray) -> bool:
    """Return True when most edges jump between the state levels in one sample.

    An edge is sample-switched when the samples on either side of it lie within 3 % of the
    level span from the low and the high state level: no sample caught the transition, so the
    interpolated crossing says nothing below half a sample. A band-limited edge (a delta-sigma
    module's filter passes 0.45 fs) never does: its samples on either side of the mid crossing
    cannot both be 0.67 sample from it. Most (80 %) of the edges must be so.
    """
    if edges.size == 0:
        return False
    low, high = state_levels(x, mask=valid if valid.any() else None)
    band = 0.03 * (high - low)
    j = np.clip(np.searchsorted(time, edges) - 1, 0, x.size - 2)
    before, after = x[j], x[j + 1]
    if polarity == "falling":
        before, after = after, before
    jumps = (before <= low + band) & (after >= high - band)
    return bool(np.mean(jumps) >= 0.8)
