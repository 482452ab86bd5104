"""Pulse edge shapes: a first-order rise fitted to the samples around each edge, onset and bound.

An optical sensor whose output rises with a first-order time constant ``tau`` of a fraction of a
sample period, sampled without an anti-alias filter, is neither sample-switched nor band-limited:
the mid-level crossing interpolated between samples is late by about ``tau ln 2`` and off by a
fraction of a sample that depends on where the edge falls between samples. When the drive period
is no whole number of samples that place beats slowly from pulse to pulse, so the edge errors are
correlated: the clock fit's residuals stay small while each edge is 100-300 us off
(docs/processing.md, "Edge shapes and the quantisation limit").

:func:`fit_edges` fits, jointly over all edges of a channel, three shapes with one width each
and one time per edge: a first-order rise ``1 - exp(-(t - t0) / tau)`` from its onset ``t0``, a
symmetric (error-function) edge and a band-limited step (``1/2 + Si(t / w) / pi``, as a
delta-sigma module's filter passes a fast edge). When the first-order rise fits clearly better,
each edge's time is its onset and its bound is what the samples leave open: the span of onsets
that fit within the noise (a whole sample interval when no sample caught the rise), widened by
how far the onset moves over every ``tau`` the edges as a whole allow.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import ArrayLike
from scipy.special import erf, sici

from rigval.acquisition.sample_times import times_of
from rigval.processing.arrays import FloatArray

__all__ = ["SYMMETRIC_BOUND", "EdgeFit", "fit_edges"]

logger = logging.getLogger(__name__)

#: Samples before and after the sample preceding each mid crossing that the fit looks at.
_BEFORE, _AFTER = 6, 14
#: Candidate widths in samples for the first scan: tau of the first-order rise, sigma of the
#: symmetric edge.
_WIDTHS = np.geomspace(0.01, 4.0, 36)
#: Candidate edge times around each guess, in samples (step 0.02).
_OFFSETS = np.linspace(-1.6, 1.6, 161)
#: Step of :data:`_OFFSETS` in samples, and the steps in a sample interval (a whole number).
_STEP = 0.02
_STEPS_PER_SAMPLE = round(1.0 / _STEP)
#: Every distance in samples of a sample after a candidate time, decreasing: lattice index 0 is
#: the last sample's from the first candidate, the last index the first sample's from the last.
_DISTANCES = (_STEP * np.arange(_STEPS_PER_SAMPLE * (_BEFORE + _AFTER) + _OFFSETS.size)
              - (_BEFORE + _OFFSETS[-1]))[::-1].copy()
#: Edges the first scan looks at (evenly picked).
_SCAN_EDGES = 60
#: Least noise rms (share of the step) the fit assumes: no sample is known better (a 16-bit
#: converter's quantisation on a 4 V step is 2e-5 rms).
_NOISE_FLOOR = 1e-4
#: A shape is chosen when its misfit is below the others' by this many noise variances (the
#: two fits share the data: 5 sigma of a chi-square difference); closer, the edges are
#: ``"ambiguous"``.
_DECIDE = 25.0
#: Bound in samples of the correlated error of a symmetric (band-limited) edge's crossing: the
#: windowed-sinc reconstruction's own error and the state levels' bias (run means up to 0.0016
#: sample measured on band-limited steps, docs/processing.md "Edge shapes").
SYMMETRIC_BOUND = 0.005
#: Least ``|x|`` whose error function rounds to +-1, with a margin (it does from 5.92 on).
_ERF_SATURATED = 6.0
#: A symmetric edge narrower than this (sigma, samples) is not resolved by the samples.
_UNRESOLVED = 0.3
#: Widths whose total misfit exceeds the best by less than this many noise variances stay
#: possible (chi-square, 1 degree of freedom, 99.9 %).
_WIDTH_CHI2 = 10.83
#: Relative steps of tau around the best one over which the possible widths are looked for.
_TAU_STEPS = np.exp(np.linspace(-0.4, 0.4, 17))
#: An edge time fits when its misfit exceeds the edge's best by less than this many variances.
_TIME_CHI2 = 1.0


@dataclass(frozen=True)
class EdgeFit:
    """Edge times and bounds from the fitted edge shape of one pulse channel.

    Attributes
    ----------
    shape : str
        ``"first-order"`` (times are onsets), ``"unresolved"`` (a symmetric edge narrower than
        the samples resolve: the given crossings, bound half a sample), ``"symmetric"`` (the
        given crossings, bound :data:`SYMMETRIC_BOUND` sample) or ``"ambiguous"`` (a
        first-order rise and a symmetric edge fit alike: times halfway between onset and
        crossing, bounds covering both).
    times : numpy.ndarray
        Edge times in s.
    bounds_s : numpy.ndarray
        Bound in s of each edge time's error that is not random from edge to edge.
    width_samples : float
        Fitted tau (first-order) or sigma (symmetric) in sample periods.
    misfit_ratio : float
        Misfit of the first-order rise over that of the symmetric edge (1).
    """

    shape: str
    times: FloatArray
    bounds_s: FloatArray
    width_samples: float
    misfit_ratio: float


def _windows(x: FloatArray, time: FloatArray, edges: FloatArray, fs: float
             ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Return each usable edge's samples (rows), its crossing in samples, start times, use mask."""
    j = np.searchsorted(time, edges) - 1
    inside = (j - _BEFORE >= 0) & (j + _AFTER < x.size)
    rows = np.arange(-_BEFORE, _AFTER + 1)
    idx = np.clip(j, _BEFORE, x.size - _AFTER - 1)[:, None] + rows[None, :]
    samples = x[idx]
    spans = time[idx[:, -1]] - time[idx[:, 0]]
    regular = np.abs(spans * fs - (_BEFORE + _AFTER)) < 0.01 * (_BEFORE + _AFTER)
    use = inside & regular & np.all(np.isfinite(samples), axis=1)
    position = (edges - time[np.clip(j, 0, time.size - 1)]) * fs
    return samples, position, time[np.clip(j, 0, time.size - 1)], use


