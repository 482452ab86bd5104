"""Clock alignment: a model ``t_ref = a_j + (1 + drift) t_dev`` per gap-free segment j.

Each device has its own oscillator (offset: file start times are software stamps, off by ms to
seconds; drift: tens of ppm; Wi-Fi restarts start new segments). The model is fitted by least
squares on matched reference events (docs/processing.md, *Accuracy measured*):

1. events on both clocks, with module input delays removed (:func:`input_delay`);
2. for each device segment, candidate offsets from pairing its first events with every reference
   event within ``coarse_offset_s +- max_offset_error_s`` (the start stamps' stated bound; nothing
   outside it is considered). A window narrower than a period holds one whole-period class: the
   stamps decide. Otherwise one class must fit the events it shares with every other 3 times
   better (the true offset leaves timing jitter, one whole periods off the period-to-period speed
   variation), or an :class:`AlignmentError` lists the candidates and names the settings that
   decide (:mod:`rigval.processing.event_match`);
3. all events matched with the candidate's line, stray partners dropped against a Theil-Sen
   line, then one joint least-squares fit of a shared drift and one offset per clock group
   (segments a dropout did not restart share one), with 95 % intervals that hold for the
   sawtooth error of sample-switched edges (docs/processing.md, "Clock alignment").

Pulses at a multiple of the reference rate (the lifting shaft's opt3, twice per main revolution)
are matched to reference events built at that multiple from the reference angle
(:func:`reference_event_times`), so every device pulse has a partner. Several event kinds (rising
and falling edges) can be fitted together. :func:`align_stream` then puts a stream on the
reference timeline without touching its samples.
"""

from __future__ import annotations

import dataclasses
import itertools
import logging
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.special
import xarray as xr
from numpy.typing import ArrayLike

from rigval.acquisition.devices import ni9237_input_delay
from rigval.acquisition.errors import DataError, DataWarning
from rigval.acquisition.sample_times import (
    clocked_time_coordinate,
    indexed_time_coordinate,
    time_coordinate,
)
from rigval.acquisition.schema import (
    append_history,
    cf_time_attrs,
    invalid_counts,
    with_invalid_counts,
)
from rigval.processing.arrays import BoolArray, FloatArray, IntArray, distinct_in_runs
from rigval.processing.encoder import increasing_angle, interp_minus
from rigval.processing.errors import AlignmentError
from rigval.processing.event_match import Match, match_segment, robust_inliers, without_strays

__all__ = [
    "ClockModel",
    "align_stream",
    "channel_time",
    "estimate_clock",
    "identity_clock",
    "input_delay",
    "ni9237_input_delay",
    "quantisation_limit",
    "reference_event_times",
    "student_t_975",
]

logger = logging.getLogger(__name__)


def input_delay(attrs: Mapping[str, Any], fs: float) -> float:
    """Return a channel's module input delay in s from its attributes.

    ``input_delay_s`` is used when present; otherwise a ``module`` attribute naming the NI 9237
    gives :func:`ni9237_input_delay`; anything else (counters, DI, SAR modules) has no delay.

    Parameters
    ----------
    attrs : mapping
        The channel variable's attributes.
    fs : float
        The stream's sampling rate in Hz.
    """
    if "input_delay_s" in attrs:
        return float(attrs["input_delay_s"])
    if "9237" in str(attrs.get("module", "")):
        return ni9237_input_delay(fs)
    return 0.0


def reference_event_times(time: ArrayLike, angle: ArrayLike, *, event_angle: float = 0.0,
                          events_per_rev: int = 1, delay_s: float = 0.0) -> FloatArray:
    """Return the times at which an unwrapped, increasing angle passes a reference position.

    Parameters
    ----------
    time : array_like
        Sample times in s.
    angle : array_like
        Unwrapped angle in rad, strictly increasing (e.g. phi_F from the main-shaft encoder);
        NaN samples (invalid, unfilterable) are skipped.
    event_angle : float, default 0
        Angle in rad at which the device's pulse fires (its mounting position in that angle).
    events_per_rev : int, default 1
        Pulses per revolution of ``angle`` (2 for the lifting-shaft sensor against phi_F).
    delay_s : float, default 0
        The angle's samples were taken at ``time - delay_s`` (its input delay, s); taken off
        the events without a copy of ``time`` (:func:`~rigval.processing.encoder.interp_minus`).

    Returns
    -------
    numpy.ndarray
        Times in s of ``angle = event_angle + k 2 pi / events_per_rev`` inside the record.
    """
    t, phi = increasing_angle(time, angle, use="to locate reference events")
    step = 2.0 * np.pi / events_per_rev
    first = np.ceil((phi[0] - event_angle) / step)
    last = np.floor((phi[-1] - event_angle) / step)
    targets = event_angle + step * np.arange(first, last + 1)
    return interp_minus(targets, phi, t, delay_s)


