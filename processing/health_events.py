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

import logging

import numpy as np
from numpy.typing import ArrayLike
from scipy.ndimage import median_filter

from rigval.acquisition.errors import DataError
from rigval.processing.arrays import BoolArray, FloatArray, IntArray
from rigval.processing.block_median import exact_median
from rigval.processing.encoder import remove_index_resets, unwrap_counts
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


def _running_median(x: FloatArray, width: int) -> FloatArray:
    """Median of ``width`` samples around each sample (the ends repeated)."""
    return median_filter(x, size=width, mode="nearest")


def _plural(noun: str, count: int) -> str:
    """Return the ending of ``noun`` for ``count`` ("es" after a sibilant)."""
    if count == 1:
        return ""
    return "es" if noun.endswith(("ch", "sh", "s", "x")) else "s"


def _steps(cumulative: IntArray, lo: int, hi: int) -> IntArray:
    """Return count steps ``lo ... hi - 1`` (step ``k`` from sample ``k`` to ``k + 1``)."""
    return np.diff(cumulative[lo:hi + 1])


def _rate_departure(cumulative: IntArray, usable: BoolArray, typical: float) -> FloatArray:
    """Return each count step minus the running median rate around it (0 where not usable).

    Unusable steps enter the median as ``typical``. Worked in blocks of ``_BLOCK`` steps, each
    with half the median's window of neighbours on either side, so the values equal those of
    one median over the whole record without its full-length temporaries (the steps
    themselves are taken from ``cumulative`` block by block).
    """
    half = _RATE_WINDOW // 2
    size = cumulative.size - 1
    departure = np.zeros(size)
    for lo, hi in _blocks(size):
        start, stop = max(lo - half, 0), min(hi + half, size)
        step = _steps(cumulative, start, stop)
        filled = np.where(usable[start:stop], step, typical)
        rate = _running_median(filled, _RATE_WINDOW)[lo - start:hi - start]
        departure[lo:hi] = np.where(usable[lo:hi], step[lo - start:hi - start] - rate, 0.0)
    return departure


def _blocks(size: int) -> list[tuple[int, int]]:
    """Split ``0 ... size - 1`` into blocks of at most ``_BLOCK``."""
    return [(lo, min(lo + _BLOCK, size)) for lo in range(0, size, _BLOCK)]


def _filled_counts(raw: np.ndarray, ok: BoolArray) -> IntArray:
    """Return the counter values as int64, 0 where not usable, filled a block at a time."""
    counts = np.empty(raw.size, np.int64)
    for lo, hi in _blocks(raw.size):
        counts[lo:hi] = np.where(ok[lo:hi], raw[lo:hi], 0)
    return counts


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


def _step(d: FloatArray) -> tuple[int, float, float]:
    """Return where two constant levels fit ``d`` best, the step between them and its error.

    The split minimises the absolute deviations from each side's median (a pulse put on the
    wrong side costs its whole difference); the step is the difference of the medians, its
    standard error from the robust scatter about them.
    """
    splits = np.arange(_WIDTH_SIDE, d.size - _WIDTH_SIDE + 1)
    cost = [np.abs(d[:k] - np.median(d[:k])).sum() + np.abs(d[k:] - np.median(d[k:])).sum()
            for k in splits]
    k = int(splits[int(np.argmin(cost))])
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
    t = np.asarray(time, dtype=np.float64)
    ok = np.ones(raw.size, bool) if valid is None else np.asarray(valid, dtype=bool)
    if ok.sum() < _RATE_WINDOW:
        return []
    cumulative = unwrap_counts(_filled_counts(raw, ok), overwrite=True)  # its own int64 copy
    if counts_per_rev:
        cumulative, _ = remove_index_resets(cumulative, counts_per_rev, overwrite=True)
    usable = ok[1:] & ok[:-1]
    steps = _blocks(usable.size)  # the medians exact, a block at a time (memory)
    typical = exact_median(_steps(cumulative, lo, hi)[usable[lo:hi]] for lo, hi in steps)
    departure = _rate_departure(cumulative, usable, float(np.nan_to_num(typical)))
    spread = 1.4826 * exact_median(np.abs(departure[lo:hi][usable[lo:hi]]) for lo, hi in steps)
    threshold = max(_JUMP_COUNTS, _JUMP_SIGMAS * spread)
    odd = np.concatenate([lo + np.flatnonzero(np.abs(departure[lo:hi]) > threshold)
                          for lo, hi in steps] or [np.zeros(0, np.int64)])
    glitches, jumps = [], []
    used: set[int] = set()
    for k in odd:
        if k in used:
            continue
        later = odd[(odd > k) & (odd <= k + _GLITCH_SAMPLES)]
        undone = [j for j in later if abs(departure[k] + departure[j]) <= threshold]
        if undone:
            glitches.append((int(k) + 1, float(departure[k])))
            used.update((int(k), int(undone[0])))
        else:
            jumps.append((int(k) + 1, float(departure[k])))
            used.add(int(k))
    def turn(i: int) -> int:
        return int(np.floor((cumulative[i] - cumulative[0]) / counts_per_rev))
    out = []
    for fault, found in (("count jump", jumps), ("count glitch", glitches)):
        if not found:
            continue
        where = np.array([i for i, _ in found], dtype=np.int64)
        sizes = [round(s) for _, s in found]
        revs = tuple(turn(i) for i in where[:50]) if counts_per_rev else ()
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
    t = np.asarray(time, dtype=np.float64)
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
