"""Sensor health of counters and pulse channels: count jumps and glitches, changing pulse widths.

- **count jump**: a step between two samples that departs from the local count rate (the median
  step over 101 samples) by more than 8 counts and 10 robust sigmas of the steps, not undone by
  the next step (counts lost or gained: the angle is off from there on);
- **count glitch**: such a step undone within 3 samples (an electrical glitch);
- **pulse width**: the pulses' mark widths (less a pattern repeating every 2, 3 or 4 pulses
  when that leaves clearly less scatter), split where two constant widths fit best (least
  absolute deviations); reported when the medians before and after differ by more than 5 % and
  8 robust sigmas.

Findings are :class:`~rigval.processing.health.Finding` records (docs/processing.md, "Sensor
health").
"""

from __future__ import annotations

import heapq
import logging
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.ndimage import median_filter

from rigval.acquisition.errors import DataError
from rigval.acquisition.sample_times import times_of
from rigval.processing.arrays import BoolArray, FloatArray, IntArray
from rigval.processing.block_median import exact_median
from rigval.processing.encoder import counter_steps
from rigval.processing.health import Finding
from rigval.processing.pulses import detect_edges

__all__ = ["counter_health", "pulse_health"]

logger = logging.getLogger(__name__)

#: Count anomalies: running-median length (samples), least departure (counts), robust sigmas,
#: and how many samples later a glitch is undone at most.
_RATE_WINDOW, _JUMP_COUNTS, _JUMP_SIGMAS, _GLITCH_SAMPLES = 101, 8.0, 10.0, 3
#: Count steps the running rate takes at a time (bounds its working arrays).
_BLOCK = 1 << 20
#: Pulse widths: least relative change, robust sigmas, fewest pulses on each side.
_WIDTH_SHARE, _WIDTH_SIGMAS, _WIDTH_SIDE = 0.05, 8.0, 3
#: Split costs closer than this fraction of the largest are equal (rounding of their sums).
_TIE = 1e-12


def _running_median(x: FloatArray, width: int) -> FloatArray:
    """Median of ``width`` samples around each sample (the ends repeated)."""
    return median_filter(x, size=width, mode="nearest")


def _plural(noun: str, count: int) -> str:
    """Return the ending of ``noun`` for ``count`` ("es" after a sibilant)."""
    if count == 1:
        return ""
    return "es" if noun.endswith(("ch", "sh", "s", "x")) else "s"


def _blocks(size: int) -> list[tuple[int, int]]:
    """Split ``0 ... size - 1`` into blocks of at most ``_BLOCK``."""
    return [(lo, min(lo + _BLOCK, size)) for lo in range(0, size, _BLOCK)]


def _count_steps(raw: np.ndarray, ok: BoolArray, lo: int, hi: int,
                 counts_per_rev: float | None) -> IntArray:
    """Return steps ``lo ... hi - 1`` of the cumulative counts (step ``k``: ``k`` to ``k + 1``).

    :func:`~rigval.processing.encoder.counter_steps` of the counter values (0 where not
    usable): the steps of the whole record's cumulative counts, a block at a time.
    """
    ok_part = ok[lo:hi + 1]
    filled = np.zeros(ok_part.size, np.int64)
    filled[ok_part] = raw[lo:hi + 1][ok_part]
    return counter_steps(filled, counts_per_rev)


def _rate_departure(raw: np.ndarray, ok: BoolArray, lo: int, hi: int, typical: float,
                    counts_per_rev: float | None) -> tuple[FloatArray, IntArray]:
    """Return steps ``lo ... hi - 1`` less the running median rate around them, and the steps.

    Departures are 0 where a step is not usable; unusable steps enter the median as
    ``typical``. The block is taken with half the median's window of neighbours on either
    side, so the values equal those of one median over the whole record.
    """
    half = _RATE_WINDOW // 2
    size = raw.size - 1
    start, stop = max(lo - half, 0), min(hi + half, size)
    step = _count_steps(raw, ok, start, stop, counts_per_rev)
    usable = ok[start + 1:stop + 1] & ok[start:stop]
    rate = _running_median(np.where(usable, step, typical), _RATE_WINDOW)
    inner = slice(lo - start, hi - start)
    return np.where(usable[inner], step[inner] - rate[inner], 0.0), step[inner]