@dataclass(frozen=True)
class ClockModel:
    """Map from a device clock to the reference clock, per gap-free segment.

    ``t_ref = offsets_s[j] + (1 + drift) * t_dev`` for samples of segment ``segments[j]``.

    Attributes
    ----------
    segments : tuple of int
        Device segment indices that could be aligned.
    offsets_s : tuple of float
        Offset a_j in s per aligned segment.
    drift : float
        Relative rate difference b - 1 (1; multiply by 1e6 for ppm).
    residual_rms_s : float
        Rms of the fit residuals in s.
    pulses_matched : int
        Events used in the fit.
    pulses_total : int
        Device events offered.
    offset_std_s : float
        Residual-based standard error of the offsets in s (largest over segments).
    drift_std : float
        Residual-based standard error of the drift (1).
    unaligned_segments : tuple of int
        Device segments without enough matched events (their samples become invalid).
    offsets_u95_s : tuple of float
        Half-width in s of the 95 % interval of each offset (residual-based Student-t interval
        combined with the bound of sample-switched edge times, docs/processing.md).
    drift_u95 : float
        Half-width of the 95 % interval of the drift (1).
    periods_decided_by : str
        What decided the whole pulse periods: ``"stamps"`` (the start stamps' window was
        narrower than a period), ``"data"`` (the pulse intervals), ``"neighbour"`` (a segment
        matched around another segment's offset), joined with ``+`` when segments differ.
    clock_groups : tuple of int
        Clock group of each aligned segment: segments of one group share one offset (a dropout
        during which the device clock ran on).
    """

    segments: tuple[int, ...]
    offsets_s: tuple[float, ...]
    drift: float
    residual_rms_s: float
    pulses_matched: int
    pulses_total: int
    offset_std_s: float = 0.0
    drift_std: float = 0.0
    unaligned_segments: tuple[int, ...] = field(default_factory=tuple)
    offsets_u95_s: tuple[float, ...] = field(default_factory=tuple)
    drift_u95: float = 0.0
    periods_decided_by: str = "data"
    clock_groups: tuple[int, ...] = field(default_factory=tuple)

    def to_reference(self, time: ArrayLike, segment: ArrayLike | int = 0) -> FloatArray:
        """Return reference-clock times (s) for device times (s) of the given segment(s).

        Samples of unaligned segments map to NaN.
        """
        t = np.asarray(time, dtype=np.float64)
        given = np.asarray(segment)
        bounds = None
        if given.shape == t.shape and t.ndim == 1 and t.size:
            # A stream's segments come in a few blocks: one offset per block, added in place,
            # instead of whole-record index and offset arrays (memory; same arithmetic).
            bounds = np.concatenate(([0], np.flatnonzero(given[1:] != given[:-1]) + 1,
                                     [t.size]))
        if bounds is None or bounds.size > 10_000:
            seg = np.broadcast_to(given.astype(np.int64, copy=False), t.shape)
            size = max(max(self.segments, default=0), int(seg.max(initial=0))) + 1
            lookup = np.full(size, np.nan)
            lookup[list(self.segments)] = self.offsets_s
            offset = np.where(seg >= 0, lookup[np.clip(seg, 0, size - 1)], np.nan)
            return offset + (1.0 + self.drift) * t
        offsets = dict(zip(self.segments, self.offsets_s, strict=True))
        out = (1.0 + self.drift) * t
        for a, b in itertools.pairwise(bounds):
            out[a:b] += offsets.get(int(given[a]), np.nan)
        return out

    def attrs(self) -> dict[str, Any]:
        """Return the clock model as netCDF-storable attributes (docs/processing.md).

        Scalars ``clock_offset_s`` (first segment), ``clock_drift_ppm``, their standard errors and
        95 % half-widths, ``residual_rms_s``, ``pulses_matched``/``pulses_total``; one entry per
        aligned segment in the arrays ``segments`` (device segment index),
        ``segment_clock_offset_s``, ``segment_clock_offset_u95_s`` and ``segment_clock_group``;
        ``unaligned_segments`` (int64 array, empty when every segment was aligned).
        """
        return {
            "clock_offset_s": float(self.offsets_s[0]),
            "clock_drift_ppm": self.drift * 1e6,
            "clock_drift_std_ppm": self.drift_std * 1e6,
            "clock_offset_std_s": self.offset_std_s,
            "clock_offset_u95_s": float(self.offsets_u95_s[0]) if self.offsets_u95_s else 0.0,
            "clock_drift_u95_ppm": self.drift_u95 * 1e6,
            "periods_decided_by": self.periods_decided_by,
            "residual_rms_s": self.residual_rms_s,
            "pulses_matched": self.pulses_matched,
            "pulses_total": self.pulses_total,
            "segments": np.array(self.segments, dtype=np.int64),
            "segment_clock_offset_s": np.array(self.offsets_s, dtype=np.float64),
            "segment_clock_offset_u95_s": np.array(
                self.offsets_u95_s or (0.0,) * len(self.segments), dtype=np.float64),
            "segment_clock_group": np.array(self.clock_groups or self.segments, dtype=np.int64),
            "unaligned_segments": np.array(self.unaligned_segments, dtype=np.int64),
        }