def _shape(u: FloatArray, width: float, shape: str) -> FloatArray:
    """Return the normalised edge of ``shape`` and ``width`` ``u`` samples after its edge time."""
    out = np.array(u, dtype=np.float64)
    return _shape_in_place(out, width, shape, np.empty(out.shape))


def _shape_in_place(u: FloatArray, width: float, shape: str, spare: FloatArray) -> FloatArray:
    """Return the edge of ``shape`` and ``width`` at ``u`` samples after its edge time, in place.

    The operations of the closed forms, in their order, written over ``u`` and ``spare`` (of
    ``u``'s shape): the result is one of the two. The values are the closed forms' to the bit.
    """
    if shape == "first-order":  # -expm1(-clip(u, 0) / width); clip(u, 0) is maximum(u, 0)
        np.maximum(u, 0.0, out=u)
        np.negative(u, u)
        u /= width
        np.expm1(u, u)
        return np.negative(u, u)
    if shape == "band-limited":  # 0.5 + Si(u / width) / pi
        u /= width
        sici(u, u, spare)
        u /= np.pi
        u += 0.5
        return u
    u /= width * np.sqrt(2.0)
    return _symmetric_in_place(u, spare)


def _symmetric(x: FloatArray) -> FloatArray:
    """Return ``(1 + erf(x)) / 2``, the error function evaluated only where it is not +-1.

    ``erf(x)`` rounds to +-1 from ``|x| = 5.92`` on (``erfc(5.92) < 2**-54``): beyond
    :data:`_ERF_SATURATED` the value is 1 or 0, as the full evaluation gives it. A narrow edge
    leaves most of the lattice there (a fifth of it is evaluated at sigma 0.3 sample).
    """
    x = np.asarray(x, dtype=np.float64)
    return _symmetric_in_place(x, np.empty(x.shape))