@dataclass(frozen=True)
class _Departures:
    """The count steps that depart from the running rate by more than any jump threshold.

    ``index``: the step (from sample ``index`` to ``index + 1``); ``departure``: its
    departure (counts); ``counts``: the cumulative counts at ``index + 1`` less the first
    sample's.
    """

    index: IntArray
    departure: FloatArray
    counts: IntArray


def _departures(raw: np.ndarray, ok: BoolArray, counts_per_rev: float | None
                ) -> tuple[float, _Departures]:
    """Return the robust sigma of the usable steps' departures (counts) and the large ones.

    Two passes over the record a block at a time: the median step (the rate where a step is
    not usable), then each block's departures from the running median rate, of which the
    usable ones' absolute values give the sigma (exact median) and those above
    :data:`_JUMP_COUNTS`, the least threshold, are kept.
    """
    blocks = _blocks(raw.size - 1)
    typical = float(np.nan_to_num(exact_median(
        _count_steps(raw, ok, lo, hi, counts_per_rev)[ok[lo + 1:hi + 1] & ok[lo:hi]]
        for lo, hi in blocks)))
    index, size, counts = [np.zeros(0, np.int64)], [np.zeros(0)], [np.zeros(0, np.int64)]
    since = 0  # cumulative counts at a block's start less the first sample's

    def usable_sizes() -> Iterator[FloatArray]:
        nonlocal since
        for lo, hi in blocks:
            departure, step = _rate_departure(raw, ok, lo, hi, typical, counts_per_rev)
            large = np.flatnonzero(np.abs(departure) > _JUMP_COUNTS)
            index.append(lo + large)
            size.append(departure[large])
            counts.append(since + np.cumsum(step)[large])
            since += int(step.sum())
            yield np.abs(departure[ok[lo + 1:hi + 1] & ok[lo:hi]])

    spread = 1.4826 * exact_median(usable_sizes())
    return spread, _Departures(np.concatenate(index), np.concatenate(size),
                               np.concatenate(counts))


def _without_pattern(relative: FloatArray, turn: IntArray, part: IntArray, repeat: int,
                     split: int) -> FloatArray:
    """Return relative widths less the pattern that repeats every ``repeat`` turns.

    A shaft whose speed varies within the revolution of another (the lifting shaft turning
    twice per main revolution) gives pulse widths that alternate; each pulse's class is its
    whole period count modulo the repeat (a missing pulse keeps the count) within its gap-free
    ``part`` (a restart's new time stamp may not keep the count across a gap). A class's
    pattern is its median's offset from the centre of its side of ``split`` (the mean of the
    class medians there), averaged over both sides: a step at ``split`` is not absorbed, and a
    wrong split makes no step.
    """
    after = np.arange(relative.size) >= split
    less = relative.copy()
    classes = part * repeat + turn % repeat
    sides = [side for side in (~after, after) if side.any()]
    # each side's centre: the mean of its classes' medians (a median of alternating widths
    # would jump between the two kinds)
    medians = {(c, n): float(np.median(relative[(classes == c) & side]))
               for c in np.unique(classes) for n, side in enumerate(sides)
               if ((classes == c) & side).any()}
    centre = [np.mean([m for (_, n), m in medians.items() if n == k]) for k in range(len(sides))]
    for c in np.unique(classes):
        # the class's offset from the centre of its side, averaged over the sides it is on
        less[classes == c] -= np.mean([m - centre[n] for (k, n), m in medians.items()
                                       if k == c])
    return less