def identity_clock(segments: ArrayLike = (0,)) -> ClockModel:
    """Return the clock model of the reference device itself (offset 0, drift 0)."""
    segs = tuple(int(s) for s in distinct_in_runs(np.asarray(segments).ravel()))
    return ClockModel(segs, tuple(0.0 for _ in segs), 0.0, 0.0, 0, 0)


def _event_kinds(ref_times: ArrayLike | Sequence[ArrayLike],
                 dev_times: ArrayLike | Sequence[ArrayLike],
                 dev_segment: ArrayLike | Sequence[ArrayLike] | None,
                 ) -> list[tuple[FloatArray, FloatArray, IntArray]]:
    """Normalise one or several event kinds to a list of (ref, dev, segment) arrays."""
    several = isinstance(ref_times, (list, tuple)) and len(ref_times) > 0 and np.ndim(
        ref_times[0]) == 1
    refs = list(ref_times) if several else [ref_times]
    devs = list(dev_times) if several else [dev_times]
    segs = (list(dev_segment) if several and dev_segment is not None
            else [dev_segment] * len(refs))
    if not len(refs) == len(devs) == len(segs):
        raise DataError(f"{len(refs)} reference event kinds but {len(devs)} device kinds")
    kinds = []
    for ref, dev, seg in zip(refs, devs, segs, strict=True):
        d = np.asarray(dev, dtype=np.float64)
        g = np.zeros(d.size, dtype=np.int64) if seg is None else np.asarray(seg, dtype=np.int64)
        kinds.append((np.asarray(ref, dtype=np.float64), d, g))
    return kinds


