"""Sensor health per channel: clipping, flat line, spikes, noise, zero drift (analog channels).

Each check reads one channel of a stream (file units, before conversion) and returns
:class:`Finding` records that say what is wrong, where (samples, times, revolutions) and
whether the fault can change a comparison's verdict (docs/processing.md, "Sensor health"):

- **clipping**: runs of 3 or more samples at the record's extreme value (a range limit: the
  channel's ``valid_min``/``valid_max`` or ``range_min``/``range_max`` attributes, or the
  module's input range, when it is at one);
- **flat line**: 0.1 s or more within one quantisation step (a broken gauge or cable);
- **spikes**: samples farther than 12 robust sigmas from the 5-sample running median;
- **noise**: 0.25 s windows whose noise (third differences, robust) exceeds 3 times the
  channel's floor (the 20th percentile of its windows), two windows running or more;
- **zero drift**: the trend of the means over whole revolutions, over the record, above 2 % of
  the signal's span and 6 standard errors.

Counters (count jumps and glitches) and pulse channels (changing pulse widths) are checked by
:mod:`rigval.processing.health_events`; :func:`rigval.processing.health_check.stream_health`
runs every check a channel's kind calls for.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy.ndimage import median_filter

from rigval.acquisition.sample_times import times_of
from rigval.processing.arrays import BoolArray, FloatArray, IntArray

__all__ = ["MODULE_RANGES", "UNTRUSTED", "Finding", "analog_health", "channel_range",
           "quantum", "runs_of"]

logger = logging.getLogger(__name__)

#: Input range (+-, file unit) of the modules rigval knows, for clipping at a range limit.
MODULE_RANGES = {"NI 9237": 0.025, "NI 9215": 10.0}
#: Faults that make a comparison on the channel untrusted (they change its values where the
#: model is compared): the others are reported beside the verdict.
UNTRUSTED = frozenset({"clipping", "flat line", "count jump", "count glitch", "spikes"})
#: Longest list of sample indices (spikes, jumps) a finding keeps.
_MAX_LISTED = 50
#: Clipping: shortest run at the extreme and fewest clipped samples.
_CLIP_RUN, _CLIP_MIN = 3, 6
#: Flat line: shortest run (s and samples).
_FLAT_S, _FLAT_MIN = 0.1, 50
#: Spikes: running-median length and threshold in robust sigmas.
_SPIKE_WINDOW, _SPIKE_SIGMAS = 5, 12.0
#: Samples the checks take at a time (bounds their working arrays: 8 MiB of float64).
_BLOCK = 1 << 20
#: Samples :func:`quantum` looks at.
_QUANTUM_SAMPLES = 20_000
#: Noise: window (s), threshold over the floor, floor percentile, fewest windows in a row.
_NOISE_WINDOW_S, _NOISE_FACTOR, _NOISE_PERCENTILE, _NOISE_RUN = 0.25, 3.0, 20.0, 2
#: Zero drift: share of the signal's span and standard errors it must exceed.
_DRIFT_SHARE, _DRIFT_SIGMAS = 0.02, 6.0
#: Zero drift: the percentiles (%) of the usable samples the signal's span lies between.
_SPAN_PERCENTILES = (0.5, 99.5)


@dataclass(frozen=True)
class Finding:
    """One health fault of one channel.

    Attributes
    ----------
    channel : str
        The channel (``stream.channel`` in :func:`stream_health`).
    fault : str
        ``"clipping"``, ``"flat line"``, ``"spikes"``, ``"noise"``, ``"zero drift"``,
        ``"count jump"``, ``"count glitch"`` or ``"pulse width"``.
    text : str
        What was found, e.g. ``"3.1 % of samples clipped at 0.002 V/V"``.
    samples : int
        Samples affected.
    first_sample, last_sample : int
        First and last affected sample (index into the stream).
    first_s, last_s : float
        Their times in s on the stream's time axis.
    value : float
        The fault's size: level (clipping, flat line), largest spike, noise over its floor,
        drift over the record, count jump (file unit, 1 or counts).
    indices : tuple of int
        Each spike's or jump's sample (at most 50 listed).
    revolutions : tuple of int
        Revolutions (pulses or counter turns from the record's start) affected.
    """

    channel: str
    fault: str
    text: str
    samples: int
    first_sample: int
    last_sample: int
    first_s: float
    last_s: float
    value: float
    indices: tuple[int, ...] = field(default_factory=tuple)
    revolutions: tuple[int, ...] = field(default_factory=tuple)

    @property
    def trusted(self) -> bool:
        """Return False when the fault can change a comparison's verdict (:data:`UNTRUSTED`)."""
        return self.fault not in UNTRUSTED

    def line(self) -> str:
        """Return the verdict line's text: ``"tor2: 3.1 % of samples clipped ...; not trusted"``."""
        return f"{self.channel}: {self.text}" + ("" if self.trusted else "; not trusted")

    def record(self) -> dict[str, Any]:
        """Return the finding as plain JSON values (alignment.json, netCDF attributes)."""
        return {"channel": self.channel, "fault": self.fault, "text": self.text,
                "samples": self.samples, "first_sample": self.first_sample,
                "last_sample": self.last_sample, "first_s": self.first_s,
                "last_s": self.last_s, "value": self.value, "indices": list(self.indices),
                "revolutions": list(self.revolutions), "trusted": self.trusted}


def runs_of(mask: ArrayLike) -> tuple[IntArray, IntArray]:
    """Return the start and stop (exclusive) index of every run of True in ``mask``."""
    m = np.concatenate(([False], np.asarray(mask, dtype=bool), [False]))
    change = np.flatnonzero(m[1:] != m[:-1])
    return change[0::2], change[1::2]


def quantum(x: FloatArray) -> float:
    """Return the quantisation step of a recorded channel (file unit; 0 for unquantised data).

    The smallest positive difference between the distinct values of up to 20,000 samples,
    accepted when most differences between neighbouring samples are whole multiples of it.
    """
    part = x[np.isfinite(x)][:_QUANTUM_SAMPLES]
    steps = np.diff(np.unique(part))
    steps = steps[steps > 0]
    if steps.size == 0:
        return 0.0
    q = float(steps.min())
    d = np.abs(np.diff(part))
    whole = np.abs(d / q - np.round(d / q)) < 0.01
    return q if np.mean(whole) > 0.9 else 0.0


def _first_usable(x: FloatArray, ok: BoolArray, count: int) -> FloatArray:
    """Return the first ``count`` samples of ``x`` where ``ok`` (``x[ok][:count]`` uncopied)."""
    parts, found = [], 0
    for lo, hi in _blocks(0, x.size):
        part = x[lo:hi][ok[lo:hi]][:count - found]
        parts.append(part)
        found += part.size
        if found == count:
            break
    return np.concatenate(parts) if parts else x[:0]


def _mask(size: int, block: Callable[[int, int], BoolArray]) -> BoolArray:
    """Return a whole-record mask whose elements ``lo ... hi - 1`` are ``block(lo, hi)``.

    Filled a block of :data:`_BLOCK` at a time, so that the comparisons making it have no
    whole-record temporaries.
    """
    out = np.empty(size, dtype=bool)
    for lo, hi in _blocks(0, size):
        out[lo:hi] = block(lo, hi)
    return out


def channel_range(attrs: Mapping[str, Any], module: str | None) -> tuple[float, float] | None:
    """Return a channel's input range (file unit) from its attributes or its module, if known."""
    for low, high in (("valid_min", "valid_max"), ("range_min", "range_max")):
        if low in attrs and high in attrs:
            return float(attrs[low]), float(attrs[high])
    if module:
        for name, limit in MODULE_RANGES.items():
            if name.replace("NI ", "") in module:
                return -limit, limit
    return None


def _finding(channel: str, fault: str, text: str, time: FloatArray, hit: IntArray,
             value: float, **extra: Any) -> Finding:
    """Build a finding over the affected samples ``hit`` (sorted indices)."""
    return Finding(channel, fault, text, int(hit.size), int(hit[0]), int(hit[-1]),
                   float(time[hit[0]]), float(time[hit[-1]]), float(value), **extra)


def _fmt(value: float, unit: str) -> str:
    return f"{value:.3g} {unit}".strip()


def _clipping(x: FloatArray, ok: BoolArray, time: FloatArray, channel: str, unit: str,
              limits: tuple[float, float] | None, q: float) -> list[Finding]:
    hits, levels = [], []
    for level in (float(np.max(x, where=ok, initial=-np.inf)),
                  float(np.min(x, where=ok, initial=np.inf))):
        # the runs at the level, found a block at a time (no whole-record mask)
        starts, stops = _long_runs(x.size, lambda lo, hi, level=level: ok[lo:hi] & (
            np.abs(x[lo:hi] - level) <= 0.5 * q), _CLIP_RUN)
        hit = np.concatenate([np.arange(a, b) for a, b in zip(starts, stops, strict=True)]
                             or [[]])
        if hit.size >= _CLIP_MIN:
            hits.append(hit.astype(np.int64))
            levels.append(level)
    if not hits:
        return []
    hit = np.sort(np.concatenate(hits))
    limit = ""
    if limits is not None and all(min(abs(level - lim) for lim in limits) <= 0.01 * (
            limits[1] - limits[0]) for level in levels):
        limit = " (the range limit)"
    where = " and ".join(_fmt(level, unit) for level in levels)
    share = 100.0 * hit.size / max(int(ok.sum()), 1)
    return [_finding(channel, "clipping",
                     f"{share:.2g} % of samples clipped at {where}{limit}, "
                     f"{time[hit[0]]:.3f}-{time[hit[-1]]:.3f} s", time, hit,
                     max(levels, key=abs))]


def _flat(x: FloatArray, ok: BoolArray, time: FloatArray, fs: float, channel: str, unit: str,
          q: float, clipping: list[Finding]) -> list[Finding]:
    """Return the flat stretches: long runs of steps within a quantum, not mostly clipped.

    The long runs are found a block at a time (:func:`_long_runs`; memory: a noisy channel's
    steps make millions of short runs, and no whole-record mask of them is made), and a run's
    clipped share from the clipping findings' spans.
    """
    shortest = max(int(_FLAT_S * fs), _FLAT_MIN)
    # a run of k steps spans k + 1 samples
    starts, stops = _long_runs(x.size - 1, lambda lo, hi: ok[lo + 1:hi + 1] & ok[lo:hi] & (
        np.abs(np.diff(x[lo:hi + 1])) <= q), shortest - 1)
    spans = _merged_spans([(f.first_sample, f.last_sample + 1) for f in clipping])
    out = []
    for a, b in zip(starts, stops + 1, strict=True):  # b: one past the run's last sample
        if _covered(spans, a, b) / (b - a) > 0.5:
            continue
        hit = np.arange(a, b)
        out.append(_finding(channel, "flat line",
                            f"flat at {_fmt(float(x[a]), unit)} for {(b - a) / fs:.3g} s "
                            f"({b - a} samples from {time[a]:.3f} s)", time, hit, float(x[a])))
    return out


def _spikes(x: FloatArray, ok: BoolArray, time: FloatArray, windows: _Windows, channel: str,
            unit: str, q: float) -> list[Finding]:
    # the scale is the noise (third differences): a median's residual is 0 on any monotone
    # stretch, so its own spread says nothing
    # per noise window, so that a noisy stretch is not taken for spikes
    width, noise = windows.width, windows.noise
    if not np.isfinite(noise).any():
        return []
    noise = np.where(np.isfinite(noise), noise, np.nanmax(noise))
    # the loudest of each window and its neighbours: a noisy stretch starts inside a window
    noise = np.maximum(noise, np.maximum(np.r_[noise[1:], noise[-1]], np.r_[noise[0], noise[:-1]]))
    hits = [_block_spikes(x, lo, hi, a, b, noise, width, q)
            for a, b in zip(*runs_of(ok), strict=True)  # each stretch of neighbours alone
            for lo, hi in _blocks(a, b)]
    hit = np.concatenate([h for h, _ in hits] or [np.zeros(0, np.int64)])
    if hit.size == 0:
        return []
    worst = max((w for h, w in hits if h.size), key=abs)
    return [_finding(channel, "spikes",
                     f"{hit.size} spikes up to {_fmt(worst, unit)} ({hit.size} samples, first at "
                     f"{time[hit[0]]:.3f} s)", time, hit, worst,
                     indices=tuple(int(i) for i in hit[:_MAX_LISTED]))]


def _blocks(a: int, b: int) -> list[tuple[int, int]]:
    """Split samples ``a ... b - 1`` into blocks of at most ``_BLOCK`` samples."""
    return [(lo, min(lo + _BLOCK, b)) for lo in range(a, b, _BLOCK)]


def _block_spikes(x: FloatArray, lo: int, hi: int, a: int, b: int, noise: FloatArray,
                  width: int, q: float) -> tuple[IntArray, float]:
    """Return the spikes among samples ``lo ... hi - 1`` of the stretch ``a ... b - 1``.

    The running median sees the block with half its window of neighbours on either side (as
    far as the stretch goes), so the block's values equal those of the whole stretch's median;
    the threshold is ``_SPIKE_SIGMAS`` times the noise of the sample's window. Returns the
    spikes' indices and the largest residual (0 without spikes).
    """
    half = _SPIKE_WINDOW // 2
    start, stop = max(lo - half, a), min(hi + half, b)
    base = median_filter(x[start:stop], size=_SPIKE_WINDOW, mode="nearest")[lo - start:hi - start]
    residual = x[lo:hi] - base
    local = noise[np.minimum(np.arange(lo, hi) // width, noise.size - 1)]
    threshold = np.maximum(_SPIKE_SIGMAS * local, 4.0 * q)
    at = np.flatnonzero((np.abs(residual) > threshold) & (threshold > 0))
    if at.size == 0:
        return at.astype(np.int64), 0.0
    return (at + lo).astype(np.int64), float(residual[at][np.argmax(np.abs(residual[at]))])


@dataclass(frozen=True)
class _Windows:
    """The noise rms of each window of ``width`` samples starting at ``starts``.

    The scale of the spike and of the noise check alike, found once for both.
    """

    width: int
    noise: FloatArray
    starts: IntArray

    @classmethod
    def of(cls, x: FloatArray, ok: BoolArray, fs: float) -> _Windows:
        """Return the windows of :data:`_NOISE_WINDOW_S` of samples ``x`` (usable: ``ok``)."""
        width = max(int(_NOISE_WINDOW_S * fs), 20)
        return cls(width, *_window_noise(x, ok, width))


def _window_noise(x: FloatArray, ok: BoolArray, width: int) -> tuple[FloatArray, IntArray]:
    """Robust noise rms per window from third differences (white noise: var = 20 sigma^2).

    Window ``a ... a + width - 1`` of the third differences takes samples ``a ... a + width +
    2``, whose four neighbours must all be usable; its differences are made from those samples
    alone (the same values as the whole record's, without its whole-record temporaries). The
    windows come about :data:`_BLOCK` samples at a time as the rows of one array, whose medians
    are taken row by row; a window with unusable samples takes its usable ones alone.
    """
    starts = np.arange(0, x.size - 3 - width + 1, width)
    noise = np.full(starts.size, np.nan)
    rows = max(_BLOCK // width, 1)
    for first in range(0, starts.size, rows):
        count = min(rows, starts.size - first)
        a, b = int(starts[first]), int(starts[first]) + count * width
        d3 = np.diff(x[a:b + 3], 3).reshape(count, width)
        use = (ok[a + 3:b + 3] & ok[a + 2:b + 2] & ok[a + 1:b + 1] & ok[a:b]).reshape(count, width)
        whole = use.all(axis=1)
        full = d3[whole]
        deviation = np.abs(full - np.median(full, axis=1, keepdims=True))
        noise[first + np.flatnonzero(whole)] = 1.4826 * np.median(deviation, axis=1) / np.sqrt(
            20.0)
        for n in np.flatnonzero(~whole):
            part = d3[n][use[n]]
            if part.size >= width // 2:
                noise[first + n] = 1.4826 * float(np.median(np.abs(part - np.median(part)))) / (
                    np.sqrt(20.0))
    return noise, starts


def _noise(x: FloatArray, time: FloatArray, windows: _Windows, channel: str, unit: str,
           q: float) -> list[Finding]:
    width, noise, starts = windows.width, windows.noise, windows.starts
    finite = noise[np.isfinite(noise)]
    if finite.size < 4:
        return []
    floor = max(float(np.percentile(finite, _NOISE_PERCENTILE)), q / np.sqrt(12.0), 1e-300)
    loud = np.nan_to_num(noise, nan=0.0) > _NOISE_FACTOR * floor
    out = []
    for a, b in zip(*runs_of(loud), strict=True):
        if b - a < _NOISE_RUN:
            continue
        hit = np.arange(starts[a], min(starts[b - 1] + width + 3, x.size))
        ratio = float(np.nanmedian(noise[a:b]) / floor)
        out.append(_finding(channel, "noise",
                            f"noise {ratio:.3g} times the channel's floor "
                            f"({_fmt(floor, unit)} rms) from {time[hit[0]]:.3f} to "
                            f"{time[hit[-1]]:.3f} s", time, hit, ratio))
    return out


def _zero_drift(x: FloatArray, ok: BoolArray, time: FloatArray, channel: str, unit: str,
                period_samples: float | None, segment: ArrayLike | None) -> list[Finding]:
    if not period_samples or period_samples < 4:
        return []
    block = round(period_samples)
    count = x.size // block
    if count < 4:
        return []
    sums, counts = _revolution_sums(x, ok, block, count)
    full = counts / block > 0.95
    if segment is not None:  # a revolution across a gap is no whole revolution
        seg = np.asarray(segment)[:count * block].reshape(count, block)
        full &= seg.min(axis=1) == seg.max(axis=1)
    if full.sum() < 4:
        return []
    means = sums[full] / counts[full]
    centres = (np.flatnonzero(full) + 0.5) * block / 1.0
    t = _time_at(centres, time)
    slope, intercept = np.polyfit(t - t.mean(), means, 1)
    residual = means - (intercept + slope * (t - t.mean()))
    first, last = _first_and_last(ok)
    span_t = float(time[last] - time[first])
    drift = float(slope) * span_t
    scale = 1.4826 * float(np.median(np.abs(residual)))  # robust: a revolution may be odd
    se = scale / float(np.sqrt(np.sum((t - t.mean()) ** 2))) * span_t
    low, high = _usable_percentiles(x, ok, _SPAN_PERCENTILES)
    span = float(high - low)
    if abs(drift) <= max(_DRIFT_SHARE * span, _DRIFT_SIGMAS * se):
        return []
    hit = np.flatnonzero(ok)
    return [_finding(channel, "zero drift",
                     f"zero drift {_fmt(drift, unit)} over {span_t:.3g} s "
                     f"({100.0 * abs(drift) / max(span, 1e-300):.2g} % of the signal's span)",
                     time, hit, drift)]


def _usable_percentiles(x: FloatArray, ok: BoolArray, percents: tuple[float, ...]
                        ) -> FloatArray:
    """Return ``numpy.percentile(x[ok], percents)`` without the copy ``x[ok]`` (memory).

    The same positions, order statistics and linear interpolation as numpy's default method
    (its ``_get_indexes``, ``_get_gamma`` and ``_lerp``), so the values are bit-identical;
    each order statistic is found among the few smallest or largest usable samples, gathered
    a block at a time (:func:`_tail`). ``ok`` holds at least once; values in ``x``'s unit.
    """
    n = int(np.count_nonzero(ok))
    virtual = (n - 1) * (np.asarray(percents, dtype=np.float64) / 100)
    previous = np.floor(virtual)
    following = previous + 1
    last = virtual >= n - 1
    previous[last], following[last] = n - 1, n - 1  # numpy's index -1
    previous[virtual < 0], following[virtual < 0] = 0, 0
    gamma = virtual - np.where(last, -1, previous)  # as numpy, against its index -1
    a = np.array([_order_statistic(x, ok, n, int(k)) for k in previous])
    b = np.array([_order_statistic(x, ok, n, int(k)) for k in following])
    difference = b - a
    result = a + difference * gamma
    above = gamma >= 0.5
    result[above] = (b - difference * (1 - gamma))[above]
    return result


def _order_statistic(x: FloatArray, ok: BoolArray, n: int, rank: int) -> float:
    """Return the ``rank``-th smallest (from 0) of the ``n`` usable samples, in ``x``'s unit."""
    if rank < n - rank:
        return float(_tail(x, ok, rank + 1, largest=False)[rank])
    return float(_tail(x, ok, n - rank, largest=True)[0])


def _tail(x: FloatArray, ok: BoolArray, count: int, *, largest: bool) -> FloatArray:
    """Return the ``count`` smallest (or largest) usable samples, sorted, a block at a time.

    The record's extreme ``count`` are each among their block's extreme ``count``: each block's
    usable samples are merged with the extremes so far, and those kept.
    """
    kept = np.zeros(0)
    for lo, hi in _blocks(0, x.size):
        merged = np.concatenate((kept, x[lo:hi][ok[lo:hi]]))
        if merged.size <= count:
            kept = merged
        elif largest:
            kept = np.partition(merged, merged.size - count)[merged.size - count:]
        else:
            kept = np.partition(merged, count - 1)[:count]
    return np.sort(kept)


def _long_runs(size: int, block: Callable[[int, int], BoolArray], min_length: int
               ) -> tuple[IntArray, IntArray]:
    """Return the runs of :func:`runs_of` of ``_mask(size, block)`` at least ``min_length`` long.

    Each block's runs are found on its own mask and the short ones dropped there; a run that
    reaches a block's end is joined to the one the next block begins with (memory: a block's
    mask and its runs at a time, not the whole record's).
    """
    starts: list[IntArray] = []
    stops: list[IntArray] = []
    open_from: int | None = None  # start of a run that reached the last block's end
    for lo, hi in _blocks(0, size):
        a, b = runs_of(block(lo, hi))
        a, b = a + lo, b + lo
        if open_from is not None:
            if a.size and a[0] == lo:
                a[0] = open_from
            else:
                a, b = np.r_[open_from, a], np.r_[lo, b]
            open_from = None
        if b.size and b[-1] == hi:
            open_from, a, b = int(a[-1]), a[:-1], b[:-1]
        long = b - a >= min_length
        starts.append(a[long])
        stops.append(b[long])
    if open_from is not None and size - open_from >= min_length:
        starts.append(np.array([open_from]))
        stops.append(np.array([size]))
    empty = np.zeros(0, dtype=np.int64)
    return (np.concatenate([empty, *starts]).astype(np.int64),
            np.concatenate([empty, *stops]).astype(np.int64))


def _merged_spans(spans: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """Return sample spans ``[a, b)`` merged where they overlap or touch, in order."""
    merged: list[tuple[int, int]] = []
    for a, b in sorted(spans):
        if merged and a <= merged[-1][1]:
            merged[-1] = (merged[-1][0], max(merged[-1][1], b))
        else:
            merged.append((a, b))
    return merged


def _covered(spans: list[tuple[int, int]], a: int, b: int) -> int:
    """Return how many of the samples ``a ... b - 1`` the merged ``spans`` cover."""
    return sum(max(0, min(b, hi) - max(a, lo)) for lo, hi in spans)


def _moving(ok: BoolArray, findings: list[Finding], segment: ArrayLike | None) -> BoolArray:
    """Return the usable samples outside the findings' spans and away from the gaps.

    The spikes and noise are judged there: a clipped or flat stretch is no signal, and the
    samples on either side of a gap are not neighbours. Made in ``ok`` itself, which the caller
    hands over, the findings' spans cleared in it (memory: no second whole-record mask).
    """
    moving = ok
    for found in findings:
        moving[found.first_sample:found.last_sample + 1] = False
    if segment is not None:
        seg = np.asarray(segment)
        for lo, hi in _blocks(0, seg.size - 1):
            for b in np.flatnonzero(seg[lo + 1:hi + 1] != seg[lo:hi]) + lo + 1:
                moving[max(b - 3, 0):b + 3] = False
    return moving


def _first_and_last(ok: BoolArray) -> tuple[int, int]:
    """Return the first and the last index where ``ok`` holds (it holds somewhere).

    Found a block at a time from either end (no whole-record index array).
    """
    first = next(lo + int(np.argmax(ok[lo:hi])) for lo, hi in _blocks(0, ok.size)
                 if ok[lo:hi].any())
    last = next(lo + int(np.flatnonzero(ok[lo:hi])[-1]) for lo, hi in
                reversed(_blocks(0, ok.size)) if ok[lo:hi].any())
    return first, last


def _time_at(positions: FloatArray, time: FloatArray) -> FloatArray:
    """Return ``time`` interpolated at fractional sample positions (increasing, within the record).

    As :func:`numpy.interp` over every sample index, from the two samples around each position
    alone (no whole-record index array).
    """
    below = np.clip(np.floor(positions).astype(np.int64), 0, max(time.size - 2, 0))
    index = np.unique(np.concatenate((below, np.minimum(below + 1, time.size - 1))))
    return np.interp(positions, index.astype(np.float64), time[index])


def _revolution_sums(x: FloatArray, ok: BoolArray, block: int, count: int
                     ) -> tuple[FloatArray, IntArray]:
    """Return the sum and the number of the usable samples of each of ``count`` revolutions.

    Revolution ``k`` is samples ``k * block ... (k + 1) * block - 1``; worked a few revolutions
    at a time, so that no copy of the whole channel is made.
    """
    rows = max(_BLOCK // block, 1)
    values = x[:count * block].reshape(count, block)
    usable = ok[:count * block].reshape(count, block)
    sums = np.concatenate([np.where(usable[k:k + rows], values[k:k + rows], 0.0).sum(axis=1)
                           for k in range(0, count, rows)])
    return sums, usable.sum(axis=1)


def analog_health(x: ArrayLike, time: ArrayLike, *, channel: str, fs: float, unit: str = "",
                  valid: ArrayLike | None = None, segment: ArrayLike | None = None,
                  limits: tuple[float, float] | None = None,
                  period_samples: float | None = None) -> list[Finding]:
    """Return the health findings of one analog channel.

    Parameters
    ----------
    x : array_like
        Samples in the file's unit.
    time : array_like
        Sample times in s.
    channel : str
        Name used in the findings.
    fs : float
        Sampling rate in Hz.
    unit : str, optional
        The samples' unit, for the texts.
    valid : array_like of bool, optional
        Usable samples (the stream's ``valid``).
    segment : array_like of int, optional
        Gap-free segment of each sample: spikes and noise are not judged across a gap.
    limits : (float, float), optional
        The channel's input range (:func:`channel_range`).
    period_samples : float, optional
        Samples per revolution: the zero drift is judged on whole revolutions (no drift check
        without it).

    Returns
    -------
    list of Finding
        Clipping, flat line, spikes, noise and zero drift findings, in that order.
    """
    data = np.asarray(x, dtype=np.float64)
    t = times_of(time)
    usable = None if valid is None else np.asarray(valid, bool)
    ok = _mask(data.size, lambda lo, hi: np.isfinite(data[lo:hi]) if usable is None
               else usable[lo:hi] & np.isfinite(data[lo:hi]))
    if ok.sum() < 20:
        return []
    q = quantum(_first_usable(data, ok, _QUANTUM_SAMPLES))
    clipping = _clipping(data, ok, t, channel, unit, limits, q)
    findings = [*clipping, *_flat(data, ok, t, fs, channel, unit, q, clipping)]
    moving = _moving(ok, findings, segment)  # ok handed over: cleared in place
    windows = _Windows.of(data, moving, fs)
    findings += _spikes(data, moving, t, windows, channel, unit, q)
    findings += _noise(data, t, windows, channel, unit, q)
    findings += _zero_drift(data, moving, t, channel, unit, period_samples, segment)
    return findings