def _deviation_sums(d: FloatArray) -> FloatArray:
    """Return ``S[k]``: the sum of ``|d[i] - median(d[:k])|`` over ``i < k``, for k = 0 ... n.

    The prefixes' medians from two heaps (the lower half, the upper half) and their running
    sums: with the halves of equal size the sum is the upper half's less the lower half's, with
    the median in the lower half that plus the median. O(n log n) against the O(n^2) of a
    median per prefix; equal to it to rounding (the values are taken about their overall
    median first, so the running sums stay small).
    """
    lower: list[float] = []  # negated: a max-heap
    upper: list[float] = []
    sum_lower = sum_upper = 0.0
    sums = np.zeros(d.size + 1)
    for k, value in enumerate((d - np.median(d)).tolist(), start=1):
        if lower and value > -lower[0]:
            heapq.heappush(upper, value)
            sum_upper += value
        else:
            heapq.heappush(lower, -value)
            sum_lower += value
        if len(lower) > len(upper) + 1:
            moved = -heapq.heappop(lower)
            heapq.heappush(upper, moved)
            sum_lower, sum_upper = sum_lower - moved, sum_upper + moved
        elif len(upper) > len(lower):
            moved = heapq.heappop(upper)
            heapq.heappush(lower, -moved)
            sum_lower, sum_upper = sum_lower + moved, sum_upper - moved
        sums[k] = sum_upper - sum_lower - (lower[0] if k % 2 else 0.0)
    return sums


def _step(d: FloatArray) -> tuple[int, float, float]:
    """Return where two constant levels fit ``d`` best, the step between them and its error.

    The split minimises the absolute deviations from each side's median (a pulse put on the
    wrong side costs its whole difference; :func:`_deviation_sums` of the pulses before and,
    reversed, after each split), the first of equal ones; the step is the difference of the
    medians, its standard error from the robust scatter about them.
    """
    splits = np.arange(_WIDTH_SIDE, d.size - _WIDTH_SIDE + 1)
    cost = _deviation_sums(d)[splits] + _deviation_sums(d[::-1])[d.size - splits]
    # the first of the splits as good as the best to rounding (the cost is flat where moving a
    # pulse across the split moves neither median past it)
    k = int(splits[np.argmax(cost <= cost.min() + _TIE * cost.max())])
    before, after = d[:k], d[k:]
    sigma = 1.4826 * float(np.median(np.abs(np.concatenate(
        (before - np.median(before), after - np.median(after))))))
    return k, float(np.median(after) - np.median(before)), sigma * np.sqrt(
        1.0 / before.size + 1.0 / after.size)


def counter_health(counts: ArrayLike, time: ArrayLike, *, channel: str,
                   counts_per_rev: float | None = None, valid: ArrayLike | None = None
                   ) -> list[Finding]:
    """Return count-jump and count-glitch findings of an encoder counter.

    Parameters
    ----------
    counts : array_like
        Counter values as recorded (32-bit wraps and index reloads are removed first).
    time : array_like
        Sample times in s.
    channel : str
        Name used in the findings.
    counts_per_rev : float, optional
        Counts per revolution (removes index reloads; revolutions of the findings).
    valid : array_like of bool, optional
        Usable samples.

    Returns
    -------
    list of Finding
        One ``"count jump"`` and one ``"count glitch"`` finding at most, each listing its
        samples and revolutions.
    """
    raw = np.asarray(counts)
    t = times_of(time)
    ok = np.ones(raw.size, bool) if valid is None else np.asarray(valid, dtype=bool)
    if ok.sum() < _RATE_WINDOW:
        return []
    spread, large = _departures(raw, ok, counts_per_rev)
    threshold = max(_JUMP_COUNTS, _JUMP_SIGMAS * spread)
    keep = np.abs(large.departure) > threshold
    odd = large.index[keep]
    departure = dict(zip(odd.tolist(), large.departure[keep].tolist(), strict=True))
    since = dict(zip(odd.tolist(), large.counts[keep].tolist(), strict=True))
    glitches, jumps = [], []
    used: set[int] = set()
    for k in odd.tolist():
        if k in used:
            continue
        later = odd[(odd > k) & (odd <= k + _GLITCH_SAMPLES)].tolist()
        undone = [j for j in later if abs(departure[k] + departure[j]) <= threshold]
        if undone:
            glitches.append((k, departure[k]))
            used.update((k, undone[0]))
        else:
            jumps.append((k, departure[k]))
            used.add(k)
    out = []
    for fault, steps in (("count jump", jumps), ("count glitch", glitches)):
        if not steps:
            continue
        found = [(k + 1, size) for k, size in steps]  # the sample after the step
        where = np.array([i for i, _ in found], dtype=np.int64)
        sizes = [round(s) for _, s in found]
        revs = (tuple(int(np.floor(since[k] / counts_per_rev)) for k, _ in steps[:50])
                if counts_per_rev else ())
        listed = ", ".join(f"{s:+d} counts at {t[i]:.3f} s" for i, s in found[:3]
                           for s in [round(s)])
        more = f" and {len(found) - 3} more" if len(found) > 3 else ""
        out.append(Finding(channel, fault, f"{len(found)} {fault}{_plural(fault, len(found))}"
                                           f": {listed}{more}", where.size, int(where[0]),
                           int(where[-1]), float(t[where[0]]), float(t[where[-1]]),
                           float(sizes[0]), tuple(int(i) for i in where[:50]), revs))
    return out