def _symmetric_in_place(x: FloatArray, spare: FloatArray) -> FloatArray:
    """Return :func:`_symmetric` of ``x`` in ``spare`` (of its shape); ``x`` is left as it was.

    (scipy's ``erf`` is not called with ``where=``: in scipy 1.17 it writes outside the mask.)
    """
    inside = np.abs(x, out=spare) < _ERF_SATURATED
    value = np.greater(x, 0.0, out=spare)
    saturating = erf(x[inside])
    saturating += 1.0
    saturating *= 0.5
    value[inside] = saturating
    return value


class _Work:
    """Work arrays the evaluations of one channel's edges share, each grown to the largest asked.

    An evaluation of a width fills a lattice of model values per edge and the residuals of
    every (sample, candidate) pair: about 0.3 and 0.9 MB at 32 edges, made anew for each of a
    channel's 170 evaluations. glibc handed such arrays back to the system as they were freed
    and mapped them again for the next (page faults: as much system time as the arithmetic).
    """

    def __init__(self) -> None:
        self._held: dict[str, FloatArray] = {}

    def array(self, name: str, shape: tuple[int, ...]) -> FloatArray:
        """Return the work array ``name`` with ``shape`` (contents undefined, C-contiguous)."""
        size = math.prod(shape)
        held = self._held.get(name)
        if held is None or held.size < size:
            held = self._held[name] = np.empty(size)
        return held[:size].reshape(shape)


def _misfit(y: FloatArray, times: FloatArray, width: float, shape: str) -> FloatArray:
    """Sum of squares per (edge, candidate time) of the normalised samples ``y`` (edges, k)."""
    r = np.arange(-_BEFORE, _AFTER + 1, dtype=np.float64)
    model = _shape(r[None, None, :] - times[:, :, None], width, shape)
    return np.sum((y[:, None, :] - model) ** 2, axis=2)


def _grid(y: FloatArray, guess: FloatArray, width: float, shape: str,
          work: _Work | None = None) -> tuple[FloatArray, FloatArray]:
    """Candidate edge times (samples) per edge for one width, and their misfits.

    The distances of an edge's samples from its candidate times all lie on one lattice of step
    :data:`_STEP` (a sample interval is a whole number of steps): the shape is evaluated once
    per lattice point (:data:`_DISTANCES`) and each (sample, candidate) pair reads its value
    through a strided view, a third of the evaluations of one per pair and no copies. The
    misfits equal :func:`_misfit`'s to rounding. The lattice and the residuals are held in
    ``work`` (default: arrays of this call's own).
    """
    work = work or _Work()
    centre = guess - (width * np.log(2.0) if shape == "first-order" else 0.0)
    candidates = centre[:, None] + _OFFSETS[None, :]
    lattice = work.array("lattice", (guess.size, _DISTANCES.size))
    np.subtract(_DISTANCES[None, :], centre[:, None], out=lattice)
    model = _shape_in_place(lattice, width, shape, work.array("spare", lattice.shape))
    # pairs[e, k, j] = model[e, (last sample - k) * steps per sample + j]: each sample's
    # candidates read forward (the residuals' fast loop)
    pairs = sliding_window_view(model, _OFFSETS.size, axis=1)[:, ::-_STEPS_PER_SAMPLE]
    residual = np.subtract(y[:, :, None], pairs,
                           out=work.array("residual", (guess.size, *pairs.shape[1:])))
    residual *= residual
    return candidates, residual.sum(axis=1)


