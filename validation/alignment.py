"""Alignment of a scene's streams: phi_F from the main encoder, one clock per device.

:func:`align_streams` puts every stream of a scene on the reference stream's timeline: phi_F(t)
from the main-shaft encoder (smoothed, never differenced raw, :func:`rigval.processing.angle.phi_f`)
is zero at the main reference pulse; each other stream's clock (offset and drift per gap-free
segment) is fitted on its reference pulses against the events the encoder angle predicts
(:func:`rigval.processing.align.estimate_clock`), with module input delays removed, within the
window its start stamps allow (device profiles, or the scene's ``start_time_uncertainty_s`` and
``coarse_offset_s``); segments a dropout did not restart keep one offset, and every offset's
95 % interval includes the uncertainty of phi_F = 0. The diagnostics
(:class:`~rigval.validation.results.StreamAlignment`) feed the report's alignment section and
``alignment.json`` (per segment: offset, clock group, samples dropped and why).
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
from scipy.stats import t as student_t

from rigval.acquisition.channel_map import ChannelSpec
from rigval.acquisition.devices import get_device, get_module
from rigval.acquisition.errors import ChannelNotFoundError, DataError
from rigval.acquisition.schema import parse_start_time, stream_gaps
from rigval.processing.align import (
    ClockModel,
    align_stream,
    channel_time,
    estimate_clock,
    identity_clock,
    reference_event_times,
)
from rigval.processing.angle import phi_f
from rigval.processing.errors import AlignmentError
from rigval.processing.pulses import StreamPulses, stream_pulses
from rigval.validation.results import StreamAlignment
from rigval.validation.scene import PulseSpec, Scene

__all__ = ["MainAngle", "align_streams"]

logger = logging.getLogger(__name__)

#: How far (s) a start time written by a device may be off: software time stamps.
START_TIME_ERROR_S = 5.0
#: The edges of a stream aligned without pulses (``method = "stamps"``).
_NO_EDGES = StreamPulses("", "rising", np.zeros(0), np.zeros(0, dtype=np.int64),
                         np.zeros(0, dtype=bool), np.zeros(0), 0.0)
#: A gap within this many samples of a whole number of samples was run through by the device
#: clock (no restart): CSV time columns with microseconds leave 0.002 sample at 1.6 kS/s.
RUNNING_CLOCK_SAMPLES = 0.01
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
    zero_u95_s : float, default 0
        Half-width in s of the 95 % interval of the time at which phi_F = 0 (the mean of the
        reference pulses: Student t on their scatter, with the bound of sample-switched edges).
        It shifts every reference event alike, so it adds to every stream's offset interval.
    """

    time: np.ndarray
    phi: np.ndarray
    zero_u95_s: float = 0.0

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
    found = stream_pulses(stream, channel.name, polarity=channel.params.get("edge", "rising"),
                          low=low, high=high)
    if found.timing_bound_s == 0.0 and channel.module:
        try:
            kind = get_module(channel.module).kind
        except ChannelNotFoundError:
            kind = "delta-sigma"  # unknown module: trust the edge shape (sample_switched)
        if kind != "delta-sigma":
            # No anti-alias filter: an edge faster than the sample clock is interpolated from
            # samples that do not describe it; half a sample bounds the error.
            found = dataclasses.replace(found, timing_bound_s=0.5 / float(
                stream.attrs["fs_nominal"]))
    return found


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
    used = pulses.good.size
    period = float(np.median(np.diff(pulses.good)))
    scatter_s = float(angle["phi_F"].attrs.get("reference_scatter_rad", 0.0)) / (2 * np.pi) * period
    mean_u95 = float(student_t.ppf(0.975, used - 1)) * scatter_s / np.sqrt(used)
    zero_u95 = float(np.hypot(mean_u95, pulses.timing_bound_s))
    return MainAngle(t, phi, zero_u95), pulses


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
        offset_u95_s=float(clock.offsets_u95_s[0]) if clock.offsets_u95_s else 0.0,
        drift_u95_ppm=clock.drift_u95 * 1e6, periods_decided_by=clock.periods_decided_by,
        residual_rms_s=float(np.sqrt(np.mean(residual**2))) if residual.size else 0.0,
        events_matched=matched, events_missing=missing, events_spurious=spurious,
        input_delay_s=max(delays, default=0.0), segments=len(clock.segments),
        gaps=tuple(stream_gaps(aligned)),
        span_s=(float(times[0]), float(times[-1])), residual_time=residual_time,
        residual_s=residual, pulse_time=empty, pulse_signal=empty, pulse_units="",
        edge_times=empty)


def _stamp_uncertainty(stream: xr.Dataset) -> float:
    """Return the bound (s) of a stream's start-stamp error from its device profile.

    The reader records the profile's ``start_time_uncertainty_s`` (docs/formats.md); a stream
    read without a profile gets it from its ``device`` attribute when that names a known
    profile, else :data:`START_TIME_ERROR_S`.
    """
    if "start_time_uncertainty_s" in stream.attrs:
        return float(stream.attrs["start_time_uncertainty_s"])
    try:
        return get_device(str(stream.attrs.get("device", ""))).start_time_uncertainty_s
    except ChannelNotFoundError:
        return START_TIME_ERROR_S