def pulse_health(x: ArrayLike, time: ArrayLike, *, channel: str,
                 valid: ArrayLike | None = None, segment: ArrayLike | None = None
                 ) -> list[Finding]:
    """Return a ``"pulse width"`` finding when the pulses' mark width changes.

    Parameters
    ----------
    x : array_like
        Pulse channel samples (rising edge first; a high pulse on a low level).
    time : array_like
        Sample times in s.
    channel : str
        Name used in the findings.
    valid, segment : array_like, optional
        The stream's ``valid`` and ``segment`` (no edge across a gap).

    Returns
    -------
    list of Finding
        At most one finding: the pulses after the change (their indices as revolutions).
    """
    t = times_of(time)
    try:
        rises = detect_edges(x, t, polarity="rising", valid=valid, segment=segment)
        falls = detect_edges(x, t, polarity="falling", valid=valid, segment=segment)
    except DataError as error:  # a channel without two levels has no pulses
        logger.info("%s: no pulses to check (%s)", channel, error)
        return []
    if rises.size < 2 * _WIDTH_SIDE + 1:
        return []
    period = float(np.median(np.diff(rises)))
    nxt = np.searchsorted(falls, rises)
    has = nxt < falls.size
    width = np.full(rises.size, np.nan)
    width[has] = falls[nxt[has]] - rises[has]
    # pulses off the grid of whole periods (spurious ones) are left out; a missing pulse
    # keeps the count of periods
    turns = (rises - rises[0]) / period
    # the grid's phase is that of most pulses (the first one may be spurious)
    angle = 2 * np.pi * turns
    turns -= float(np.angle(np.mean(np.exp(1j * angle)))) / (2 * np.pi)
    on_grid = np.abs(turns - np.round(turns)) < 0.2
    width[(width <= 0) | (width >= 0.9 * period) | ~on_grid] = np.nan
    good = np.flatnonzero(np.isfinite(width))
    if good.size < 2 * _WIDTH_SIDE + 1:
        return []
    turn = np.round(turns[good]).astype(np.int64)
    part = (np.zeros(good.size, dtype=np.int64) if segment is None else np.asarray(segment)[
        np.clip(np.searchsorted(t, rises[good]), 0, t.size - 1)].astype(np.int64))
    relative = width[good] / np.median(width[good])
    split, _, _ = _step(relative)
    # a pattern repeating every 2-4 pulses is taken out when it leaves clearly less scatter
    chosen, scatter = relative, np.inf
    for repeat in range(1, 5):
        less = _without_pattern(relative, turn, part, repeat, split)
        k, jump, _ = _step(less)
        spread = float(np.median(np.abs(less - np.where(np.arange(less.size) < k, np.median(
            less[:k]), np.median(less[k:])))))
        if spread < 0.7 * scatter:
            chosen, scatter = less, spread
    k, jump, se = _step(chosen)
    if abs(jump) <= max(_WIDTH_SHARE, _WIDTH_SIGMAS * se):
        return []
    pulses = good[k:]
    first, last = np.searchsorted(t, rises[pulses[0]]), np.searchsorted(t, rises[pulses[-1]])
    return [Finding(channel, "pulse width",
                    f"pulse width changes by {100.0 * jump:+.3g} % from pulse "
                    f"{int(pulses[0])} ({rises[pulses[0]]:.3f} s) on: {pulses.size} of "
                    f"{rises.size} pulses", int(pulses.size), int(first), int(last),
                    float(rises[pulses[0]]), float(rises[pulses[-1]]), jump,
                    revolutions=tuple(int(p) for p in pulses[:50]))]
