"""Alignment of a scene's streams: phi_F from the main encoder, one clock per device.

:func:`align_streams` puts every stream of a scene on the reference stream's timeline: phi_F(t)
from the main-shaft encoder (smoothed, never differenced raw, :func:`rigval.processing.angle.phi_f`)
is zero at the main reference pulse; each other stream's clock (offset and drift per gap-free
segment) is fitted on its reference pulses against the events the encoder angle predicts
(:func:`rigval.processing.align.estimate_clock`), with module input delays removed. Segments that
follow a Wi-Fi restart are matched from their neighbour's offset and all segments refitted with
one drift. The diagnostics (:class:`~rigval.validation.results.StreamAlignment`) feed the
report's alignment section and ``alignment.json``.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from rigval.acquisition.channel_map import ChannelSpec
from rigval.acquisition.errors import AlignmentError, DataError
from rigval.acquisition.schema import parse_start_time, stream_gaps
from rigval.processing.align import (
    ClockModel,
    align_stream,
    channel_time,
    estimate_clock,
    identity_clock,
    match_events,
    reference_event_times,
)
from rigval.processing.angle import phi_f
from rigval.processing.pulses import StreamPulses, stream_pulses
from rigval.validation.results import StreamAlignment
from rigval.validation.scene import Scene

__all__ = ["MainAngle", "align_streams"]

logger = logging.getLogger(__name__)

#: How far (s) a start time written by a device may be off: software time stamps.
START_TIME_ERROR_S = 5.0
#: Start times in or before this year mean "unknown" (NI writes 1904-01-01 for relative time).
UNKNOWN_START_YEAR = 1904
#: Matched events farther than this many robust sigmas from the clock fit count as spurious.
OUTLIER_SIGMAS = 6.0
#: ... unless they are within this distance in s (a sample period of the slowest device).
MIN_EVENT_TOLERANCE_S = 1e-3
#: Hysteresis half-band of a reference pulse's ``threshold``, as a fraction of it.
PULSE_HYSTERESIS = 0.1
#: Half-width of the raw-pulse window in the alignment figure, in main-shaft periods.
PULSE_WINDOW = 0.04


@dataclass(frozen=True)
class MainAngle:
    """phi_F, the main shaft angle from the reference position, on the reference timeline.

    Parameters
    ----------
    time : numpy.ndarray
        Reference-clock times in s where the encoder angle is defined.
    phi : numpy.ndarray
        phi_F in rad, increasing, multiples of 2 pi at the reference pulse.
    """

    time: np.ndarray
    phi: np.ndarray

    def times_at(self, angles: np.ndarray) -> np.ndarray:
        """Return the reference times (s) at which phi_F takes the given values (rad)."""
        return np.interp(angles, self.phi, self.time)


def _pulses(stream: xr.Dataset, channel: ChannelSpec) -> StreamPulses:
    """Edges of a reference-pulse channel (delay-corrected, classified) as its table says."""
    threshold = channel.params.get("threshold")
    low = high = None
    if threshold is not None:
        band = PULSE_HYSTERESIS * max(abs(threshold), float(np.finfo(float).tiny))
        low, high = threshold - band, threshold + band
    return stream_pulses(stream, channel.name, polarity=channel.params.get("edge", "rising"),
                         low=low, high=high)


def _main_angle(scene: Scene, ref: xr.Dataset) -> tuple[MainAngle, StreamPulses]:
    """Return phi_F(t) from the main encoder, zero at the reference pulse, and those pulses."""
    encoder = scene.alignment.main_encoder
    params = scene.channel(encoder).params
    directions = [d.direction for d in scene.model.drivers.values() if d.encoder == encoder]
    pulses = _pulses(ref, scene.channel(scene.alignment.main_reference_pulse))
    if pulses.good.size < scene.angle.min_cycles:
        raise DataError(f"only {pulses.good.size} reference pulses on "
                        f"{scene.alignment.main_reference_pulse}",
                        where={"key": "alignment.main_reference_pulse"},
                        hint="check the pulse channel (threshold, edge, wiring)")
    angle = phi_f(ref, encoder.channel, pulses, counts_per_rev=params["counts_per_rev"],
                  direction=float(directions[0] if directions else 1),
                  index_reset=bool(params.get("index_reset", False)))
    t = channel_time(ref, encoder.channel)
    phi = angle["phi_F"].to_numpy()
    finite = np.isfinite(phi)
    t, phi = t[finite], phi[finite]
    if phi.size < 2 or np.any(np.diff(phi) <= 0):
        raise DataError("the main shaft angle does not increase steadily (standstill, reversal "
                        "or the encoder counting down)", where={"channel": str(encoder)},
                        hint="validate runs at steady speed; set direction = -1 in the driver "
                             "table of an encoder that counts down")
    return MainAngle(t, phi), pulses


def _residuals(mapped: np.ndarray, events: np.ndarray, period: float, per_revolution: int = 1
               ) -> tuple[np.ndarray, np.ndarray]:
    """Residual of each mapped event against its nearest expected event; matched mask.

    With several pulses per revolution, each kind of pulse (its place within the revolution)
    may fire at its own angle; the median residual of each kind is removed, as the clock fit
    does.
    """
    index = np.clip(np.searchsorted(events, mapped), 1, events.size - 1)
    nearest = np.where(np.abs(mapped - events[index - 1]) <= np.abs(events[index] - mapped),
                       index - 1, index)
    residual = mapped - events[nearest]
    matched = np.abs(residual) < 0.25 * period / per_revolution
    if matched.sum() > 3:  # a spurious pulse can fall inside a quarter period: robust cut
        spread = 1.4826 * float(np.median(np.abs(residual[matched]
                                                 - np.median(residual[matched]))))
        matched &= np.abs(residual - np.median(residual[matched])) <= max(
            OUTLIER_SIGMAS * spread, MIN_EVENT_TOLERANCE_S)
    if per_revolution > 1:
        kind = nearest % per_revolution
        for k in range(per_revolution):
            chosen = matched & (kind == k)
            if chosen.any():
                residual[kind == k] -= np.median(residual[chosen])
    return residual, matched


def _consistent_offsets(clock: ClockModel, segments: np.ndarray, event_period: float
                        ) -> dict[int, float]:
    """Return the fitted offsets (s) per segment, without those a whole period off.

    Segments differ in offset only by their start stamps' errors (tens of ms), so a segment whose
    offset is more than half an event period (s) from that of the segment with the most events
    was matched to the wrong pulses (a short segment's pulse intervals may not tell periods
    apart); it is left out, to be matched again around its neighbour's offset.
    """
    offsets = dict(zip(clock.segments, clock.offsets_s, strict=True))
    anchor = max(offsets, key=lambda s: (int(np.count_nonzero(segments == s)), -s))
    wrong = [s for s, offset in offsets.items()
             if abs(offset - offsets[anchor]) > 0.5 * event_period]
    for segment in wrong:
        logger.info("segment %d: offset %.6f s is %.3f s from segment %d's, a whole period off; "
                    "matching it again", segment, offsets[segment],
                    offsets[segment] - offsets[anchor], anchor)
        del offsets[segment]
    return offsets


def _recover_segments(clock: ClockModel, events: np.ndarray, edges: np.ndarray,
                      segments: np.ndarray, period: float, per_revolution: int,
                      where: Mapping[str, Any]) -> ClockModel:
    """Align segments the clock fit left out or matched a whole period off, then refit them all.

    A restart (Wi-Fi dropout) starts a segment whose device time comes from a new software
    start stamp, off by milliseconds, not periods: matching it within +-0.4 of an event period
    (a pulse period over ``per_revolution``) around the nearest segment's offset removes the
    whole-period ambiguity a short segment has on its own. Every segment's events are then
    matched around its offset and one least squares fit gives a shared drift, an offset per
    segment and, with several pulses per revolution, a constant per kind of pulse (each may fire
    at its own angle); events beyond 6 robust sigma are left out. The drift so rests on the
    whole record.
    """
    offsets = _consistent_offsets(clock, segments, period / per_revolution)
    if not clock.unaligned_segments and len(offsets) == len(clock.segments):
        return clock
    pairs: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    for segment in sorted(set(np.unique(segments).tolist())):
        known = sorted(offsets, key=lambda s: (abs(s - segment), s > segment))
        chosen = segments == segment
        if not known or chosen.sum() < 2:
            continue
        coarse = offsets.get(segment, offsets[known[0]])
        try:
            ref_index, dev_index = match_events(
                events, edges[chosen], coarse_offset_s=coarse,
                max_offset_error_s=0.4 * period / per_revolution,
                where={**where, "segment": int(segment)})
        except AlignmentError as error:
            logger.info("segment %d stays unaligned: %s", segment, error)
            continue
        if ref_index.size >= 2:
            pairs.append((ref_index, edges[chosen][dev_index], np.full(ref_index.size, segment)))
            offsets.setdefault(int(segment), coarse)
    index, dev, seg = (np.concatenate(column) for column in zip(*pairs, strict=True))
    ref, kind = events[index], index % per_revolution
    order = sorted(set(seg.tolist()))
    columns = [(seg == s).astype(float) for s in order]
    columns += [(kind == k).astype(float) for k in range(1, per_revolution)] + [dev]
    design = np.column_stack(columns)
    keep = np.ones(ref.size, dtype=bool)
    for _ in range(2):
        solution, *_ = np.linalg.lstsq(design[keep], ref[keep] - dev[keep], rcond=None)
        residual = ref - dev - design @ solution
        spread = 1.4826 * float(np.median(np.abs(residual[keep] - np.median(residual[keep]))))
        keep = np.abs(residual) <= max(OUTLIER_SIGMAS * spread, 1e-9)
    logger.info("clock refit on %d events of segments %s: drift %.4f ppm", int(keep.sum()),
                order, solution[-1] * 1e6)
    return dataclasses.replace(
        clock, segments=tuple(int(s) for s in order),
        offsets_s=tuple(float(solution[i]) for i in range(len(order))),
        drift=float(solution[-1]), residual_rms_s=float(np.sqrt(np.mean(residual[keep] ** 2))),
        pulses_matched=int(keep.sum()),
        unaligned_segments=tuple(s for s in sorted({*clock.segments, *clock.unaligned_segments})
                                 if s not in order))


def _with_pulse_window(summary: StreamAlignment, aligned: xr.Dataset, channel: str,
                       edges: np.ndarray, centre: float, half_width: float) -> StreamAlignment:
    """Attach the raw pulse signal and its edges within ``centre +- half_width`` (s)."""
    t = channel_time(aligned, channel)
    inside = np.abs(t - centre) <= half_width
    return dataclasses.replace(
        summary, pulse_time=t[inside], pulse_signal=aligned[channel].to_numpy()[inside],
        pulse_units=str(aligned[channel].attrs.get("units", "")),
        edge_times=edges[np.abs(edges - centre) <= half_width])


def _common_pulse(pulses: np.ndarray, spans: list[tuple[float, float]], margin: float) -> float:
    """Return the first reference pulse that every stream recorded (else the first pulse)."""
    start = max(span[0] for span in spans) + margin
    stop = min(span[1] for span in spans) - margin
    inside = pulses[(pulses >= start) & (pulses <= stop)]
    return float(inside[0] if inside.size else pulses[0])


def _stream_summary(name: str, aligned: xr.Dataset, clock: ClockModel, *, is_reference: bool,
                    residual_time: np.ndarray, residual: np.ndarray, matched: int,
                    missing: int, spurious: int) -> StreamAlignment:
    empty = np.zeros(0)
    delays = [float(aligned[v].attrs.get("input_delay_s", 0.0)) for v in aligned.data_vars
              if v not in ("valid", "segment")]
    times = aligned["time"].to_numpy()
    return StreamAlignment(
        stream=name, device=str(aligned.attrs.get("device", "")), is_reference=is_reference,
        offset_s=float(clock.offsets_s[0]), drift_ppm=clock.drift * 1e6,
        residual_rms_s=float(np.sqrt(np.mean(residual**2))) if residual.size else 0.0,
        events_matched=matched, events_missing=missing, events_spurious=spurious,
        input_delay_s=max(delays, default=0.0), segments=len(clock.segments),
        gaps=tuple(stream_gaps(aligned)),
        span_s=(float(times[0]), float(times[-1])), residual_time=residual_time,
        residual_s=residual, pulse_time=empty, pulse_signal=empty, pulse_units="",
        edge_times=empty)


def _coarse_offset(stream: xr.Dataset, ref: xr.Dataset, ref_start: np.datetime64
                   ) -> tuple[float, float]:
    """Return a first guess of ``t_ref - t_dev`` in s and how far to search around it.

    From the files' start times when both are known (search +-5 s: software time stamps); a
    file without a start time (1904-01-01, e.g. a CSV with relative time) is searched over the
    whole overlap of the two records.
    """
    start = parse_start_time(stream.attrs["start_time"])
    if start.astype("datetime64[Y]").astype(int) + 1970 > UNKNOWN_START_YEAR and (
            ref_start.astype("datetime64[Y]").astype(int) + 1970 > UNKNOWN_START_YEAR):
        return float((start - ref_start) / np.timedelta64(1, "s")), START_TIME_ERROR_S
    ref_span = float(ref["time"].values[-1] - ref["time"].values[0])
    dev_span = float(stream["time"].values[-1] - stream["time"].values[0])
    logger.info("stream %s has no start time: searching offsets over the whole record",
                stream.attrs.get("stream", ""))
    return 0.5 * (ref_span - dev_span), 0.5 * (ref_span + dev_span)


def align_streams(scene: Scene, converted: Mapping[str, xr.Dataset]
                  ) -> tuple[dict[str, xr.Dataset], dict[str, StreamAlignment], MainAngle]:
    """Put every stream on the reference timeline.

    Parameters
    ----------
    scene : Scene
        The scene (its ``[alignment]`` table).
    converted : mapping of str to xarray.Dataset
        The streams after :func:`rigval.validation.convert.convert_stream`.

    Returns
    -------
    aligned : dict of str to xarray.Dataset
        Streams with ``time`` on the reference clock (samples unchanged).
    diagnostics : dict of str to StreamAlignment
        Clock model, events and gaps per stream.
    main : MainAngle
        phi_F(t).

    Raises
    ------
    AlignmentError
        When a stream's clock cannot be fitted with confidence.
    """
    reference = scene.alignment.reference
    ref = align_stream(converted[reference], identity_clock(converted[reference]["segment"]),
                       name=reference)
    main, ref_pulses = _main_angle(scene, ref)
    pulses = ref_pulses.good[(ref_pulses.good >= main.time[0])
                             & (ref_pulses.good <= main.time[-1])]
    period = float(np.median(np.diff(pulses)))
    expected = main.times_at(2.0 * np.pi * np.arange(math.ceil(main.phi[0] / (2 * np.pi)),
                                                     math.floor(main.phi[-1] / (2 * np.pi)) + 1))
    residual, matched = _residuals(pulses, expected, period)
    aligned = {reference: ref}
    diagnostics = {reference: _stream_summary(
        reference, ref, identity_clock(), is_reference=True, residual_time=pulses,
        residual=residual[matched], matched=int(matched.sum()),
        missing=max(expected.size - int(matched.sum()), 0),
        spurious=int(ref_pulses.spurious.sum()))}
    shown = {reference: (scene.alignment.main_reference_pulse.channel, pulses)}
    ref_start = parse_start_time(ref.attrs["start_time"])
    for name, pulse in scene.alignment.pulses.items():
        stream = converted[name]
        channel = pulse.channel.channel
        found = _pulses(stream, scene.channel(pulse.channel))
        edges, segments = found.times[~found.spurious], found.segment[~found.spurious]
        events = reference_event_times(main.time, main.phi, event_angle=pulse.angle,
                                       events_per_rev=pulse.per_revolution)
        coarse, search = _coarse_offset(stream, ref, ref_start)
        where = {"stream": name, "channel": channel}
        clock = estimate_clock(events, edges, segments, coarse_offset_s=coarse,
                               max_offset_error_s=search, where=where)
        clock = _recover_segments(clock, events, edges, segments, period,
                                  pulse.per_revolution, where)
        aligned[name] = align_stream(stream, clock, name=name)
        mapped = clock.to_reference(edges, segments)
        ok = np.isfinite(mapped)
        residual, matched = _residuals(mapped[ok], events, period, pulse.per_revolution)
        inside = (events >= aligned[name]["time"].values[0]) & (
            events <= aligned[name]["time"].values[-1])
        diagnostics[name] = _stream_summary(
            name, aligned[name], clock, is_reference=False,
            residual_time=mapped[ok][matched], residual=residual[matched],
            matched=int(matched.sum()), missing=max(int(inside.sum()) - int(matched.sum()), 0),
            spurious=int((~matched).sum() + found.spurious.sum()))
        shown[name] = (channel, mapped[ok])
    half_width = PULSE_WINDOW * period
    centre = _common_pulse(pulses, [d.span_s for d in diagnostics.values()], half_width)
    diagnostics = {name: _with_pulse_window(summary, aligned[name], *shown[name], centre,
                                            half_width)
                   for name, summary in diagnostics.items()}
    return aligned, diagnostics, main
