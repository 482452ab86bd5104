"""Pairing a device's events with reference events: candidate offsets, whole periods, strays.

Step 2 of the clock alignment (:mod:`rigval.processing.clock_fit`, docs/processing.md "Clock
alignment"): for one gap-free device segment, candidate offsets come from pairing its first
events with every reference event within ``coarse_offset_s +- max_offset_error_s``; the stamps
decide the whole periods when that window is narrower than a period, else the data must (one
class fitting the events it shares with every other 3 times better). Pairs are then made along
the candidate's robust line, and stray partners dropped against a Theil-Sen line with the one
outlier rule of the alignment, :func:`robust_inliers`.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from rigval.processing.arrays import BoolArray, FloatArray, IntArray
from rigval.processing.errors import AlignmentError

__all__ = [
    "OUTLIER_SIGMAS",
    "SLOPES_HELD",
    "SLOPE_BINS",
    "Match",
    "match_events",
    "match_segment",
    "pairwise_slope_median",
    "robust_inliers",
    "without_strays",
]

logger = logging.getLogger(__name__)

#: Candidate offsets are scored on the events of this many seconds at the start of a segment.
_SCORING_SPAN_S = 60.0
#: A runner-up candidate whose residual scale is within this factor of the best makes the match
#: ambiguous.
_AMBIGUITY_FACTOR = 3.0
#: A candidate whole periods outside the stamps' window whose residual scale, on the device
#: events both match, is this many times smaller than the best inside it, says the stamps are worse
#: than stated (a wrong whole period leaves the speed wander, milliseconds; the right one
#: timing jitter).
_OUTSIDE_FACTOR = 10.0
#: ... judged only on this many common events (a line through fewer says little).
_OUTSIDE_MIN_EVENTS = 6
#: Residual scales below this (s) count as equal: no clock is timed better than a nanosecond.
_TIMING_FLOOR_S = 1e-9
#: Matched events farther than this many robust sigmas (1.4826 times the median absolute
#: deviation) from a clock line count as strays: the one cut of every robust refit here and of
#: the alignment diagnostics (docs/processing.md, "Clock alignment", gives the coverage figures
#: that chose 5 over 6).
OUTLIER_SIGMAS = 5.0


def robust_inliers(residual: ArrayLike, *, among: ArrayLike | None = None,
                   floor_s: float = 0.0) -> BoolArray:
    """Return which residuals lie within :data:`OUTLIER_SIGMAS` robust sigmas of their centre.

    The centre is the median and the robust sigma 1.4826 times the median absolute deviation
    (the standard deviation of Gaussian residuals, unmoved by a fifth of strays), both taken
    over the residuals selected by ``among``.

    Parameters
    ----------
    residual : array_like
        Residuals in s (NaN is never an inlier).
    among : array_like of bool, optional
        Residuals that set the centre and the scale (default: the finite ones).
    floor_s : float, default 0
        Distance in s from the centre that always counts as inlying (a timing bound below which
        a sharp residual distribution would otherwise reject good events).

    Returns
    -------
    numpy.ndarray of bool
        True for the inliers; all False when ``among`` selects nothing.
    """
    res = np.asarray(residual, dtype=np.float64)
    use = np.isfinite(res) if among is None else np.asarray(among, dtype=bool) & np.isfinite(res)
    if not use.any():
        return np.zeros(res.shape, dtype=bool)
    centre = float(np.median(res[use]))
    sigma = 1.4826 * float(np.median(np.abs(res[use] - centre)))
    with np.errstate(invalid="ignore"):
        return np.abs(res - centre) <= max(OUTLIER_SIGMAS * sigma, floor_s)


def _nearest(sorted_ref: FloatArray, targets: FloatArray) -> IntArray:
    """Return the index of the nearest reference time for each target."""
    right = np.clip(np.searchsorted(sorted_ref, targets), 1, sorted_ref.size - 1)
    left = right - 1
    pick_left = np.abs(targets - sorted_ref[left]) <= np.abs(sorted_ref[right] - targets)
    return np.where(pick_left, left, right)


def _line_residual(x: FloatArray, y: FloatArray) -> tuple[FloatArray, float]:
    """Fit ``y = p0 + p1 x`` robustly; return ``(p0, p1)`` and the robust residual scale.

    A first line from the median of the pairwise slopes (Theil-Sen: a stray partner 0.1 period
    off cannot drag it, as it drags a least-squares line), the scale 1.4826 times the median
    absolute deviation about it; points beyond :data:`OUTLIER_SIGMAS` of it are dropped before
    a least-squares fit of the rest, so a stray partner does not decide between candidate
    offsets.
    """
    if x.size < 3:
        return np.array([float(np.mean(y - x)) if x.size else 0.0, 1.0]), np.inf
    centre = x.mean()
    slope, res = _theil_sen(x - centre, y)
    scale = 1.4826 * float(np.median(np.abs(res)))
    use = robust_inliers(res, floor_s=1e-12)
    coeffs = np.array([slope, float(np.median(y - slope * (x - centre)))])
    if use.sum() >= 3:
        coeffs = np.polyfit(x[use] - centre, y[use], 1)
        res = y - np.polyval(coeffs, x - centre)
        scale = 1.4826 * float(np.median(np.abs(res[use] - np.median(res[use]))))
    return np.array([coeffs[1] - coeffs[0] * centre, coeffs[0]]), scale


@dataclass(frozen=True)
class Match:
    """Matched pairs of one device segment and how their whole periods were decided.

    Attributes
    ----------
    ref_index, dev_index : numpy.ndarray of int
        Indices of the paired reference and device events.
    offset_s : float
        The winning candidate offset ``t_ref - t_dev`` in s.
    decided_by : str
        ``"stamps"``, ``"data"`` or ``"neighbour"`` (see
        :attr:`~rigval.processing.clock_fit.ClockModel.periods_decided_by`).
    """

    ref_index: IntArray
    dev_index: IntArray
    offset_s: float
    decided_by: str


def _settle_hint(keys: Sequence[str] | None, period: float) -> str:
    """Return the how-to-fix text naming the keys that settle the whole periods."""
    if keys:
        offset_key, uncertainty_key = keys
        return (f"set {offset_key} to the right candidate (e.g. from a note of when each device "
                f"started, or an event both devices saw), or, if the start stamps are better "
                f"than assumed, {uncertainty_key} below half a period ({period / 2:.3g} s)")
    return (f"give coarse_offset_s good to {period / 2:.3g} s and max_offset_error_s below half "
            "a period")


def _score(ref: FloatArray, scoring: FloatArray, offset: float, period: float,
           tolerance: float) -> tuple[int, float, float, float]:
    """Return one candidate's events matched, residual scale (s), offset (s), matched share.

    The share is of the events the candidate places inside the reference record: an offset
    that moves events off the record's ends is not penalised for them.
    """
    hit, nearest = _hits(ref, scoring, offset, period, tolerance)
    _, scale = _line_residual(scoring[hit], ref[nearest[hit]])
    predicted = scoring + offset
    inside = np.count_nonzero((predicted > ref[0] - tolerance * period)
                              & (predicted < ref[-1] + tolerance * period))
    return int(hit.sum()), scale, float(offset), hit.sum() / max(inside, 1)


def _hits(ref: FloatArray, scoring: FloatArray, offset: float, period: float,
          tolerance: float) -> tuple[BoolArray, IntArray]:
    """Return which scoring events a candidate matches and their reference partners."""
    predicted = scoring + offset
    nearest = _nearest(ref, predicted)
    return np.abs(ref[nearest] - predicted) < tolerance * period, nearest


def _theil_sen(x: FloatArray, y: FloatArray) -> tuple[float, FloatArray]:
    """Return the Theil-Sen slope through (x, y) and the residuals about that line.

    The slope is the median of the pairwise slopes; the residuals are centred on their median.
    """
    slope = pairwise_slope_median(x, y)
    res = y - slope * x
    return slope, res - np.median(res)


#: Pairwise slopes held at once when their median is taken: above, it is selected pass by pass
#: (:func:`pairwise_slope_median`; an hour's 7000 events of one segment have 24.5 M slopes).
SLOPES_HELD = 2_000_000


def _slope_rows(x: FloatArray, y: FloatArray, rows: range) -> Iterator[FloatArray]:
    """Yield row i's slopes ``(y[j] - y[i]) / (x[j] - x[i])``, ``j > i``, for i in ``rows``."""
    for i in rows:
        row = np.subtract(y[i + 1:], y[i])
        row /= x[i + 1:] - x[i]
        yield row


