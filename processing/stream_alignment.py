"""Alignment of a set of streams: phi_F from the main encoder, one clock per device.

:func:`align_streams` puts every stream on the reference stream's timeline: phi_F(t) from the
main-shaft encoder (smoothed, never differenced raw, :func:`rigval.processing.angle.phi_f`) is
zero at the main reference pulse; each other stream's clock (offset and drift per gap-free
segment) is fitted on its reference pulses against the events the encoder angle predicts
(:func:`rigval.processing.clock_fit.estimate_clock`), with module input delays removed, within the
window its start stamps allow (:func:`rigval.processing.stamps.coarse_offset`); segments a
dropout did not restart keep one offset, and every offset's 95 % interval includes the
uncertainty of phi_F = 0. The inputs are plain settings (:class:`AlignmentSettings`, which a
scene's ``[alignment]`` table fills, docs/scene.md); the diagnostics
(:class:`~rigval.processing.alignment_summary.StreamAlignment`) feed the report's alignment
section and ``alignment.json``. It runs in two halves, which a caller holding long records
calls itself (:func:`reference_angle`, then :func:`align_to_reference` on the events
:func:`pulse_events` takes from phi_F), so that phi_F is let go before the other streams are
aligned.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import xarray as xr

from rigval.acquisition.channel_map import ChannelSpec
from rigval.acquisition.devices import get_module
from rigval.acquisition.errors import ChannelNotFoundError, DataError
from rigval.acquisition.sample_times import SampleTimes, sample_times
from rigval.processing import alignment_summary as diagnose
from rigval.processing import clock_fit
from rigval.processing.alignment_summary import PulseSamples, StreamAlignment, pulse_samples
from rigval.processing.angle import AngleGrid, angle_grid, phi_f
from rigval.processing.encoder import (
    increasing_angle,
    interp_minus,
    remove_index_resets,
    unwrap_counts,
)
from rigval.processing.errors import AlignmentError
from rigval.processing.pulses import StreamPulses, stream_pulses
from rigval.processing.stamps import CoarseOffset, clock_groups, coarse_offset, stamps_clock

__all__ = [
    "AlignmentSettings",
    "ClockSettings",
    "MainAngle",
    "ReferenceAngle",
    "ReferencePulses",
    "ReferenceRecord",
    "align_streams",
    "align_to_reference",
    "clock_pulses",
    "pulse_events",
    "reference_angle",
    "reference_pulses",
]

logger = logging.getLogger(__name__)

#: Hysteresis half-band of a reference pulse's ``threshold``, as a fraction of it.
PULSE_HYSTERESIS = 0.1
#: Half-width of the raw-pulse window in the alignment figure, in main-shaft periods.
PULSE_WINDOW = 0.04


@dataclass(frozen=True)
class ClockSettings:
    """How one non-reference stream's clock is found.

    Attributes
    ----------
    method : {"pulses", "stamps"}
        ``"pulses"``: fitted on the pulse channel; ``"stamps"``: the stream's clock is
        synchronised with the reference's (same chassis, NTP/PTP) and its start stamp is used as
        it is, good to the window.
    pulse : ChannelSpec or None
        The stream's reference-pulse channel (``params``: ``threshold``, ``edge``); None with
        ``method = "stamps"``.
    per_revolution : int, default 1
        Pulses per main-shaft revolution (2 for a lifting shaft turning twice as fast).
    angle : float, default 0
        phi_F in rad at which the sensor fires (its mounting position).
    coarse_offset_s : float or None
        ``t_ref - t_stream`` in s to search around instead of the start stamps' difference.
    start_time_uncertainty_s : float or None
        Bound in s of the error of the stamps' difference (or of ``coarse_offset_s``); None:
        the sum of both device profiles' bounds.
    key : str, default ""
        Key path of these settings (``alignment.pulses.wls1``), named in error messages.
    """

    method: Literal["pulses", "stamps"] = "pulses"
    pulse: ChannelSpec | None = None
    per_revolution: int = 1
    angle: float = 0.0
    coarse_offset_s: float | None = None
    start_time_uncertainty_s: float | None = None
    key: str = ""


@dataclass(frozen=True)
class AlignmentSettings:
    """What :func:`align_streams` needs to know about the streams.

    Attributes
    ----------
    reference : str
        Name of the stream that keeps its own clock: every other stream is mapped onto it.
    encoder : ChannelSpec
        Main-shaft encoder on the reference stream (``params``: ``counts_per_rev``,
        ``index_reset``): phi_F(t).
    reference_pulse : ChannelSpec
        Once-per-revolution pulse on the reference stream: phi_F = 0 at its edges.
    streams : mapping of str to ClockSettings
        Per other stream, how its clock is found.
    direction : float, default 1
        +1, or -1 for an encoder that counts down while the shaft turns forward.
    min_pulses : int, default 2
        Fewest good reference pulses the reference stream must hold.
    min_pulses_key : str, default "min_pulses"
        Key path of ``min_pulses`` (``angle.min_cycles`` in a scene), named when the record is
        shorter than it (the encoder turned fewer revolutions), not the pulse channel.
    key : str, default "alignment"
        Key path of these settings, named in error messages.
    """

    reference: str
    encoder: ChannelSpec
    reference_pulse: ChannelSpec
    streams: Mapping[str, ClockSettings] = field(default_factory=dict)
    direction: float = 1.0
    min_pulses: int = 2
    min_pulses_key: str = "min_pulses"
    key: str = "alignment"


@dataclass(frozen=True)
class MainAngle:
    """phi_F, the main shaft angle from the reference position, on the reference timeline.

    The encoder's samples were taken at ``axis - delay_s``: the stream's time axis is held with
    the encoder's input delay beside it, not the delayed copy of the whole axis (memory); the
    methods take the delay off the times they return, with the values of the copy.

    Parameters
    ----------
    axis : numpy.ndarray or SampleTimes
        The reference stream's times in s at the encoder's samples, the delay not taken off
        (a lazy axis's, computed where read: memory).
    phi : numpy.ndarray
        phi_F in rad, increasing, multiples of 2 pi at the reference pulse.
    zero_u95_s : float, default 0
        Half-width in s of the 95 % interval of the time at which phi_F = 0 (the mean of the
        reference pulses: Student t on their scatter, with the bound of sample-switched edges).
        It shifts every reference event alike, so it adds to every stream's offset interval.
    delay_s : float, default 0
        The encoder's input delay in s.
    """

    axis: np.ndarray | SampleTimes
    phi: np.ndarray
    zero_u95_s: float = 0.0
    delay_s: float = 0.0

    @property
    def time(self) -> np.ndarray:
        """Reference-clock times (s) where the encoder angle is defined.

        Made when the axis is lazy, a copy when delayed (the methods below need neither).
        """
        axis = self.axis[:] if isinstance(self.axis, SampleTimes) else self.axis
        return axis - self.delay_s if self.delay_s else axis

    @property
    def span_s(self) -> tuple[float, float]:
        """The first and the last of :attr:`time`, s."""
        return float(self.axis[0] - self.delay_s), float(self.axis[-1] - self.delay_s)

    def times_at(self, angles: np.ndarray) -> np.ndarray:
        """Return the reference times (s) at which phi_F takes the given values (rad)."""
        return interp_minus(angles, self.phi, self.axis, self.delay_s)

    def event_times(self, event_angle: float = 0.0, events_per_rev: int = 1) -> np.ndarray:
        """Return the times (s) at which phi_F passes ``event_angle + k 2 pi / events_per_rev``.

        :func:`rigval.processing.clock_fit.reference_event_times` of phi_F.
        """
        return clock_fit.reference_event_times(self.axis, self.phi, event_angle=event_angle,
                                               events_per_rev=events_per_rev,
                                               delay_s=self.delay_s)

    def grid(self, points_per_rev: int) -> AngleGrid:
        """Return the record's uniform phi_F grid (:func:`rigval.processing.angle.angle_grid`)."""
        return angle_grid(self.axis, self.phi, points_per_rev, delay_s=self.delay_s)


def _pulses(stream: xr.Dataset, channel: ChannelSpec) -> StreamPulses:
    """Edges of a reference-pulse channel (delay-corrected, classified) as its spec says."""
    threshold = channel.params.get("threshold")
    low = high = None
    if threshold is not None:
        band = PULSE_HYSTERESIS * max(abs(threshold), float(np.finfo(float).tiny))
        low, high = threshold - band, threshold + band
    found = stream_pulses(stream, channel.name, polarity=channel.params.get("edge", "rising"),
                          low=low, high=high)
    if found.shape == "symmetric" and channel.module:
        try:
            kind = get_module(channel.module).kind
        except ChannelNotFoundError:
            kind = "delta-sigma"  # unknown module: trust the edge shape (sample_switched)
        if kind != "delta-sigma":
            # No anti-alias filter: an edge faster than the sample clock is interpolated from
            # samples that do not describe it; half a sample bounds the error.
            found = dataclasses.replace(found, timing_bound_s=0.5 / float(
                stream.attrs["fs_nominal"]), bounds_s=None)
    return found


@dataclass(frozen=True)
class ReferencePulses:
    """The main reference pulses, found on the reference stream as read; its channel let go.

    Attributes
    ----------
    pulses : StreamPulses
        The channel's edges, as :func:`align_streams` finds them on the aligned reference stream
        (whose clock is the identity: the same times, delays and valid samples).
    samples : PulseSamples
        The channel's samples near each good edge: any pulse window the alignment figure can
        centre on one of them.
    """

    pulses: StreamPulses
    samples: PulseSamples


def reference_pulses(settings: AlignmentSettings, stream: xr.Dataset
                     ) -> tuple[xr.Dataset, ReferencePulses | None]:
    """Find the main reference pulses on the reference stream and let its pulse channel go.

    Reading a long record, the pulse channel is then held as its edges and the samples near
    them (memory), not whole through the alignment.

    Parameters
    ----------
    settings : AlignmentSettings
        The alignment settings (the reference stream and its pulse channel).
    stream : xarray.Dataset
        The reference stream in physical units, before the alignment.

    Returns
    -------
    stream : xarray.Dataset
        The stream without its pulse channel (unchanged when the pulses cannot bound the
        window, below).
    pulses : ReferencePulses or None
        For :func:`align_streams`; None, and the channel kept, when fewer than two good edges
        or edges not in time order leave the window's width unbounded.
    """
    channel = settings.reference_pulse.name
    found = _pulses(stream, settings.reference_pulse)
    intervals = np.diff(found.good)
    if intervals.size == 0 or not np.all(intervals > 0):
        return stream, None
    # The window is PULSE_WINDOW times the median interval of a run of these edges: never
    # wider than PULSE_WINDOW times the longest.
    widest = PULSE_WINDOW * float(np.max(intervals))
    # the aligned reference stream's delay: this one times (1 + drift), drift 0
    delay = clock_fit.input_delay(stream[channel].attrs, float(stream.attrs["fs_nominal"]))
    samples = pulse_samples(stream, channel, found.good, widest, delay)
    return stream.drop_vars(channel), ReferencePulses(found, samples)


def clock_pulses(settings: AlignmentSettings, name: str, stream: xr.Dataset
                 ) -> StreamPulses | None:
    """Find the pulses stream ``name``'s clock is fitted on, before phi_F is known.

    A stream's pulse edges depend on its own samples alone, so they may be found as it is read
    (beside other work) and handed to :func:`align_to_reference` (``found``): the results are
    the same.

    Parameters
    ----------
    settings : AlignmentSettings
        How each other stream is aligned.
    name : str
        One of the other streams (``settings.streams``).
    stream : xarray.Dataset
        It in physical units, as read.

    Returns
    -------
    StreamPulses or None
        None for a stream aligned by its stamps or without a pulse channel (its alignment says
        why, or needs none).
    """
    clock = settings.streams[name]
    if clock.method != "pulses" or clock.pulse is None:
        return None
    return _pulses(stream, clock.pulse)


def _encoder_turns(ref: xr.Dataset, encoder: ChannelSpec) -> float:
    """Return the revolutions the main encoder turned over the record (NaN: counts unusable)."""
    try:
        counts = unwrap_counts(ref[encoder.name].to_numpy())
    except DataError:
        return math.nan  # reported by the angle itself
    cpr = float(encoder.params["counts_per_rev"])
    if encoder.params.get("index_reset", False):
        counts, _ = remove_index_resets(counts, cpr)
    return float(np.ptp(counts)) / cpr if counts.size else 0.0


def _main_angle(settings: AlignmentSettings, ref: xr.Dataset, pulses: StreamPulses
                ) -> MainAngle:
    """Return phi_F(t) from the main encoder, zero at the reference pulses ``pulses``."""
    encoder, pulse_channel = settings.encoder, settings.reference_pulse
    if pulses.good.size < settings.min_pulses:
        turns = _encoder_turns(ref, encoder)
        found = (f"only {pulses.good.size} reference pulses on "
                 f"{settings.reference}.{pulse_channel.name}; the main encoder turned "
                 f"{turns:.3g} revolutions")
        if math.isfinite(turns) and pulses.good.size >= math.floor(turns) - 1:  # a short record
            raise DataError(f"{found}, fewer than the {settings.min_pulses} cycles asked for",
                            where={"key": settings.min_pulses_key},
                            hint=f"record more revolutions, or lower {settings.min_pulses_key}")
        raise DataError(found, where={"key": f"{settings.key}.main_reference_pulse"},
                        hint="check the pulse channel (threshold, edge, wiring)")
    angle = phi_f(ref, encoder.name, pulses, counts_per_rev=encoder.params["counts_per_rev"],
                  direction=float(settings.direction),
                  index_reset=bool(encoder.params.get("index_reset", False)), derivatives=False)
    # the encoder's times are the time axis (lazy where read so) and its delay, not their
    # copy (memory)
    delay = float(ref[encoder.name].attrs.get("input_delay_s", 0.0))
    try:  # the finite samples, copied only when some are not
        t, phi = increasing_angle(sample_times(ref), angle["phi_F"].to_numpy(), use="(phi_F)")
    except DataError:
        raise DataError("the main shaft angle does not increase steadily (standstill, reversal "
                        "or the encoder counting down)",
                        where={"channel": f"{settings.reference}.{encoder.name}"},
                        hint="validate runs at steady speed; set direction = -1 in the driver "
                             "table of an encoder that counts down") from None
    used = pulses.good.size
    period = float(np.median(np.diff(pulses.good)))
    # phi_f stores the scatter on the Dataset, not on the phi_F variable
    scatter_s = float(angle.attrs["reference_scatter_rad"]) / (2 * np.pi) * period
    mean_u95 = clock_fit.student_t_975(used - 1) * scatter_s / np.sqrt(used)
    zero_u95 = float(np.hypot(mean_u95, pulses.timing_bound_s))
    return MainAngle(t, phi, zero_u95, delay)


def _fit_clock(events: np.ndarray, found: StreamPulses, coarse: CoarseOffset,
               groups: Mapping[int, int], clock: ClockSettings, name: str,
               where: Mapping[str, Any]) -> clock_fit.ClockModel:
    """Fit the stream's clock on its pulses; segments grouped by a running clock first."""
    edges, segments = found.times[~found.spurious], found.segment[~found.spurious]
    key = clock.key or name
    # as few events as leave one degree of freedom (3 for one offset and a drift): the
    # Student-t interval then says how little they tell
    kwargs = {"coarse_offset_s": coarse.offset_s, "max_offset_error_s": coarse.window_s,
              "min_events": 3, "timing_bound_s": found.good_bounds,
              "per_revolution": clock.per_revolution, "where": where,
              "drift_bound": coarse.drift_bound,
              "settle_keys": (f"{key}.coarse_offset_s", f"{key}.start_time_uncertainty_s")}
    if len(set(groups.values())) < len(groups):
        try:
            return clock_fit.estimate_clock(events, edges, segments, clock_groups=groups, **kwargs)
        except AlignmentError as error:
            logger.info("%s: one clock across the dropouts does not fit (%s); a clock per "
                        "segment", name, error)
    return clock_fit.estimate_clock(events, edges, segments, **kwargs)


@dataclass(frozen=True)
class ReferenceRecord:
    """What aligning the other streams takes of the reference stream besides phi_F's events.

    Attributes
    ----------
    summary : StreamAlignment
        The reference stream's record, without its pulse window.
    pulses : numpy.ndarray
        The good reference pulses within phi_F, s.
    period : float
        Their median interval, s.
    zero_u95_s : float
        :attr:`MainAngle.zero_u95_s`.
    kept : PulseSamples or None
        The samples of the pulse channel let go as the stream was read
        (:attr:`ReferencePulses.samples`); None when the channel is in the stream.
    """

    summary: StreamAlignment
    pulses: np.ndarray
    period: float
    zero_u95_s: float
    kept: PulseSamples | None


@dataclass(frozen=True)
class ReferenceAngle:
    """:func:`reference_angle`'s output: the reference stream on its timeline, phi_F, its record.

    Attributes
    ----------
    stream : xarray.Dataset
        The reference stream with ``time`` on its own clock
        (:func:`~rigval.processing.clock_fit.align_stream` with the identity clock).
    main : MainAngle
        phi_F(t).
    record : ReferenceRecord
        For :func:`align_to_reference`.
    """

    stream: xr.Dataset
    main: MainAngle
    record: ReferenceRecord


def reference_angle(settings: AlignmentSettings, stream: xr.Dataset, *,
                    device_time: bool = True, found: ReferencePulses | None = None
                    ) -> ReferenceAngle:
    """Put the reference stream on its own timeline; phi_F and the reference pulses' record.

    The first half of :func:`align_streams`: what the other streams need of phi_F, the events
    it predicts (:func:`pulse_events`), is then taken from it, so that phi_F can be let go
    before they are aligned (:func:`align_to_reference`).

    Parameters
    ----------
    settings : AlignmentSettings
        The reference stream, its encoder and pulse.
    stream : xarray.Dataset
        The reference stream in physical units.
    device_time, found
        As in :func:`align_streams`.

    Returns
    -------
    ReferenceAngle
        The stream, phi_F and the record.

    Raises
    ------
    DataError
        When the reference stream has too few pulses or its encoder angle does not increase.
    """
    # a lazy time axis stays lazy: phi_F is made and held on it (memory)
    ref = clock_fit.align_stream(stream, clock_fit.identity_clock(stream["segment"]),
                                 name=settings.reference, device_time=device_time)
    ref_pulses = found.pulses if found is not None else _pulses(ref, settings.reference_pulse)
    main = _main_angle(settings, ref, ref_pulses)
    first, last = main.span_s
    pulses = ref_pulses.good[(ref_pulses.good >= first) & (ref_pulses.good <= last)]
    period = float(np.median(np.diff(pulses)))
    expected = main.times_at(2.0 * np.pi * np.arange(math.ceil(main.phi[0] / (2 * np.pi)),
                                                     math.floor(main.phi[-1] / (2 * np.pi)) + 1))
    residual, matched = diagnose.event_residuals(pulses, expected, period)
    kept = found.samples if found is not None else None
    summary = diagnose.stream_summary(
        settings.reference, ref, clock_fit.identity_clock(), is_reference=True,
        residual_time=pulses, residual=residual[matched], matched=int(matched.sum()),
        missing=max(expected.size - int(matched.sum()), 0),
        spurious=int(ref_pulses.spurious.sum()), let_go=kept)
    return ReferenceAngle(ref, main, ReferenceRecord(summary, pulses, period, main.zero_u95_s,
                                                     kept))


def pulse_events(settings: AlignmentSettings, main: MainAngle) -> dict[str, np.ndarray]:
    """Return the reference events phi_F predicts for each stream aligned on its pulses.

    Parameters
    ----------
    settings : AlignmentSettings
        Each other stream's pulse angle and pulses per revolution.
    main : MainAngle
        phi_F(t).

    Returns
    -------
    dict of str to numpy.ndarray
        Stream name -> reference times (s) of phi_F at its pulse angle
        (:meth:`MainAngle.event_times`); streams aligned by their stamps are absent.
    """
    return {name: main.event_times(clock.angle, clock.per_revolution)
            for name, clock in settings.streams.items() if clock.method == "pulses"}


def _align_by_pulses(name: str, stream: xr.Dataset, clock: ClockSettings, coarse: CoarseOffset,
                     events: np.ndarray, record: ReferenceRecord, reference_start: str, *,
                     device_time: bool = True, found: StreamPulses | None = None
                     ) -> tuple[xr.Dataset, StreamAlignment, np.ndarray]:
    """Align one stream on its pulses; return it, its record and its mapped edges (s).

    ``events`` are the reference times phi_F predicts for its pulses (:func:`pulse_events`);
    ``reference_start`` is the reference stream's ``start_time``, the origin of the CF time units;
    ``found``: its pulses (:func:`clock_pulses`), found here by default.
    """
    if clock.pulse is None:
        raise AlignmentError(f"stream {name} has no pulse channel to fit its clock on",
                             where={"stream": name, "key": clock.key},
                             hint='name its pulse channel or use method = "stamps"')
    if found is None:
        found = _pulses(stream, clock.pulse)
    edges, segments = found.times[~found.spurious], found.segment[~found.spurious]
    where = {"stream": name, "channel": clock.pulse.name}
    model = _fit_clock(events, found, coarse, clock_groups(stream), clock, name, where)
    model = dataclasses.replace(model, offsets_u95_s=tuple(
        float(np.hypot(u, record.zero_u95_s)) for u in model.offsets_u95_s))
    aligned = clock_fit.align_stream(stream, model, name=name, reference_start=reference_start,
                                 device_time=device_time)
    mapped = model.to_reference(edges, segments)
    mapped = mapped[np.isfinite(mapped)]
    residual, matched = diagnose.event_residuals(mapped, events, record.period,
                                                 clock.per_revolution)
    time = aligned["time"].to_numpy()
    inside = (events >= time[0]) & (events <= time[-1])
    summary = dataclasses.replace(diagnose.stream_summary(
        name, aligned, model, is_reference=False, residual_time=mapped[matched],
        residual=residual[matched], matched=int(matched.sum()),
        missing=max(int(inside.sum()) - int(matched.sum()), 0),
        spurious=int((~matched).sum() + found.spurious.sum())),
        start_time_uncertainty_s=coarse.window_s, coarse_offset_s=coarse.offset_s,
        coarse_offset_source=coarse.source,
        segment_table=diagnose.segment_table(stream, model, found, events))
    return aligned, summary, mapped


def _align_by_stamps(name: str, stream: xr.Dataset, ref: xr.Dataset, coarse: CoarseOffset, *,
                     device_time: bool) -> tuple[xr.Dataset, StreamAlignment]:
    """Align one stream on its start stamp; return it and its record."""
    model = stamps_clock(stream, ref, coarse)
    aligned = clock_fit.align_stream(stream, model, name=name,
                                     reference_start=ref.attrs["start_time"],
                                     device_time=device_time)
    summary = dataclasses.replace(diagnose.stream_summary(
        name, aligned, model, is_reference=False, residual_time=np.zeros(0),
        residual=np.zeros(0), matched=0, missing=0, spurious=0),
        method="stamps", start_time_uncertainty_s=coarse.window_s,
        coarse_offset_s=coarse.offset_s, coarse_offset_source=coarse.source,
        segment_table=diagnose.segment_table(stream, model, None, np.zeros(0)))
    return aligned, summary


def align_to_reference(settings: AlignmentSettings, ref: xr.Dataset,
                       converted: Mapping[str, xr.Dataset], record: ReferenceRecord,
                       events: Mapping[str, np.ndarray], *, device_time: bool = True,
                       found: Mapping[str, StreamPulses] | None = None
                       ) -> tuple[dict[str, xr.Dataset], dict[str, StreamAlignment]]:
    """Put every other stream on the reference timeline; attach every stream's pulse window.

    The second half of :func:`align_streams`, which takes phi_F's predicted events, not phi_F.

    Parameters
    ----------
    settings : AlignmentSettings
        How each other stream is aligned.
    ref : xarray.Dataset
        The reference stream on its timeline (:attr:`ReferenceAngle.stream`), its channels
        those the caller keeps.
    converted : mapping of str to xarray.Dataset
        The other streams in physical units (the reference, if there, is not read).
    record : ReferenceRecord
        The reference's (:attr:`ReferenceAngle.record`).
    events : mapping of str to numpy.ndarray
        :func:`pulse_events` of phi_F.
    device_time : bool, default True
        As in :func:`align_streams`.
    found : mapping of str to StreamPulses, optional
        Streams' pulses found before (:func:`clock_pulses`); the others' are found here.

    Returns
    -------
    aligned, diagnostics
        As :func:`align_streams` returns them, the reference stream first.

    Raises
    ------
    AlignmentError
        When a stream's clock cannot be fitted with confidence.
    """
    reference = settings.reference
    aligned = {reference: ref}
    diagnostics = {reference: record.summary}
    shown = {reference: (settings.reference_pulse.name, record.pulses)}
    for name, clock in settings.streams.items():
        stream = converted[name]
        coarse = coarse_offset(ref, stream, offset_s=clock.coarse_offset_s,
                               uncertainty_s=clock.start_time_uncertainty_s)
        if clock.method == "stamps":
            aligned[name], diagnostics[name] = _align_by_stamps(name, stream, ref, coarse,
                                                                device_time=device_time)
            continue
        aligned[name], diagnostics[name], mapped = _align_by_pulses(
            name, stream, clock, coarse, events[name], record, ref.attrs["start_time"],
            device_time=device_time, found=(found or {}).get(name))
        shown[name] = (clock.pulse.name if clock.pulse else "", mapped)
    half_width = PULSE_WINDOW * record.period
    centre = diagnose.common_pulse(record.pulses, [d.span_s for d in diagnostics.values()],
                                   half_width)
    kept = {reference: record.kept} if record.kept is not None else {}
    diagnostics = {name: diagnose.with_pulse_window(summary, aligned[name], *shown[name],
                                                    centre, half_width, kept.get(name))
                   if name in shown else summary
                   for name, summary in diagnostics.items()}
    return aligned, diagnostics


def align_streams(settings: AlignmentSettings, converted: Mapping[str, xr.Dataset], *,
                  device_time: bool = True, found: ReferencePulses | None = None
                  ) -> tuple[dict[str, xr.Dataset], dict[str, StreamAlignment], MainAngle]:
    """Put every stream on the reference timeline.

    :func:`reference_angle`, :func:`pulse_events` and :func:`align_to_reference` in a row;
    a caller that must let phi_F go before the other streams are aligned calls them itself.

    Parameters
    ----------
    settings : AlignmentSettings
        The reference stream, its encoder and pulse, and how each other stream is aligned.
    converted : mapping of str to xarray.Dataset
        The streams in physical units (:func:`rigval.processing.sensors.convert_stream`); every
        stream named in ``settings`` must be there.
    device_time : bool, default True
        Keep each stream's ``device_time`` coordinate
        (:func:`~rigval.processing.clock_fit.align_stream`); False: memory for callers that never
        read it.
    found : ReferencePulses, optional
        The main reference pulses found as the reference stream was read
        (:func:`reference_pulses`), its pulse channel then absent from it; default: found
        here on the reference stream's pulse channel. The results are the same.

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
    DataError
        When the reference stream has too few pulses or its encoder angle does not increase.
    """
    reference = reference_angle(settings, converted[settings.reference],
                                device_time=device_time, found=found)
    aligned, diagnostics = align_to_reference(
        settings, reference.stream, converted, reference.record,
        pulse_events(settings, reference.main), device_time=device_time)
    return aligned, diagnostics, reference.main