def _known(start: np.datetime64) -> bool:
    return bool(start.astype("datetime64[Y]").astype(int) + 1970 > UNKNOWN_START_YEAR)


def _coarse_offset(stream: xr.Dataset, ref: xr.Dataset, ref_start: np.datetime64,
                   pulse: PulseSpec) -> tuple[float, float, str]:
    """Return a first guess of ``t_ref - t_dev`` in s, the window to search around it, and why.

    The scene's ``coarse_offset_s`` when given (window: its ``start_time_uncertainty_s``, else
    the stream's profile bound); else the files' start times (window: the scene's
    ``start_time_uncertainty_s``, else the sum of both profiles' bounds); a file without a start
    time (1904-01-01, e.g. a CSV with relative time) is searched over the whole overlap.
    """
    if pulse.coarse_offset_s is not None:
        window = pulse.start_time_uncertainty_s or _stamp_uncertainty(stream)
        return pulse.coarse_offset_s, window, "scene coarse_offset_s"
    start = parse_start_time(stream.attrs["start_time"])
    if _known(start) and _known(ref_start):
        window = pulse.start_time_uncertainty_s or (_stamp_uncertainty(stream)
                                                    + _stamp_uncertainty(ref))
        return float((start - ref_start) / np.timedelta64(1, "s")), window, "start stamps"
    ref_span = float(ref["time"].values[-1] - ref["time"].values[0])
    dev_span = float(stream["time"].values[-1] - stream["time"].values[0])
    logger.info("stream %s has no start time: searching offsets over the whole record",
                stream.attrs.get("stream", ""))
    return 0.5 * (ref_span - dev_span), 0.5 * (ref_span + dev_span), "no start time"


def _clock_groups(stream: xr.Dataset) -> dict[int, int]:
    """Return segment -> clock group: a gap the device clock ran through keeps the group.

    A device whose clock runs on through a dropout writes the samples after it at a whole
    number of sample periods from those before (CSV time column, TDMS ``wf_start_time``
    advanced by counted samples); a restart takes a new software stamp, which lands anywhere
    between samples. Gaps within :data:`RUNNING_CLOCK_SAMPLES` of a whole number of samples
    keep one clock (one offset across the segments).
    """
    fs = float(stream.attrs["fs_nominal"])
    groups = {0: 0}
    for k, gap in enumerate(stream_gaps(stream)):
        steps = float(gap["duration_s"]) * fs + 1.0  # sample periods from before to after
        running = abs(steps - round(steps)) <= RUNNING_CLOCK_SAMPLES
        groups[k + 1] = groups[k] if running else k + 1
    return groups


def _clock_tolerance(stream: xr.Dataset) -> float:
    """Return a stream's oscillator tolerance (1) from its attributes or device profile."""
    if "clock_tolerance_ppm" in stream.attrs:
        return float(stream.attrs["clock_tolerance_ppm"]) * 1e-6
    try:
        return get_device(str(stream.attrs.get("device", ""))).clock_tolerance_ppm * 1e-6
    except ChannelNotFoundError:
        return 100e-6


def _stamps_clock(stream: xr.Dataset, ref: xr.Dataset, coarse: float, window: float
                  ) -> ClockModel:
    """Clock of a stream aligned by its start stamps alone (``method = "stamps"``).

    Offset: the stamps' difference (or the scene's ``coarse_offset_s``), good to the window;
    drift 0, good to both devices' oscillator tolerances (sample clocks are not disciplined by
    NTP/PTP of their hosts).
    """
    segments = tuple(int(s) for s in np.unique(stream["segment"].to_numpy()))
    tolerance = _clock_tolerance(stream) + _clock_tolerance(ref)
    return ClockModel(segments, tuple(coarse for _ in segments), 0.0, 0.0, 0, 0,
                      window / 1.96, tolerance / 1.96, (), tuple(window for _ in segments),
                      tolerance, "stamps", tuple(0 for _ in segments))


def _fit_clock(events: np.ndarray, found: StreamPulses, coarse: float,
               window: float, groups: Mapping[int, int], pulse: PulseSpec, name: str,
               where: Mapping[str, Any]) -> ClockModel:
    """Fit the stream's clock on its pulses; segments grouped by a running clock first."""
    edges, segments = found.times[~found.spurious], found.segment[~found.spurious]
    key = f"alignment.pulses.{name}"
    # as few events as leave one degree of freedom (3 for one offset and a drift): the
    # Student-t interval then says how little they tell
    kwargs = {"coarse_offset_s": coarse, "max_offset_error_s": window, "min_events": 3,
              "timing_bound_s": found.timing_bound_s,
              "per_revolution": pulse.per_revolution, "where": where,
              "settle_keys": (f"{key}.coarse_offset_s", f"{key}.start_time_uncertainty_s")}
    if len(set(groups.values())) < len(groups):
        try:
            return estimate_clock(events, edges, segments, clock_groups=groups, **kwargs)
        except AlignmentError as error:
            logger.info("%s: one clock across the dropouts does not fit (%s); a clock per "
                        "segment", name, error)
    return estimate_clock(events, edges, segments, **kwargs)


