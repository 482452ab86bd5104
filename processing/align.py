"""Clock alignment: a model ``t_ref = a_j + (1 + drift) t_dev`` per gap-free segment j.

Each device has its own oscillator (offset: file start times are software stamps, off by ms to
seconds; drift: tens of ppm; Wi-Fi restarts start new segments). The model is fitted by least
squares on matched reference events (docs/processing.md, *Accuracy measured*):

1. events on both clocks, with module input delays removed (:func:`input_delay`);
2. for each device segment, candidate offsets from pairing its first events with every reference
   event within ``coarse_offset_s +- max_offset_error_s``; each candidate is scored by how many
   events it matches within a quarter period and by the robust scale of the residuals about a
   fitted line. The true offset leaves only timing jitter, an offset wrong by whole periods
   leaves the period-to-period speed variation, so whole-period ambiguity is resolved from the
   data (and reported as an :class:`AlignmentError` when the pulse train is too regular);
3. all events matched with the candidate's line, then one joint least-squares fit of a shared
   drift and one offset per segment, with 2-pass rejection of residuals above 5 robust sigma.

Pulses at a multiple of the reference rate (the lifting shaft's opt3, twice per main revolution)
are matched to reference events built at that multiple from the reference angle
(:func:`reference_event_times`), so every device pulse has a partner. Several event kinds (rising
and falling edges) can be fitted together. :func:`align_stream` then puts a stream on the
reference timeline without touching its samples.
"""

from __future__ import annotations

import json
import logging
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from rigval.acquisition.devices import ni9237_input_delay
from rigval.acquisition.errors import AlignmentError, DataError, DataWarning
from rigval.acquisition.schema import (
    append_history,
    invalid_counts,
    parse_start_time,
    with_invalid_counts,
)

__all__ = [
    "ClockModel",
    "align_stream",
    "channel_time",
    "coarse_offset",
    "estimate_clock",
    "identity_clock",
    "input_delay",
    "match_events",
    "ni9237_input_delay",
    "reference_event_times",
]

logger = logging.getLogger(__name__)

_FloatArray = NDArray[np.float64]
_IntArray = NDArray[np.int64]