def _intervals95(design: FloatArray, residual: FloatArray, bound: FloatArray,
                 transform: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Return standard errors and 95 % half-widths of ``transform @ coefficients``.

    The half-width combines the residual-based interval (Student t with the fit's degrees of
    freedom) with the worst case of bounded event-time errors: ``sum_i |w_i| h_i`` where ``w``
    are the estimator's weights and ``h_i`` the bound of event i (half a sample of a sample-
    switched edge). A sawtooth quantisation error is correlated from event to event (it beats
    slowly, and a line absorbs part of it), so it is bounded, not averaged.
    """
    weights = transform @ np.linalg.pinv(design)
    dof = design.shape[0] - design.shape[1]
    sigma2 = float(residual @ residual) / dof if dof > 0 else np.inf
    se = np.sqrt(sigma2 * np.sum(weights**2, axis=1))
    quantile = student_t_975(dof) if dof > 0 else np.inf
    worst = np.abs(weights) @ bound
    return se, np.sqrt((quantile * se) ** 2 + worst**2)


def student_t_975(dof: float) -> float:
    """Return Student's t quantile of 0.975 for ``dof`` degrees of freedom (95 % two-sided).

    ``scipy.stats.t.ppf(0.975, dof)`` to the bit, from the function it calls
    (``scipy.special.stdtrit``), without loading :mod:`scipy.stats` (a run never needs it:
    :mod:`rigval.processing.scipy_signal`).
    """
    return float(scipy.special.stdtrit(dof, 0.975))


def quantisation_limit(dev_times: ArrayLike, fs: float) -> tuple[float, float]:
    """Return the quantisation limit of a clock fit on sampled edges: offset (s), drift (1).

    Without a model of its shape, an edge is located only within the sample interval that
    holds its crossing, to ``h = 1 / (2 fs)``. The most such errors can move the least-squares
    line ``t_ref = a + (1 + d) t_dev`` is ``h sum_i |w_i|`` with ``w`` the estimator's weights:
    ``w_d,i = (t_i - tbar) / S_tt`` for the drift and ``w_a,i = 1 / n - tbar w_d,i`` for the
    offset at device time 0 (docs/processing.md, "Edge shapes and the quantisation limit").

    Parameters
    ----------
    dev_times : array_like
        The fitted device events in s on the device clock (at least 2 distinct).
    fs : float
        The device's sampling rate in Hz.
    """
    t = np.asarray(dev_times, dtype=np.float64)
    centred = t - t.mean()
    w_drift = centred / float(centred @ centred)
    w_offset = 1.0 / t.size - t.mean() * w_drift
    half = 0.5 / fs
    return half * float(np.abs(w_offset).sum()), half * float(np.abs(w_drift).sum())


def _segment_starts(kinds: Sequence[tuple[FloatArray, FloatArray, IntArray]]
                    ) -> dict[int, float]:
    """Return each segment's first device event in s (0 at the latest: time since the stamps)."""
    starts: dict[int, float] = {}
    for _, dev, seg in kinds:
        for s in np.unique(seg):
            first = float(dev[seg == s].min(initial=np.inf))
            starts[int(s)] = max(min(starts.get(int(s), np.inf), first), 0.0)
    return starts


def _clock_fit(ref: FloatArray, dev: FloatArray, group: IntArray, kind: IntArray,
               bound: FloatArray) -> tuple[dict[int, float], float, FloatArray, FloatArray,
                                            FloatArray]:
    """Least squares ``ref = a_group + c_kind + (1 + drift) dev``.

    Returns offsets per group (s), drift, residuals (s), standard errors and 95 % half-widths
    of (offsets..., drift).
    """
    groups, column = np.unique(group, return_inverse=True)
    kinds = [k for k in np.unique(kind) if k != kind.min()]
    centre = float(dev.mean())
    design = np.zeros((dev.size, groups.size + len(kinds) + 1))
    design[np.arange(dev.size), column] = 1.0
    for n, k in enumerate(kinds):
        design[:, groups.size + n] = kind == k
    design[:, -1] = dev - centre
    coeffs, *_ = np.linalg.lstsq(design, ref - dev, rcond=None)
    residual = ref - dev - design @ coeffs
    drift = float(coeffs[-1])
    # reported: a_j = c_j - drift * centre, and the drift
    transform = np.zeros((groups.size + 1, design.shape[1]))
    transform[np.arange(groups.size), np.arange(groups.size)] = 1.0
    transform[:groups.size, -1] = -centre
    transform[-1, -1] = 1.0
    se, half = _intervals95(design, residual, bound, transform)
    offsets = {int(g): float(coeffs[i] - drift * centre) for i, g in enumerate(groups)}
    return offsets, drift, residual, se, half


def _median_centred(residual: FloatArray, among: BoolArray,
                    labels: Sequence[IntArray]) -> FloatArray:
    """Return residuals (s) less the median of each label's class, label after label.

    The medians are taken over the residuals selected by ``among``; a class with none of them
    becomes NaN (never an inlier).
    """
    out = np.array(residual, dtype=np.float64)
    for label in labels:
        for value in np.unique(label):
            this = label == value
            chosen = out[this & among]
            out[this] -= np.median(chosen) if chosen.size else np.nan
    return out