def _dropped_because(n_edges: int, span: tuple[float, float], events: np.ndarray) -> str:
    """Why a segment could not be aligned (span: its rough reference-clock times in s)."""
    if events.size and (span[1] < events[0] or span[0] > events[-1]):
        return ("not aligned: the segment lies outside the reference record (no reference "
                "events to match)")
    if n_edges < 2:
        return f"not aligned: {n_edges} reference-pulse edges in the segment (need 2)"
    return (f"not aligned: its {n_edges} reference-pulse edges could not be matched to the "
            "reference events")


def _segment_table(stream: xr.Dataset, clock: ClockModel, edges: StreamPulses,
                   events: np.ndarray) -> tuple[dict[str, Any], ...]:
    """Per segment: offset, its 95 % interval, clock group, samples and samples dropped (why)."""
    segment = stream["segment"].to_numpy()
    device_time = stream["time"].to_numpy()
    offsets = dict(zip(clock.segments, clock.offsets_s, strict=True))
    fitted_groups = dict(zip(clock.segments, clock.clock_groups or clock.segments, strict=True))
    u95 = dict(zip(clock.segments, clock.offsets_u95_s or (0.0,) * len(clock.segments),
                   strict=True))
    rows = []
    for s in np.unique(segment):
        mine = segment == s
        aligned = int(s) in offsets
        n_edges = int(np.count_nonzero(edges.segment == s)) if edges.times.size else 0
        rows.append({
            "segment": int(s), "clock_group": fitted_groups.get(int(s)),
            "device_time_s": [float(device_time[mine][0]), float(device_time[mine][-1])],
            "samples": int(mine.sum()),
            "clock_offset_s": offsets.get(int(s)), "clock_offset_u95_s": u95.get(int(s)),
            "samples_dropped": 0 if aligned else int(mine.sum()),
            "dropped_because": "" if aligned else _dropped_because(
                n_edges, (float(device_time[mine][0] + clock.offsets_s[0]),
                          float(device_time[mine][-1] + clock.offsets_s[0])), events)})
    return tuple(rows)


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
        coarse, window, source = _coarse_offset(stream, ref, ref_start, pulse)
        groups = _clock_groups(stream)
        if pulse.method == "stamps":
            clock = _stamps_clock(stream, ref, coarse, window)
            aligned[name] = align_stream(stream, clock, name=name,
                                         reference_start=ref.attrs["start_time"])
            diagnostics[name] = _stream_summary(
                name, aligned[name], clock, is_reference=False, residual_time=np.zeros(0),
                residual=np.zeros(0), matched=0, missing=0, spurious=0)
            diagnostics[name] = dataclasses.replace(
                diagnostics[name], method="stamps", start_time_uncertainty_s=window,
                coarse_offset_s=coarse, coarse_offset_source=source,
                segment_table=_segment_table(stream, clock, _NO_EDGES, np.zeros(0)))
            continue
        assert pulse.channel is not None  # the scene requires it with method = "pulses"
        channel = pulse.channel.channel
        found = _pulses(stream, scene.channel(pulse.channel))
        edges, segments = found.times[~found.spurious], found.segment[~found.spurious]
        events = reference_event_times(main.time, main.phi, event_angle=pulse.angle,
                                       events_per_rev=pulse.per_revolution)
        where = {"stream": name, "channel": channel}
        clock = _fit_clock(events, found, coarse, window, groups, pulse, name, where)
        clock = dataclasses.replace(clock, offsets_u95_s=tuple(
            float(np.hypot(u, main.zero_u95_s)) for u in clock.offsets_u95_s))
        aligned[name] = align_stream(stream, clock, name=name,
                                         reference_start=ref.attrs["start_time"])
        mapped = clock.to_reference(edges, segments)
        ok = np.isfinite(mapped)
        residual, matched = _residuals(mapped[ok], events, period, pulse.per_revolution)
        inside = (events >= aligned[name]["time"].values[0]) & (
            events <= aligned[name]["time"].values[-1])
        diagnostics[name] = dataclasses.replace(_stream_summary(
            name, aligned[name], clock, is_reference=False,
            residual_time=mapped[ok][matched], residual=residual[matched],
            matched=int(matched.sum()), missing=max(int(inside.sum()) - int(matched.sum()), 0),
            spurious=int((~matched).sum() + found.spurious.sum())),
            start_time_uncertainty_s=window, coarse_offset_s=coarse,
            coarse_offset_source=source, segment_table=_segment_table(stream, clock, found, events))
        shown[name] = (channel, mapped[ok])
    half_width = PULSE_WINDOW * period
    centre = _common_pulse(pulses, [d.span_s for d in diagnostics.values()], half_width)
    diagnostics = {name: _with_pulse_window(summary, aligned[name], *shown[name], centre,
                                            half_width) if name in shown else summary
                   for name, summary in diagnostics.items()}
    return aligned, diagnostics, main