#: Bins of the counting pass of :func:`pairwise_slope_median`: edges from a sample of the slopes,
#: so that the bins holding the middle ranks keep about ``total / SLOPE_BINS`` slopes.
SLOPE_BINS = 1024


def pairwise_slope_median(x: FloatArray, y: FloatArray) -> float:
    """Return the median of all pairwise slopes, exactly as numpy.median of them all.

    Up to :data:`SLOPES_HELD` slopes they are taken at once. Beyond, the median is selected
    without holding them, in two passes over the slopes row by row: the first counts them in
    bins whose edges are quantiles of the slopes of every k-th row (:data:`SLOPE_BINS`), the
    second keeps only those of the bins that hold the middle ranks, from which the middle ranks
    are picked. A sample of rows far from the median of all only makes those bins fuller.

    Parameters
    ----------
    x, y : numpy.ndarray
        ``(n,)`` abscissae (distinct) and ordinates.

    Returns
    -------
    float
        The median slope (NaN if any slope is NaN, as numpy.median gives it).
    """
    n = x.size
    total = n * (n - 1) // 2
    if total <= SLOPES_HELD:
        rows = list(_slope_rows(x, y, range(n - 1)))
        return float(np.median(np.concatenate(rows) if rows else np.zeros(0)))
    ranks = ((total - 1) // 2, total // 2)
    stride = max(1, (total + SLOPES_HELD - 1) // SLOPES_HELD)
    sample = np.sort(np.concatenate(list(_slope_rows(x, y, range(0, n - 1, stride)))))
    if np.isnan(sample[-1]):
        return math.nan
    edges = np.unique(sample[::max(1, sample.size // SLOPE_BINS)])
    del sample
    # bin b holds the slopes in [edges[b - 1], edges[b]), bin 0 those below edges[0]
    counts = np.zeros(edges.size + 1, dtype=np.int64)
    for row in _slope_rows(x, y, range(n - 1)):
        if np.isnan(row).any():
            return math.nan
        counts += np.bincount(np.searchsorted(edges, row, side="right"), minlength=counts.size)
    cumulative = np.cumsum(counts)
    first, last = (int(np.searchsorted(cumulative, rank, side="right")) for rank in ranks)
    below = int(cumulative[first - 1]) if first else 0
    low = edges[first - 1] if first else -np.inf
    high = edges[last] if last < edges.size else np.inf
    kept = np.sort(np.concatenate([row[(row >= low) & (row < high)]
                                   for row in _slope_rows(x, y, range(n - 1))]))
    return float(np.mean(kept[[ranks[0] - below, ranks[1] - below]]))


def _line_fit(x: FloatArray, y: FloatArray) -> FloatArray:
    """Residuals of y about the Theil-Sen line through (x, y)."""
    return _theil_sen(x, y)[1]


def _rms_about_line(x: FloatArray, y: FloatArray) -> float:
    centred = x - x.mean()
    return float(np.sqrt(np.mean((y - np.polyval(np.polyfit(centred, y, 1), centred)) ** 2)))


def _far_better(ref: FloatArray, scoring: FloatArray, best: float, other: float,
                period: float, tolerance: float, *, factor: float = _OUTSIDE_FACTOR,
                min_common: int = _OUTSIDE_MIN_EVENTS) -> bool:
    """Whether ``other`` fits the events both candidates match ``factor`` times better.

    Compared on the same device events: on those, every whole-period shift of an exactly
    periodic train leaves the same residuals, so fitting fewer events (or another part of a
    sawtooth) cannot make a candidate look better. Pairs off either candidate's line by more
    than 5 % of a period (a stray partner) are left out; the rest are compared by their rms
    about a least-squares line. False with fewer than ``min_common`` such events.
    """
    hit_best, near_best = _hits(ref, scoring, best, period, tolerance)
    hit_other, near_other = _hits(ref, scoring, other, period, tolerance)
    common = np.flatnonzero(hit_best & hit_other)
    if common.size < max(min_common, 3):
        return False
    x = scoring[common]
    y_best, y_other = ref[near_best[common]] - x, ref[near_other[common]] - x
    keep = ((np.abs(_line_fit(x, y_best)) <= 0.05 * period)
            & (np.abs(_line_fit(x, y_other)) <= 0.05 * period))
    if keep.sum() < max(min_common, 3):
        return False
    return (factor * _rms_about_line(x[keep], y_other[keep]) + _TIMING_FLOOR_S
            < _rms_about_line(x[keep], y_best[keep]))


def _describe(scored: Sequence[tuple[int, float, float, float]]) -> str:
    return "; ".join(f"{offset:.6g} s ({hits} events, residual scale {scale:.3g} s)"
                     for hits, scale, offset, _ in scored)


def match_segment(ref: FloatArray, dev: FloatArray, *, coarse_offset_s: float,
                  max_offset_error_s: float, tolerance: float, place: Mapping[str, Any],
                  settle_keys: Sequence[str] | None, min_hits: int = 3) -> Match:
    """Pair one segment's device events with reference events (as :func:`match_events`).

    Parameters
    ----------
    ref, dev : numpy.ndarray
        Reference events (s, reference clock) and the segment's device events (s, device
        clock), increasing.
    coarse_offset_s, max_offset_error_s, tolerance, settle_keys
        As in :func:`match_events`.
    place : mapping
        Context for error messages.
    min_hits : int, default 3
        Fewest matched events a candidate needs (2 for a segment matched around another
        segment's offset, whose drift the other segments give).

    Returns
    -------
    Match
        The pairs and what decided the whole periods.

    Raises
    ------
    AlignmentError
        As :func:`match_events`.
    """
    if ref.size < 3 or dev.size < min_hits:
        raise AlignmentError(f"too few events to align: {ref.size} reference and {dev.size} "
                             f"device events (need 3 and {min_hits})", where=place,
                             hint="check pulse thresholds and that the records overlap")
    period = float(np.median(np.diff(ref)))
    dev_period = float(np.median(np.diff(dev)))
    if abs(dev_period / period - 1.0) > 0.2:
        raise AlignmentError(
            f"inconsistent periods: device events every {dev_period:.6g} s, reference events "
            f"every {period:.6g} s", where=place,
            hint="build reference events at the device pulse rate (events_per_rev) and check "
                 "that both sensors watch the same shaft")
    scoring = dev[dev <= dev[0] + max(_SCORING_SPAN_S, 10 * period)]
    # Seeds: the first device events that can have a partner (a device that started before the
    # reference has events before the reference record).
    shifted = dev + coarse_offset_s
    seeds = dev[(shifted >= ref[0] - max_offset_error_s)
                & (shifted <= ref[-1] + max_offset_error_s)][:3]
    candidates = []
    for seed in seeds:
        lo, hi = np.searchsorted(ref, [seed + coarse_offset_s - max_offset_error_s,
                                       seed + coarse_offset_s + max_offset_error_s])
        candidates.extend(ref[lo:hi] - seed)
    if not candidates:
        raise AlignmentError(
            f"no overlap: no reference event within {max_offset_error_s:.3g} s of the device "
            f"events shifted by the coarse offset {coarse_offset_s:.6g} s", where=place,
            hint=_settle_hint(settle_keys, period) if settle_keys else
            "check the start times of both files or widen max_offset_error_s")
    step = tolerance * period / 4
    candidates = np.unique(np.round(np.asarray(candidates) / step)) * step
    scored = [_score(ref, scoring, offset, period, tolerance) for offset in candidates]
    most = max(s[0] for s in scored)
    share = max((s[3] for s in scored if s[0] >= max(min_hits, 0.5 * most)), default=0.0)
    contenders = sorted((s for s in scored if s[0] >= max(min_hits, 0.5 * most)
                         and s[3] >= 0.8 * share), key=lambda s: s[1])
    if not contenders:
        raise AlignmentError(f"too few matched events: at most {most} of {scoring.size} device "
                             "events found a reference partner", where=place,
                             hint="check the coarse offset and the reference events")
    best = contenders[0]
    if 2.0 * max_offset_error_s < period:
        # The stamps' window holds one whole-period class: the stamps decide. A candidate whole
        # periods outside it that fits far better says the stamps are worse than stated.
        decided = "stamps"
        reach = int(np.ceil(min(_SCORING_SPAN_S, 5.0 * period) / period))
        outside = [_score(ref, scoring, best[2] + k * period, period, tolerance)
                   for k in range(-reach, reach + 1) if k]
        better = sorted((s for s in outside
                         if _far_better(ref, scoring, best[2], s[2], period, tolerance)),
                        key=lambda s: s[1])
        if better:
            keys = settle_keys or ("coarse_offset_s", "max_offset_error_s")
            raise AlignmentError(
                f"the start stamps look off by more than their stated uncertainty "
                f"({max_offset_error_s:.3g} s): inside the window the best offset is "
                f"{_describe([best])}, but {_describe(better[:2])} fits far better",
                where=place,
                hint=f"set {keys[0]} to {better[0][2]:.6g} s if the stamps are known to be off, "
                     f"or {keys[1]} to at least {abs(better[0][2] - coarse_offset_s):.3g} s so "
                     "that the data decide")
    else:
        # The data decide: one whole-period class must fit the events it shares with every
        # other class 3 times better (compared on common events: a candidate that leaves
        # events off the record's ends must not win by fitting fewer of them).
        decided = "data"
        classes: list[tuple[int, float, float, float]] = []
        for s in contenders:
            if all(abs(s[2] - c[2]) > 0.5 * period for c in classes):
                classes.append(s)
        winners = [c for c in classes
                   if all(_far_better(ref, scoring, d[2], c[2], period, tolerance,
                                      factor=_AMBIGUITY_FACTOR, min_common=4)
                          for d in classes if d is not c)]
        if len(classes) > 1 and not winners:
            raise AlignmentError(
                f"whole-period ambiguity: {len(classes)} offsets fit equally well within the "
                f"start stamps' window of +-{max_offset_error_s:.3g} s around "
                f"{coarse_offset_s:.6g} s: {_describe(sorted(classes, key=lambda s: s[2]))}; "
                "the pulse intervals are too regular to tell whole periods apart", where=place,
                hint=_settle_hint(settle_keys, period))
        best = winners[0] if winners else classes[0]
    predicted = scoring + best[2]
    nearest = _nearest(ref, predicted)
    hit = np.abs(ref[nearest] - predicted) < tolerance * period
    line, _ = _line_residual(scoring[hit], ref[nearest[hit]])
    predicted = line[0] + line[1] * dev
    nearest = _nearest(ref, predicted)
    hit = np.abs(ref[nearest] - predicted) < tolerance * period
    dev_index = np.flatnonzero(hit)
    ref_index = nearest[hit]
    # One reference event takes at most one device event: keep the closer one.
    order = np.argsort(np.abs(ref[ref_index] - predicted[dev_index]), kind="stable")
    _, first = np.unique(ref_index[order], return_index=True)
    keep = np.sort(order[first])
    return Match(ref_index[keep].astype(np.int64), dev_index[keep].astype(np.int64),
                  float(best[2]), decided)


def match_events(ref_times: ArrayLike, dev_times: ArrayLike, *, coarse_offset_s: float = 0.0,
                 max_offset_error_s: float = 5.0, tolerance: float = 0.25,
                 where: Mapping[str, Any] | None = None,
                 settle_keys: Sequence[str] | None = None) -> tuple[IntArray, IntArray]:
    """Pair device events with reference events within the start stamps' window.

    Candidate offsets outside ``coarse_offset_s +- max_offset_error_s`` are not considered.
    When the window is narrower than a reference period, it holds one whole-period class and the
    stamps decide the whole periods; otherwise the data must (the true offset leaves timing
    jitter, one whole periods off leaves the period-to-period speed variation).

    Parameters
    ----------
    ref_times : array_like
        Reference events in s on the reference clock, increasing.
    dev_times : array_like
        Events of one gap-free device segment in s on the device clock, increasing.
    coarse_offset_s : float, default 0
        Rough ``t_ref - t_dev`` in s (from the files' start times).
    max_offset_error_s : float, default 5
        How far in s the coarse offset may be wrong (the start stamps' stated uncertainty).
    tolerance : float, default 0.25
        Largest match distance as a fraction of the reference period.
    where : mapping, optional
        Context for error messages (stream, channel).
    settle_keys : (str, str), optional
        Names of the coarse-offset and the start-time-uncertainty settings, for error messages
        (e.g. scene keys); default: this function's parameters.

    Returns
    -------
    ref_index, dev_index : numpy.ndarray of int
        Indices of the matched pairs.

    Raises
    ------
    AlignmentError
        Too few events, no overlap, inconsistent periods, whole-period ambiguity (listing each
        candidate offset with its evidence) or a far better fit outside the stamps' window.
    """
    match = match_segment(np.asarray(ref_times, dtype=np.float64),
                   np.asarray(dev_times, dtype=np.float64), coarse_offset_s=coarse_offset_s,
                   max_offset_error_s=max_offset_error_s, tolerance=tolerance,
                   place=dict(where or {}), settle_keys=settle_keys)
    return match.ref_index, match.dev_index


def without_strays(match: Match, ref: FloatArray, dev: FloatArray, bound: float) -> Match:
    """Drop pairs beyond :data:`OUTLIER_SIGMAS` of the segment's Theil-Sen line (a stray partner).

    A least-squares fit with a partner 0.1 period off is dragged so far that a sigma-based
    rejection after it can miss the stray; the median of pairwise slopes is not. At most a fifth
    of the pairs go.
    """
    if match.ref_index.size < 4:
        return match
    x = dev[match.dev_index]
    keep = robust_inliers(_line_fit(x - x.mean(), ref[match.ref_index] - x),
                          floor_s=2.0 * bound + 1e-6)
    if keep.sum() < 0.8 * keep.size:
        return match
    return dataclasses.replace(match, ref_index=match.ref_index[keep],
                               dev_index=match.dev_index[keep])