def _refined(y: FloatArray, candidates: FloatArray, grid: FloatArray, width: float,
             shape: str) -> tuple[FloatArray, FloatArray]:
    """Return each edge's best time (samples) between grid points and its misfit.

    A parabola through the grid's minimum and its neighbours; the misfit is evaluated there and
    never exceeds the grid's minimum.
    """
    k = np.clip(np.argmin(grid, axis=1), 1, grid.shape[1] - 2)
    rows = np.arange(grid.shape[0])
    left, mid, right = grid[rows, k - 1], grid[rows, k], grid[rows, k + 1]
    curvature = left - 2.0 * mid + right
    with np.errstate(divide="ignore", invalid="ignore"):
        shift = np.where(curvature > 0, 0.5 * (left - right) / curvature, 0.0)
    step = candidates[:, 1] - candidates[:, 0]
    times = candidates[rows, k] + np.clip(shift, -1.0, 1.0) * step
    misfit = _misfit(y, times[:, None], width, shape)[:, 0]
    best = grid.min(axis=1)
    better = misfit < best
    return (np.where(better, times, candidates[rows, np.argmin(grid, axis=1)]),
            np.where(better, misfit, best))


def _total(y: FloatArray, guess: FloatArray, width: float, shape: str, work: _Work) -> float:
    """Misfit summed over the edges, each at its best time (between the fine grid's points)."""
    candidates, grid = _grid(y, guess, width, shape, work)
    return float(_refined(y, candidates, grid, width, shape)[1].sum())


def _scan(y: FloatArray, guess: FloatArray, shape: str, work: _Work) -> tuple[float, float]:
    """Best width (samples) and its total misfit over the given edges.

    A scan over ``_WIDTHS``, then a golden-section search of the log width between the best
    one's neighbours; each edge at its best time (:func:`_total`).
    """
    totals = [_total(y, guess, w, shape, work) for w in _WIDTHS]
    i = int(np.argmin(totals))
    lo, hi = np.log(_WIDTHS[max(i - 1, 0)]), np.log(_WIDTHS[min(i + 1, _WIDTHS.size - 1)])
    ratio = (np.sqrt(5.0) - 1.0) / 2.0
    a, b = hi - ratio * (hi - lo), lo + ratio * (hi - lo)
    fa, fb = _total(y, guess, np.exp(a), shape, work), _total(y, guess, np.exp(b), shape, work)
    for _ in range(16):
        if fa <= fb:
            hi, b, fb = b, a, fa
            a = hi - ratio * (hi - lo)
            fa = _total(y, guess, np.exp(a), shape, work)
        else:
            lo, a, fa = a, b, fb
            b = lo + ratio * (hi - lo)
            fb = _total(y, guess, np.exp(b), shape, work)
    return (float(np.exp(a)), fa) if fa <= fb else (float(np.exp(b)), fb)


def _span(candidates: FloatArray, grid: FloatArray, variance: float
          ) -> tuple[FloatArray, FloatArray]:
    """Earliest and latest candidate time per edge whose misfit is within the threshold."""
    fits = grid <= grid.min(axis=1, keepdims=True) + _TIME_CHI2 * variance
    return (np.where(fits, candidates, np.inf).min(axis=1),
            np.where(fits, candidates, -np.inf).max(axis=1))