def estimate_clock(ref_times: ArrayLike | Sequence[ArrayLike],
                   dev_times: ArrayLike | Sequence[ArrayLike],
                   dev_segment: ArrayLike | Sequence[ArrayLike] | None = None, *,
                   coarse_offset_s: float = 0.0, max_offset_error_s: float = 5.0,
                   min_events: int = 5, max_residual_s: float = 1e-3,
                   timing_bound_s: float | Sequence[float] = 0.0,
                   clock_groups: Mapping[int, int] | None = None, per_revolution: int = 1,
                   settle_keys: Sequence[str] | None = None,
                   where: Mapping[str, Any] | None = None,
                   drift_bound: float = 0.0) -> ClockModel:
    """Estimate a device's clock model from its reference events.

    Every segment is matched within the start stamps' window
    (:func:`~rigval.processing.event_match.match_segment`), widened by ``drift_bound`` times
    the segment's start on the device clock: a restart hours into a record takes a new host
    stamp, but the reference's record has run off host time meanwhile (50 ppm is 0.5 s after
    three hours). A segment the window leaves undecided, or that lands whole periods off the
    best-matched segment although the clocks cannot have run that far apart between the two,
    is matched again within 0.4 event period of that segment's offset (a restart's new stamp
    is off by milliseconds, not periods). One least-squares fit then gives one drift, one offset per
    clock group and, with several pulses per revolution, a constant per pulse (each may fire at
    its own angle). Residuals beyond :data:`~rigval.processing.event_match.OUTLIER_SIGMAS`
    robust sigmas are left out, unless that would leave out more than a fifth of the pairs
    (then the residual check decides).

    Parameters
    ----------
    ref_times : array_like or sequence of array_like
        Reference events in s on the reference clock (delay-corrected), increasing. A list of
        arrays gives several event kinds (e.g. rising and falling edges), each matched with its
        own kind and all fitted together (more events, smaller error).
    dev_times : array_like or sequence of array_like
        The device's events in s on its own clock (delay-corrected), increasing, per kind;
        spurious and missing pulses are allowed.
    dev_segment : array_like of int or sequence of them, optional
        Gap-free segment of each device event, per kind (default: one segment).
    coarse_offset_s : float, default 0
        Rough ``t_ref - t_dev`` in s, e.g. from the start-time attributes.
    max_offset_error_s : float, default 5
        How far in s the coarse offset may be wrong (the stamps' stated uncertainty).
    min_events : int, default 5
        Fewest matched events overall; a segment needs at least 2 of its own.
    max_residual_s : float, default 1e-3
        Largest acceptable residual rms in s.
    timing_bound_s : float, array_like or sequence of them, default 0
        Bound in s of each event's time error that is not random from event to event (half a
        sample of a sample-switched edge on either clock; a first-order edge's onset bound,
        :func:`~rigval.processing.pulses.time_edges`), per kind: one for all its events or
        one per device event.
    clock_groups : mapping of int to int, optional
        Segment -> clock group: segments of one group share one offset (a dropout during which
        the device clock ran on). Default: each segment its own.
    per_revolution : int, default 1
        Reference events per revolution (a constant per pulse of the revolution is fitted).
    settle_keys : (str, str), optional
        Names of the coarse-offset and start-time-uncertainty settings for error messages.
    where : mapping, optional
        Context for error messages.
    drift_bound : float, default 0
        How fast (1) the coarse offset may go off with time since the starts: the sum of both
        clocks' oscillator tolerances (:func:`rigval.processing.stamps.clock_tolerance`).

    Returns
    -------
    ClockModel
        The fitted model with 95 % intervals; segments without 2 matched events are listed as
        unaligned.

    Raises
    ------
    AlignmentError
        When no trustworthy model can be fitted (with the reason).
    """
    kinds = _event_kinds(ref_times, dev_times, dev_segment)
    given = (list(timing_bound_s) if isinstance(timing_bound_s, (list, tuple))
             else [timing_bound_s] * len(kinds))
    # one bound per device event of each kind (a scalar is every event's)
    bounds = [np.broadcast_to(np.asarray(b, dtype=np.float64), dev.shape)
              for b, (_, dev, _) in zip(given, kinds, strict=True)]
    place = dict(where or {})
    all_segments = np.unique(np.concatenate([seg for _, _, seg in kinds]))
    groups = {int(s): int((clock_groups or {}).get(int(s), s)) for s in all_segments}
    matches: dict[tuple[int, int], Match] = {}
    failures: list[tuple[int, AlignmentError]] = []
    starts = _segment_starts(kinds)
    for kind, (ref, dev, seg) in enumerate(kinds):
        for s in np.unique(seg):
            try:
                matches[(kind, int(s))] = match_segment(
                    ref, dev[seg == s], coarse_offset_s=coarse_offset_s,
                    max_offset_error_s=max_offset_error_s + drift_bound * starts[int(s)],
                    tolerance=0.25,
                    place={**place, "segment": int(s), "event_kind": kind},
                    settle_keys=settle_keys)
            except AlignmentError as error:
                if all_segments.size == 1 and len(kinds) == 1:
                    raise
                logger.info("segment %d, event kind %d not matched: %s", s, kind, error)
                failures.append((int(np.count_nonzero(seg == s)), error))
    if not matches:
        # the segment with the most events says best why
        raise max(failures, key=lambda f: f[0])[1]
    anchor = max(matches, key=lambda k: (matches[k].ref_index.size, -k[1]))
    anchor_offset = matches[anchor].offset_s
    for kind, (ref, dev, seg) in enumerate(kinds):
        period = float(np.median(np.diff(ref))) if ref.size > 1 else np.inf
        for s in np.unique(seg):
            found = matches.get((kind, int(s)))
            # how far the clocks may have run apart between the anchor's start and this one's
            apart = drift_bound * abs(starts[int(s)] - starts[anchor[1]])
            if apart >= 0.4 * period:
                continue  # too far in time for the anchor's offset to tell whole periods
            if found is not None and abs(found.offset_s - anchor_offset) <= 0.5 * period:
                continue
            if np.count_nonzero(seg == s) < 2:
                continue
            try:
                again = match_segment(ref, dev[seg == s], coarse_offset_s=anchor_offset,
                               max_offset_error_s=min(max_offset_error_s + apart, 0.4 * period),
                               tolerance=0.25, place={**place, "segment": int(s)},
                               settle_keys=settle_keys, min_hits=2)
            except AlignmentError as error:
                logger.info("segment %d stays unaligned: %s", s, error)
                matches.pop((kind, int(s)), None)
                continue
            logger.info("segment %d matched around segment %d's offset %.6f s", s, anchor[1],
                        anchor_offset)
            matches[(kind, int(s))] = dataclasses.replace(again, decided_by="neighbour")
    for key, m in list(matches.items()):
        matches[key] = without_strays(m, kinds[key[0]][0], kinds[key[0]][1][
            kinds[key[0]][2] == key[1]], float(bounds[key[0]].max(initial=0.0)))
    count = {int(s): 0 for s in all_segments}
    for (_, s), m in matches.items():
        count[s] += m.ref_index.size
    unaligned = sorted(s for s, n in count.items() if n < 2)
    rows = [(kinds[k][0][m.ref_index], kinds[k][1][kinds[k][2] == s][m.dev_index],
             np.full(m.ref_index.size, groups[s]), np.full(m.ref_index.size, s),
             m.ref_index % per_revolution, bounds[k][kinds[k][2] == s][m.dev_index])
            for (k, s), m in sorted(matches.items()) if s not in unaligned]
    if not rows:
        raise AlignmentError("no segment of the device could be matched to reference events",
                             where=place, hint="check the pulse channel and the coarse offset")
    r, d, g, segment_of, kind_of, h = (np.concatenate(c) for c in zip(*rows, strict=True))
    keep = np.ones(r.size, dtype=bool)
    for _ in range(2):
        _offsets, drift, _res, _se, _half = _clock_fit(r[keep], d[keep], g[keep],
                                                       kind_of[keep], h[keep])
        # the offsets by medians: a least-squares offset of a short segment takes a share of
        # its stray partner's error onto every pair of that segment
        residual = _median_centred(r - (1 + drift) * d, keep, (g, kind_of))
        trial = robust_inliers(residual, among=keep, floor_s=2.0 * float(h.max()) + 1e-6)
        if trial.sum() < max(0.8 * r.size, min_events):
            logger.info("rejection would leave %d of %d pairs: all kept", trial.sum(), r.size)
            break
        keep = trial
    # one degree of freedom at least: offsets per clock group, constants per pulse, the drift
    needed = max(min_events, np.unique(g[keep]).size + np.unique(kind_of[keep]).size + 1)
    if keep.sum() < needed:
        raise AlignmentError(f"too few matched events: {int(keep.sum())} (need {needed})",
                             where=place, hint="record longer or check the pulse channels")
    offsets, drift, residual, se, half = _clock_fit(r[keep], d[keep], g[keep], kind_of[keep],
                                                    h[keep])
    rms = float(np.sqrt(np.mean(residual**2)))
    if rms > max_residual_s:
        keys = settle_keys or ("coarse_offset_s", "max_offset_error_s")
        raise AlignmentError(
            f"clock fit residual rms {rms:.3g} s exceeds {max_residual_s:.3g} s", where=place,
            hint="the events may be paired whole periods off (start stamps worse than stated): "
                 f"set {keys[1]} to the stamps' real bound so that the data decide, or "
                 f"{keys[0]}; otherwise check the event angle and the pulse channel")
    segments = tuple(sorted({int(s) for s in segment_of[keep]}))
    unaligned.extend(s for s in count if s not in segments and s not in unaligned)
    ordered = sorted(offsets)
    decided = sorted({m.decided_by for m in matches.values()})
    model = ClockModel(
        segments, tuple(offsets[groups[s]] for s in segments), drift, rms, int(keep.sum()),
        sum(dev.size for _, dev, _ in kinds), float(np.max(se[:-1])), float(se[-1]),
        tuple(sorted(unaligned)),
        offsets_u95_s=tuple(float(half[ordered.index(groups[s])]) for s in segments),
        drift_u95=float(half[-1]), periods_decided_by="+".join(decided),
        clock_groups=tuple(groups[s] for s in segments))
    logger.info("clock model: offset %.9f s +- %.3g s, drift %.4f +- %.4f ppm (95 %%), "
                "rms %.3g s, %d/%d events, periods decided by %s", model.offsets_s[0],
                model.offsets_u95_s[0], drift * 1e6, model.drift_u95 * 1e6, rms,
                model.pulses_matched, model.pulses_total, model.periods_decided_by)
    return model