#: Candidate offsets are scored on the events of this many seconds at the start of a segment.
_SCORING_SPAN_S = 60.0
#: A runner-up candidate whose residual scale is within this factor of the best makes the match
#: ambiguous.
_AMBIGUITY_FACTOR = 3.0
#: Residual scales below this (s) count as equal: no clock is timed better than a nanosecond.
_TIMING_FLOOR_S = 1e-9


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
                          events_per_rev: int = 1) -> _FloatArray:
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

    Returns
    -------
    numpy.ndarray
        Times in s of ``angle = event_angle + k 2 pi / events_per_rev`` inside the record.
    """
    t = np.asarray(time, dtype=np.float64)
    phi = np.asarray(angle, dtype=np.float64)
    finite = np.isfinite(phi)
    t, phi = t[finite], phi[finite]
    if phi.size < 2 or np.any(np.diff(phi) <= 0):
        raise DataError("the reference angle must increase strictly to locate events",
                        hint="use the smoothed drive angle (excitation.drive_angle) and split at "
                             "standstills")
    step = 2.0 * np.pi / events_per_rev
    first = np.ceil((phi[0] - event_angle) / step)
    last = np.floor((phi[-1] - event_angle) / step)
    targets = event_angle + step * np.arange(first, last + 1)
    return np.interp(targets, phi, t)


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
        Standard error of the offsets in s (largest over segments).
    drift_std : float
        Standard error of the drift (1).
    unaligned_segments : tuple of int
        Device segments without enough matched events (their samples become invalid).
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

    def to_reference(self, time: ArrayLike, segment: ArrayLike | int = 0) -> _FloatArray:
        """Return reference-clock times (s) for device times (s) of the given segment(s).

        Samples of unaligned segments map to NaN.
        """
        t = np.asarray(time, dtype=np.float64)
        seg = np.broadcast_to(np.asarray(segment, dtype=np.int64), t.shape)
        size = max(max(self.segments, default=0), int(seg.max(initial=0))) + 1
        lookup = np.full(size, np.nan)
        lookup[list(self.segments)] = self.offsets_s
        offset = np.where(seg >= 0, lookup[np.clip(seg, 0, size - 1)], np.nan)
        return offset + (1.0 + self.drift) * t

    def attrs(self) -> dict[str, Any]:
        """Return the design 3.2 attributes (``clock_offset_s``, ``clock_drift_ppm``, ...)."""
        return {
            "clock_offset_s": float(self.offsets_s[0]),
            "clock_drift_ppm": self.drift * 1e6,
            "clock_drift_std_ppm": self.drift_std * 1e6,
            "clock_offset_std_s": self.offset_std_s,
            "residual_rms_s": self.residual_rms_s,
            "pulses_matched": self.pulses_matched,
            "pulses_total": self.pulses_total,
            "segments": json.dumps([{"segment": s, "clock_offset_s": o}
                                    for s, o in zip(self.segments, self.offsets_s,
                                                    strict=True)]),
            "unaligned_segments": json.dumps(list(self.unaligned_segments)),
        }


def identity_clock(segments: ArrayLike = (0,)) -> ClockModel:
    """Return the clock model of the reference device itself (offset 0, drift 0)."""
    segs = tuple(int(s) for s in np.unique(np.asarray(segments)))
    return ClockModel(segs, tuple(0.0 for _ in segs), 0.0, 0.0, 0, 0)


def _nearest(sorted_ref: _FloatArray, targets: _FloatArray) -> _IntArray:
    """Return the index of the nearest reference time for each target."""
    right = np.clip(np.searchsorted(sorted_ref, targets), 1, sorted_ref.size - 1)
    left = right - 1
    pick_left = np.abs(targets - sorted_ref[left]) <= np.abs(sorted_ref[right] - targets)
    return np.where(pick_left, left, right)


def _line_residual(x: _FloatArray, y: _FloatArray) -> tuple[_FloatArray, float]:
    """Fit ``y = p0 + p1 x`` robustly; return ``(p0, p1)`` and the robust residual scale.

    The scale is 1.4826 times the median absolute deviation; points beyond 5 of it are dropped
    before a second fit, so a stray partner does not decide between candidate offsets.
    """
    if x.size < 3:
        return np.array([float(np.mean(y - x)) if x.size else 0.0, 1.0]), np.inf
    centre = x.mean()
    use = np.ones(x.size, dtype=bool)
    scale = np.inf
    coeffs = np.zeros(2)
    for _ in range(2):
        coeffs = np.polyfit(x[use] - centre, y[use], 1)
        res = y - np.polyval(coeffs, x - centre)
        scale = 1.4826 * float(np.median(np.abs(res[use] - np.median(res[use]))))
        use = np.abs(res) <= 5.0 * scale + 1e-12
        if use.sum() < 3:
            break
    return np.array([coeffs[1] - coeffs[0] * centre, coeffs[0]]), scale


def match_events(ref_times: ArrayLike, dev_times: ArrayLike, *, coarse_offset_s: float = 0.0,
                 max_offset_error_s: float = 5.0, tolerance: float = 0.25,
                 where: Mapping[str, Any] | None = None) -> tuple[_IntArray, _IntArray]:
    """Pair device events with reference events starting from a coarse offset.

    Parameters
    ----------
    ref_times : array_like
        Reference events in s on the reference clock, increasing.
    dev_times : array_like
        Events of one gap-free device segment in s on the device clock, increasing.
    coarse_offset_s : float, default 0
        Rough ``t_ref - t_dev`` in s (from the files' start times).
    max_offset_error_s : float, default 5
        How far in s the coarse offset may be wrong.
    tolerance : float, default 0.25
        Largest match distance as a fraction of the reference period.
    where : mapping, optional
        Context for error messages (stream, channel).

    Returns
    -------
    ref_index, dev_index : numpy.ndarray of int
        Indices of the matched pairs.

    Raises
    ------
    AlignmentError
        Too few events, no overlap, inconsistent periods or whole-period ambiguity.
    """
    ref = np.asarray(ref_times, dtype=np.float64)
    dev = np.asarray(dev_times, dtype=np.float64)
    place = dict(where or {})
    if ref.size < 3 or dev.size < 3:
        raise AlignmentError(f"too few events to align: {ref.size} reference and {dev.size} "
                             "device events (need 3 each)", where=place,
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
            f"no overlap: no reference event within {max_offset_error_s} s of the device events "
            f"shifted by the coarse offset {coarse_offset_s:.6g} s", where=place,
            hint="check the start times of both files or widen max_offset_error_s")
    candidates = np.unique(np.round(np.asarray(candidates) / (tolerance * period / 4)))
    candidates = candidates * (tolerance * period / 4)
    scored = []
    for offset in candidates:
        predicted = scoring + offset
        nearest = _nearest(ref, predicted)
        hit = np.abs(ref[nearest] - predicted) < tolerance * period
        _, scale = _line_residual(scoring[hit], ref[nearest[hit]])
        scored.append((int(hit.sum()), scale, float(offset)))
    most = max(s[0] for s in scored)
    contenders = sorted((s for s in scored if s[0] >= max(3, 0.8 * most)), key=lambda s: s[1])
    if not contenders:
        raise AlignmentError(f"too few matched events: at most {most} of {scoring.size} device "
                             "events found a reference partner", where=place,
                             hint="check the coarse offset and the reference events")
    best = contenders[0]
    distinct = [s for s in contenders[1:] if abs(s[2] - best[2]) > 0.5 * period]
    if distinct and distinct[0][1] <= _AMBIGUITY_FACTOR * best[1] + _TIMING_FLOOR_S:
        raise AlignmentError(
            f"whole-period ambiguity: offsets {best[2]:.6g} s and {distinct[0][2]:.6g} s fit "
            f"equally well (residual scale {best[1]:.3g} s vs {distinct[0][1]:.3g} s); the pulse "
            "intervals are too regular to tell whole periods apart", where=place,
            hint=f"give a coarse offset good to {period / 2:.3g} s (max_offset_error_s below "
                 "half a period)")
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
    return ref_index[keep].astype(np.int64), dev_index[keep].astype(np.int64)


def _joint_fit(ref: _FloatArray, dev: _FloatArray, seg: _IntArray,
               ) -> tuple[_FloatArray, float, _FloatArray, _FloatArray]:
    """Least squares ``ref = a_seg + b dev``; return offsets, b, residuals, standard errors."""
    segments, column = np.unique(seg, return_inverse=True)
    centre = float(dev.mean())
    design = np.zeros((dev.size, segments.size + 1))
    design[np.arange(dev.size), column] = 1.0
    design[:, -1] = dev - centre
    target = ref - dev
    coeffs, *_ = np.linalg.lstsq(design, target, rcond=None)
    residual = target - design @ coeffs
    dof = max(dev.size - coeffs.size, 1)
    sigma2 = float(residual @ residual) / dof
    cov = sigma2 * np.linalg.pinv(design.T @ design)
    drift = float(coeffs[-1])
    offsets = coeffs[:-1] - drift * centre
    var_offsets = (np.diag(cov)[:-1] + centre**2 * cov[-1, -1]
                   - 2 * centre * cov[:-1, -1])
    std = np.sqrt(np.maximum(np.concatenate((var_offsets, [cov[-1, -1]])), 0.0))
    return offsets, drift, residual, std


def _event_kinds(ref_times: ArrayLike | Sequence[ArrayLike],
                 dev_times: ArrayLike | Sequence[ArrayLike],
                 dev_segment: ArrayLike | Sequence[ArrayLike] | None,
                 ) -> list[tuple[_FloatArray, _FloatArray, _IntArray]]:
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


def estimate_clock(ref_times: ArrayLike | Sequence[ArrayLike],
                   dev_times: ArrayLike | Sequence[ArrayLike],
                   dev_segment: ArrayLike | Sequence[ArrayLike] | None = None, *,
                   coarse_offset_s: float = 0.0, max_offset_error_s: float = 5.0,
                   min_events: int = 5, max_residual_s: float = 1e-3,
                   where: Mapping[str, Any] | None = None) -> ClockModel:
    """Estimate a device's clock model from its reference events.

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
        How far in s the coarse offset may be wrong.
    min_events : int, default 5
        Fewest matched events overall; a segment needs at least 2 of its own.
    max_residual_s : float, default 1e-3
        Largest acceptable residual rms in s.
    where : mapping, optional
        Context for error messages.

    Returns
    -------
    ClockModel
        The fitted model; segments without 2 matched events are listed as unaligned.

    Raises
    ------
    AlignmentError
        When no trustworthy model can be fitted (with the reason).
    """
    kinds = _event_kinds(ref_times, dev_times, dev_segment)
    place = dict(where or {})
    pairs_ref: list[_FloatArray] = []
    pairs_dev: list[_FloatArray] = []
    pairs_seg: list[_IntArray] = []
    matched: dict[int, int] = {}
    all_segments = np.unique(np.concatenate([seg for _, _, seg in kinds]))
    n_offered = 0
    for kind, (ref, dev, seg) in enumerate(kinds):
        n_offered += dev.size
        for s in np.unique(seg):
            events = dev[seg == s]
            try:
                ri, di = match_events(ref, events, coarse_offset_s=coarse_offset_s,
                                      max_offset_error_s=max_offset_error_s,
                                      where={**place, "segment": int(s), "event_kind": kind})
            except AlignmentError as error:
                if all_segments.size == 1 and len(kinds) == 1:
                    raise
                logger.info("segment %d, event kind %d not matched: %s", s, kind, error)
                continue
            pairs_ref.append(ref[ri])
            pairs_dev.append(events[di])
            pairs_seg.append(np.full(ri.size, s, dtype=np.int64))
            matched[int(s)] = matched.get(int(s), 0) + ri.size
    unaligned = [int(s) for s in all_segments if matched.get(int(s), 0) < 2]
    pairs = [(r, d, g) for r, d, g in zip(pairs_ref, pairs_dev, pairs_seg, strict=True)
             if int(g[0]) not in unaligned]
    if not pairs:
        raise AlignmentError("no segment of the device could be matched to reference events",
                             where=place, hint="check the pulse channel and the coarse offset")
    pairs_ref, pairs_dev, pairs_seg = ([p[i] for p in pairs] for i in range(3))
    r, d, g = (np.concatenate(p) for p in (pairs_ref, pairs_dev, pairs_seg))
    keep = np.ones(r.size, dtype=bool)
    for _ in range(2):
        offsets, drift, residual, std = _joint_fit(r[keep], d[keep], g[keep])
        full_offsets = dict(zip(np.unique(g[keep]).tolist(), offsets, strict=True))
        model_all = np.array([full_offsets.get(int(s), np.nan) for s in g]) + (1 + drift) * d
        res_all = r - model_all
        sigma = 1.4826 * float(np.median(np.abs(residual - np.median(residual))))
        keep = np.abs(res_all) <= max(5.0 * sigma, 1e-9)
    if keep.sum() < min_events:
        raise AlignmentError(f"too few matched events: {int(keep.sum())} (need {min_events})",
                             where=place, hint="record longer or check the pulse channels")
    offsets, drift, residual, std = _joint_fit(r[keep], d[keep], g[keep])
    rms = float(np.sqrt(np.mean(residual**2)))
    if rms > max_residual_s:
        raise AlignmentError(
            f"clock fit residual rms {rms:.3g} s exceeds {max_residual_s:.3g} s", where=place,
            hint="events may be matched to the wrong partner, or the clock wanders; check the "
                 "event angle and the pulse channel")
    segments = tuple(int(s) for s in np.unique(g[keep]))
    unaligned.extend(int(s) for s in np.unique(g) if int(s) not in segments)
    model = ClockModel(segments, tuple(float(o) for o in offsets), drift, rms, int(keep.sum()),
                       n_offered, float(np.max(std[:-1])), float(std[-1]),
                       tuple(sorted(unaligned)))
    logger.info("clock model: offset %.9f s, drift %.4f ppm, rms %.3g s, %d/%d events",
                model.offsets_s[0], drift * 1e6, rms, model.pulses_matched, dev.size)
    return model


def coarse_offset(reference: xr.Dataset, stream: xr.Dataset) -> float:
    """Return the rough clock offset ``t_ref - t_dev`` in s from the streams' start times.

    The start times are software time stamps (ms-accurate at best, off by seconds after a bad
    host clock); :func:`estimate_clock` refines this within ``max_offset_error_s``.
    """
    start_ref = parse_start_time(reference.attrs["start_time"])
    start_dev = parse_start_time(stream.attrs["start_time"])
    return float((start_dev - start_ref) / np.timedelta64(1, "ns")) * 1e-9


def channel_time(aligned: xr.Dataset, name: str) -> _FloatArray:
    """Return the reference-clock time (s) at which a channel's samples were taken.

    That is the aligned ``time`` minus the channel's ``input_delay_s`` (on the reference clock).
    """
    delay = float(aligned[name].attrs.get("input_delay_s", 0.0))
    return aligned["time"].to_numpy() - delay


def align_stream(stream: xr.Dataset, clock: ClockModel, *, name: str | None = None) -> xr.Dataset:
    """Put a stream on the reference timeline with its clock model.

    Parameters
    ----------
    stream : xarray.Dataset
        A stream (design 3.1).
    clock : ClockModel
        The stream's clock model (:func:`estimate_clock`, or :func:`identity_clock` for the
        reference stream).
    name : str, optional
        Stream name for the history line.

    Returns
    -------
    xarray.Dataset
        Same variables and samples (nothing interpolated); ``time`` is the reference-clock time of
        each sample clock tick, ``device_time`` keeps the device's own; each channel gets
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
    device_time = stream["time"].to_numpy()
    segment = stream["segment"].to_numpy()
    ref_time = clock.to_reference(device_time, segment)
    lost = ~np.isfinite(ref_time)
    out = stream.copy()
    if lost.any():
        warnings.warn(f"{int(lost.sum())} samples in segments {list(clock.unaligned_segments)} "
                      "could not be aligned and were marked invalid", DataWarning, stacklevel=2)
        # Unaligned samples get a placeholder: the device time plus the offset interpolated
        # from the aligned neighbours, so the coordinate stays increasing.
        good = np.flatnonzero(~lost)
        offset = (np.interp(np.arange(ref_time.size), good, ref_time[good] - device_time[good])
                  if good.size else np.zeros(ref_time.size))
        ref_time = np.where(lost, device_time + offset, ref_time)
        counts = invalid_counts(stream)
        newly = int(np.count_nonzero(lost & stream["valid"].to_numpy()))
        counts["unaligned segment"] = counts.get("unaligned segment", 0) + newly
        out["valid"] = stream["valid"] & ~xr.DataArray(lost, dims="time")
        out = with_invalid_counts(out, counts)
    out = out.assign_coords(time=("time", ref_time, {
        "units": "s", "long_name": "time on the reference device clock"}),
        device_time=("time", device_time, {"units": "s",
                                           "long_name": "time on the device clock"}))
    for var in out.data_vars:
        if var in ("valid", "segment"):
            continue
        out[var].attrs["input_delay_s"] = input_delay(stream[var].attrs, fs) * (1 + clock.drift)
    out.attrs.update(clock.attrs())
    append_history(out, f"processing.align_stream {name or stream.attrs.get('device', '')}: "
                        f"offset {clock.offsets_s[0]:.9f} s, drift {clock.drift * 1e6:.4f} ppm")
    return out