def fit_edges(x: ArrayLike, time: ArrayLike, edges: ArrayLike, *, fs: float, low: float,
              high: float, noise: float) -> EdgeFit:
    """Fit the edge shape of a pulse channel; return onsets and bounds for a first-order rise.

    Parameters
    ----------
    x : array_like
        Pulse signal samples, oriented so that the edges rise (negate a falling edge's signal).
    time : array_like
        Sample times in s.
    edges : array_like
        Mid-level crossing times in s of the edges (:func:`~rigval.processing.pulses.detect_edges`).
    fs : float
        Sampling rate in Hz.
    low, high : float
        State levels in the unit of ``x``.
    noise : float
        Rms noise of the signal in the unit of ``x`` (from its flat parts).

    Returns
    -------
    EdgeFit
        First-order onsets with bounds; the given crossings with bound half a sample
        (``"unresolved"``: a symmetric edge narrower than 0.3 sample) or
        :data:`SYMMETRIC_BOUND` (``"symmetric"``, also when fewer than 3 edges can be fitted);
        halfway between for ``"ambiguous"`` edges (the misfits differ by at most 25 noise
        variances).
    """
    data = np.asarray(x, dtype=np.float64)
    t = times_of(time)
    given = np.asarray(edges, dtype=np.float64)
    unchanged = EdgeFit("symmetric", given, np.full(given.size, SYMMETRIC_BOUND / fs), 0.0, 1.0)
    samples, position, start, use = _windows(data, t, given, fs)
    if use.sum() < 3:
        return unchanged
    y = (samples[use] - low) / (high - low)
    guess = position[use]
    # the shapes are told apart on a few edges (cost); the onsets come from all of them
    pick = np.unique(np.linspace(0, guess.size - 1, min(guess.size, _SCAN_EDGES)).astype(int))
    work = _Work()
    tau, first = _scan(y[pick], guess[pick], "first-order", work)
    sigma, symmetric = _scan(y[pick], guess[pick], "symmetric", work)
    band, limited = _scan(y[pick], guess[pick], "band-limited", work)
    ratio = float(first / max(min(symmetric, limited), 1e-300))
    # the shapes' misfits differ by more than the noise can make them differ: decided
    noise_var = max((noise / (high - low)) ** 2, _NOISE_FLOOR**2)
    excess = (min(symmetric, limited) - first) / noise_var
    unresolved = symmetric < limited and sigma < _UNRESOLVED
    width = sigma if symmetric < limited else band
    crossing_bound = (0.5 if unresolved else SYMMETRIC_BOUND) / fs
    if excess < -_DECIDE:
        if unresolved:
            return EdgeFit("unresolved", given, np.full(given.size, crossing_bound), sigma,
                           ratio)
        return EdgeFit("symmetric", given, np.full(given.size, crossing_bound), width, ratio)
    first = _total(y, guess, tau, "first-order", work)
    dof = max(y.size - guess.size - 1, 1)
    variance = max((noise / (high - low)) ** 2, first / dof, _NOISE_FLOOR**2)
    candidates, grid = _grid(y, guess, tau, "first-order", work)
    lo_best, hi_best = _span(candidates, grid, variance)
    best_time, _ = _refined(y, candidates, grid, tau, "first-order")
    centre = 0.5 * (np.minimum(lo_best, best_time) + np.maximum(hi_best, best_time))
    reach = np.maximum(hi_best - centre, centre - lo_best)
    possible = 1
    for factor in _TAU_STEPS:
        candidates, grid = _grid(y, guess, tau * factor, "first-order", work)
        if _refined(y, candidates, grid, tau * factor, "first-order")[1].sum() > (
                first + _WIDTH_CHI2 * variance):
            continue
        possible += 1
        lo, hi = _span(candidates, grid, variance)
        reach = np.maximum(reach, np.maximum(hi - centre, centre - lo))
    step = _OFFSETS[1] - _OFFSETS[0]
    times = given.copy()
    bounds = np.full(given.size, 0.5 / fs)  # edges the fit could not see: half a sample
    times[use] = start[use] + centre / fs
    bounds[use] = (reach + step) / fs
    if excess <= _DECIDE:
        # either shape fits within the noise: the time lies between the onset and the
        # crossing, bounded so that both hold
        between = 0.5 * np.abs(times - given)
        times, bounds = 0.5 * (times + given), between + np.maximum(bounds, crossing_bound)
        logger.info("edges fit a first-order rise (tau %.3g samples) and a symmetric edge "
                    "alike: times between onset and crossing, median bound %.3g samples", tau,
                    float(np.median(bounds)) * fs)
        return EdgeFit("ambiguous", times, bounds, tau, ratio)
    logger.info("first-order edges: tau %.3g samples (%d widths fit), misfit %.3g of the "
                "symmetric edge's, median bound %.3g samples", tau, possible, ratio,
                float(np.median(bounds[use])) * fs)
    return EdgeFit("first-order", times, bounds, tau, ratio)