def channel_time(aligned: xr.Dataset, name: str) -> FloatArray:
    """Return the reference-clock time (s) at which a channel's samples were taken.

    That is the aligned ``time`` minus the channel's ``input_delay_s`` (on the reference clock).
    """
    delay = float(aligned[name].attrs.get("input_delay_s", 0.0))
    return aligned["time"].to_numpy() - delay


def _maps_to_itself(clock: ClockModel, segment: np.ndarray) -> bool:
    """Return whether ``clock`` gives every sample of these segments its own time (identity).

    Offset 0 and drift 0 on each of the stream's segments: :meth:`ClockModel.to_reference`
    then returns the times themselves, value for value.
    """
    if clock.drift != 0.0 or any(offset != 0.0 for offset in clock.offsets_s):
        return False
    return set(distinct_in_runs(segment).tolist()) <= set(clock.segments)


def _fill_unaligned(ref_time: FloatArray, own_time: FloatArray, lost: np.ndarray) -> None:
    """Give unaligned samples a placeholder reference time, in place, so the axis stays increasing.

    A lost sample's placeholder is its device time (s) plus the offset (reference minus device
    time, s) interpolated linearly between the aligned samples on either side of its run, or
    that of the nearest aligned sample beyond the record's ends; zero offset when no sample is
    aligned. Only the lost samples and the aligned ends of their runs are touched (no
    whole-record index or offset arrays): equal, value for value, to ``np.interp`` over every
    aligned sample, which uses the same two neighbours.

    Parameters
    ----------
    ref_time : numpy.ndarray
        Reference times (s), NaN at the lost samples; filled there.
    own_time : numpy.ndarray
        Device times (s) of the same samples.
    lost : numpy.ndarray
        Boolean mask of the samples without a reference time.
    """
    where = np.flatnonzero(lost)
    if where.size == ref_time.size:
        ref_time[:] = own_time + 0.0
        return
    # first and last sample of each lost run, then their aligned neighbours
    starts = where[np.concatenate(([True], np.diff(where) > 1))]
    stops = where[np.concatenate((np.diff(where) > 1, [True]))] + 1
    anchors = np.unique(np.concatenate((starts[starts > 0] - 1, stops[stops < lost.size])))
    offset = np.interp(where, anchors, ref_time[anchors] - own_time[anchors])
    ref_time[where] = own_time[where] + offset


def align_stream(stream: xr.Dataset, clock: ClockModel, *, name: str | None = None,
                 reference_start: str | None = None, device_time: bool = True) -> xr.Dataset:
    """Put a stream on the reference timeline with its clock model.

    Parameters
    ----------
    stream : xarray.Dataset
        A stream (the stream schema, docs/formats.md).
    clock : ClockModel
        The stream's clock model (:func:`estimate_clock`, or :func:`identity_clock` for the
        reference stream).
    name : str, optional
        Stream name for the history line.
    reference_start : str, optional
        ``start_time`` (ISO 8601) of the reference stream: the origin of the reference clock, so
        the aligned ``time`` carries CF units ``"seconds since <reference_start>"``. Default: the
        stream's own ``start_time`` (right for the reference stream itself).
    device_time : bool, default True
        Keep the device's own times as the ``device_time`` coordinate; False leaves it out
        (memory: one whole-record float64 array less, for callers that never read it).

    Returns
    -------
    xarray.Dataset
        Same variables and samples (nothing interpolated); ``time`` is the reference-clock time of
        each sample clock tick (the stream's own coordinate, lazy or not, where the clock is the
        identity on every segment), ``device_time`` keeps the device's own; each channel gets
        ``input_delay_s`` (its module delay, in reference seconds; subtract it with
        :func:`channel_time`); samples of unaligned segments are marked invalid; the clock model is
        stored in the attributes (``clock_offset_s``, ``clock_drift_ppm``, ``residual_rms_s``,
        ``pulses_matched``, ``segments``).

    Warns
    -----
    DataWarning
        When segments could not be aligned and their samples were marked invalid.
    """
    fs = float(stream.attrs["fs_nominal"])
    segment = stream["segment"].to_numpy()
    origin = reference_start if reference_start is not None else str(stream.attrs["start_time"])
    on_reference = cf_time_attrs(origin, "time on the reference device clock")
    out = stream.copy()
    if _maps_to_itself(clock, segment):
        # offset 0 + (1 + 0) t is t: the stream's own time coordinate is its reference time,
        # kept as it is (lazy for a TDMS stream: no whole-record array)
        coords = time_coordinate(stream, on_reference)
        own_time = stream["time"].to_numpy() if device_time else None
    elif (lazy := clocked_time_coordinate(
            stream, 1.0 + clock.drift, dict(zip(clock.segments, clock.offsets_s, strict=True)),
            on_reference)) is not None:
        # a file's lazy axis, every segment aligned: (1 + drift) t + offset computed where
        # read, the values ClockModel.to_reference gives the materialised axis below
        coords = lazy
        own_time = stream["time"].to_numpy() if device_time else None
    else:
        own_time = stream["time"].to_numpy()
        ref_time = clock.to_reference(own_time, segment)
        lost = ~np.isfinite(ref_time)
        if lost.any():
            label = name or stream.attrs.get("device", "")
            warnings.warn(f"stream {label}: {int(lost.sum())} samples in segments "
                          f"{list(clock.unaligned_segments)} could not be aligned (no matched "
                          "reference pulses) and were marked invalid; alignment.json lists them",
                          DataWarning, stacklevel=2)
            _fill_unaligned(ref_time, own_time, lost)
            counts = invalid_counts(stream)
            newly = int(np.count_nonzero(lost & stream["valid"].to_numpy()))
            counts["unaligned segment"] = counts.get("unaligned segment", 0) + newly
            out["valid"] = stream["valid"] & ~xr.DataArray(lost, dims="time")
            out = with_invalid_counts(out, counts)
        coords = indexed_time_coordinate(ref_time, on_reference)
    if device_time:
        own = cf_time_attrs(str(stream.attrs["start_time"]), "time on the device clock")
        device = {k: own[k] for k in ("units", "calendar", "long_name")}
        coords = coords.assign(device_time=("time", own_time, device))
    del own_time
    out = out.assign_coords(coords)
    for var in out.data_vars:
        if var in ("valid", "segment"):
            continue
        out[var].attrs["input_delay_s"] = input_delay(stream[var].attrs, fs) * (1 + clock.drift)
    out.attrs.update(clock.attrs())
    append_history(out, f"processing.align_stream {name or stream.attrs.get('device', '')}: "
                        f"offset {clock.offsets_s[0]:.9f} s, drift {clock.drift * 1e6:.4f} ppm")
    return out
