"""Alignment diagnostics: how each stream's clock was mapped onto the reference timeline.

:class:`StreamAlignment` is the record per stream (clock, events, gaps, a raw-pulse window) that
the report's alignment section and ``alignment.json`` show; the functions here fill it from a
fitted :class:`~rigval.processing.clock_fit.ClockModel` and the stream's pulse edges
(:func:`rigval.processing.stream_alignment.align_streams` calls them).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr

from rigval.acquisition.sample_times import SampleTimes, sample_times
from rigval.acquisition.schema import invalid_counts, stream_gaps
from rigval.processing.arrays import distinct_in_runs
from rigval.processing.clock_fit import ClockModel
from rigval.processing.event_match import robust_inliers
from rigval.processing.pulses import StreamPulses

__all__ = [
    "MIN_EVENT_TOLERANCE_S",
    "PulseSamples",
    "StreamAlignment",
    "common_pulse",
    "event_residuals",
    "pulse_samples",
    "segment_table",
    "stream_summary",
    "with_pulse_window",
]

#: Matched events within this distance in s of the clock line always count as matched (a
#: sample period of the slowest device), however tight the others are.
MIN_EVENT_TOLERANCE_S = 1e-3


@dataclass(frozen=True)
class StreamAlignment:
    """How one stream's clock was mapped onto the reference timeline.

    Parameters
    ----------
    stream : str
        Stream name.
    device : str
        Device kind.
    is_reference : bool
        True for the reference stream (offset 0, drift 0 by definition).
    offset_s : float
        Clock offset in s (reference time of the stream's time zero).
    drift_ppm : float
        Clock drift in ppm, as in ``t_ref = offset + (1 + drift) t_stream``: positive when the
        stream's clock runs slow against the reference's.
    residual_rms_s : float
        RMS of the clock-fit residuals on the matched events in s.
    events_matched : int
        Reference events matched with the reference stream.
    events_missing : int
        Expected events that were not seen.
    events_spurious : int
        Events that matched nothing.
    input_delay_s : float
        Module input delay removed in s.
    segments : int
        Gap-free segments (each with its own clock fit).
    gaps : tuple of mapping
        Gaps: ``{"after_s", "duration_s", "missing_samples"}`` on the stream's own clock.
    span_s : tuple of float
        First and last sample on the reference timeline in s.
    residual_time : numpy.ndarray
        Reference-timeline times of the matched events in s.
    residual_s : numpy.ndarray
        Clock-fit residual per matched event in s.
    pulse_time : numpy.ndarray
        A short window of the raw pulse channel around one reference pulse that every stream
        recorded: times on the reference timeline in s.
    pulse_signal : numpy.ndarray
        The raw pulse signal there, in ``pulse_units``.
    pulse_units : str
        Unit of the pulse channel as read.
    edge_times : numpy.ndarray
        Detected rising edges within that stretch in s.
    offset_u95_s, drift_u95_ppm : float
        Half-widths of the 95 % intervals of the offset (s) and the drift (ppm).
    periods_decided_by : str
        What decided the whole pulse periods (``stamps``, ``data``, ``neighbour``).
    method : str
        ``pulses`` or ``stamps`` (:class:`~rigval.processing.stream_alignment.ClockSettings`).
    start_time_uncertainty_s : float
        Half-width in s of the window the offset was searched in.
    coarse_offset_s : float
        Centre of that window in s.
    coarse_offset_source : str
        Where the centre came from (:attr:`~rigval.processing.stamps.CoarseOffset.source`).
    invalid_samples : mapping of str to int
        Samples of the aligned stream marked invalid, by reason (empty cells, unaligned
        segments, ...; the stream's ``invalid_reason``/``invalid_count``).
    segment_table : tuple of mapping
        Per gap-free segment: clock offset and its 95 % interval, clock group, samples, samples
        dropped and why.
    """

    stream: str
    device: str
    is_reference: bool
    offset_s: float
    drift_ppm: float
    residual_rms_s: float
    events_matched: int
    events_missing: int
    events_spurious: int
    input_delay_s: float
    segments: int
    gaps: tuple[Mapping[str, Any], ...]
    span_s: tuple[float, float]
    residual_time: np.ndarray = field(repr=False)
    residual_s: np.ndarray = field(repr=False)
    pulse_time: np.ndarray = field(repr=False)
    pulse_signal: np.ndarray = field(repr=False)
    pulse_units: str
    edge_times: np.ndarray = field(repr=False)
    offset_u95_s: float = 0.0
    drift_u95_ppm: float = 0.0
    periods_decided_by: str = ""
    method: str = "pulses"
    start_time_uncertainty_s: float = 0.0
    coarse_offset_s: float = 0.0
    coarse_offset_source: str = ""
    segment_table: tuple[Mapping[str, Any], ...] = ()
    invalid_samples: Mapping[str, int] = field(default_factory=dict)

    def summary(self) -> dict[str, Any]:
        """Return the JSON-ready summary written to ``alignment.json``."""
        return {
            "device": self.device, "reference": self.is_reference, "offset_s": self.offset_s,
            "drift_ppm": self.drift_ppm, "residual_rms_s": self.residual_rms_s,
            "events_matched": self.events_matched, "events_missing": self.events_missing,
            "events_spurious": self.events_spurious, "input_delay_s": self.input_delay_s,
            "segments": self.segments, "gaps": [dict(g) for g in self.gaps],
            "span_s": list(self.span_s), "offset_u95_s": self.offset_u95_s,
            "drift_u95_ppm": self.drift_u95_ppm, "periods_decided_by": self.periods_decided_by,
            "method": self.method, "start_time_uncertainty_s": self.start_time_uncertainty_s,
            "coarse_offset_s": self.coarse_offset_s,
            "coarse_offset_source": self.coarse_offset_source,
            "samples_dropped": sum(int(row.get("samples_dropped", 0))
                                   for row in self.segment_table),
            "segment_table": [dict(row) for row in self.segment_table],
            "invalid_samples": dict(self.invalid_samples),
        }


def event_residuals(mapped: np.ndarray, events: np.ndarray, period: float,
                    per_revolution: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Residual (s) of each mapped event against its nearest expected event; matched mask.

    An event within a quarter period (of the pulse rate) of an expected event is matched unless
    :func:`~rigval.processing.event_match.robust_inliers` calls it a stray (within
    :data:`MIN_EVENT_TOLERANCE_S` it never is). With several pulses per revolution, each kind of
    pulse (its place within the revolution) may fire at its own angle; the median residual of
    each kind is removed, as the clock fit does.
    """
    index = np.clip(np.searchsorted(events, mapped), 1, events.size - 1)
    nearest = np.where(np.abs(mapped - events[index - 1]) <= np.abs(events[index] - mapped),
                       index - 1, index)
    residual = mapped - events[nearest]
    matched = np.abs(residual) < 0.25 * period / per_revolution
    if matched.sum() > 3:  # a spurious pulse can fall inside a quarter period: robust cut
        matched &= robust_inliers(residual, among=matched, floor_s=MIN_EVENT_TOLERANCE_S)
    if per_revolution > 1:
        kind = nearest % per_revolution
        for k in range(per_revolution):
            chosen = matched & (kind == k)
            if chosen.any():
                residual[kind == k] -= np.median(residual[chosen])
    return residual, matched


@dataclass(frozen=True)
class PulseSamples:
    """The samples of a pulse channel near its edges: what its pulse window can show.

    A pulse channel whose edges are found as it is read is let go then (memory); the window
    of :func:`with_pulse_window` around any of its edges is cut from these samples instead.

    Parameters
    ----------
    attrs : mapping
        The channel's attributes (``units``, ``input_delay_s`` in s as the aligned stream has it).
    starts, stops : numpy.ndarray of int64
        First and one-past-last sample index of each kept run of samples, increasing, the runs
        apart.
    values : numpy.ndarray
        The kept runs' samples one run after the other (the channel's unit).
    """

    attrs: Mapping[str, Any]
    starts: np.ndarray
    stops: np.ndarray
    values: np.ndarray = field(repr=False)

    def between(self, lo: int, hi: int) -> np.ndarray:
        """Return the samples ``lo ... hi - 1`` of the channel.

        Raises
        ------
        ValueError
            If they are not within one kept run (a window wider than the samples were kept for).
        """
        run = int(np.searchsorted(self.starts, lo, side="right")) - 1
        if run < 0 or hi > self.stops[run]:
            raise ValueError(f"pulse samples {lo} to {hi} were not kept (kept runs "
                             f"{self.starts.size}, the window is wider than they were kept for)")
        first = int(np.sum(self.stops[:run] - self.starts[:run])) + lo - int(self.starts[run])
        return self.values[first:first + hi - lo]


def _window_bounds(time: np.ndarray | SampleTimes, centres: np.ndarray, half_width: float,
                   delay: float) -> tuple[np.ndarray, np.ndarray]:
    """Return the sample ranges ``[lo, hi)`` of the windows ``centre +- half_width`` (s).

    Two samples more on either side than the delayed window holds (its edges are tested
    exactly on the channel's times afterwards).
    """
    lo = np.searchsorted(time, centres - half_width + delay) - 2
    hi = np.searchsorted(time, centres + half_width + delay) + 2
    return np.maximum(lo, 0), np.minimum(hi, time.size)


def pulse_samples(stream: xr.Dataset, channel: str, edges: np.ndarray, half_width: float,
                  delay: float) -> PulseSamples:
    """Keep the samples of a pulse channel that a window around any of its edges can show.

    Parameters
    ----------
    stream : xarray.Dataset
        The stream holding the channel, its ``time`` as the aligned stream will have it.
    channel : str
        The pulse channel.
    edges : numpy.ndarray
        Times (s) of the edges a window may be centred on, increasing.
    half_width : float
        The widest half-width (s) a window will have.
    delay : float
        The channel's input delay (s) on the aligned stream (``input_delay_s``).

    Returns
    -------
    PulseSamples
        The samples within ``half_width`` of each edge, as :func:`with_pulse_window` cuts them.
    """
    lo, hi = _window_bounds(sample_times(stream), edges, half_width, delay)  # not made whole
    reach = np.maximum.accumulate(hi) if hi.size else hi
    new_run = np.ones(lo.size, dtype=bool)
    new_run[1:] = lo[1:] > reach[:-1]
    starts = lo[new_run].astype(np.int64)
    stops = reach[np.r_[np.flatnonzero(new_run)[1:] - 1, lo.size - 1]].astype(np.int64) \
        if lo.size else np.zeros(0, np.int64)
    data = stream[channel].to_numpy()
    values = np.concatenate([data[a:b] for a, b in zip(starts, stops, strict=True)]) \
        if starts.size else np.zeros(0, data.dtype)
    return PulseSamples({**stream[channel].attrs, "input_delay_s": delay}, starts, stops,
                        values)


def with_pulse_window(summary: StreamAlignment, aligned: xr.Dataset, channel: str,
                      edges: np.ndarray, centre: float, half_width: float,
                      kept: PulseSamples | None = None) -> StreamAlignment:
    """Attach the raw pulse signal and its edges within ``centre +- half_width`` (s).

    The samples come from ``kept`` when the channel was let go after its edges were found
    (it is then not in ``aligned``), else from ``aligned``.
    """
    # the window's samples found on the increasing time axis, then the exact test on them
    # alone (no whole-record temporaries)
    time = sample_times(aligned)  # not made whole
    attrs = kept.attrs if kept is not None else aligned[channel].attrs
    delay = float(attrs.get("input_delay_s", 0.0))
    lo, hi = (int(b[0]) for b in _window_bounds(time, np.array([centre]), half_width, delay))
    t = time[lo:hi] - delay  # as clock_fit.channel_time
    inside = np.abs(t - centre) <= half_width
    if kept is None:
        signal = aligned[channel].to_numpy()[lo:hi][inside]
    else:  # kept around every edge a window can be centred on; none when the window is empty
        signal = kept.between(lo, hi)[inside] if inside.any() else kept.values[:0]
    return dataclasses.replace(
        summary, pulse_time=t[inside], pulse_signal=signal,
        pulse_units=str(attrs.get("units", "")),
        edge_times=edges[np.abs(edges - centre) <= half_width])


def common_pulse(pulses: np.ndarray, spans: list[tuple[float, float]], margin: float) -> float:
    """Return the first reference pulse (s) that every stream recorded (else the first pulse)."""
    start = max(span[0] for span in spans) + margin
    stop = min(span[1] for span in spans) - margin
    inside = pulses[(pulses >= start) & (pulses <= stop)]
    return float(inside[0] if inside.size else pulses[0])


def stream_summary(name: str, aligned: xr.Dataset, clock: ClockModel, *, is_reference: bool,
                   residual_time: np.ndarray, residual: np.ndarray, matched: int,
                   missing: int, spurious: int, let_go: PulseSamples | None = None
                   ) -> StreamAlignment:
    """Return a stream's record without its pulse window (:func:`with_pulse_window` adds it).

    Parameters
    ----------
    name : str
        Stream name.
    aligned : xarray.Dataset
        The stream on the reference timeline.
    clock : ClockModel
        Its clock model.
    is_reference : bool
        Whether it is the reference stream.
    residual_time, residual : numpy.ndarray
        Reference times (s) of the matched events and their residuals (s).
    matched, missing, spurious : int
        Event counts.
    let_go : PulseSamples, optional
        The pulse channel let go after its edges were found: its input delay counts among the
        stream's.
    """
    empty = np.zeros(0)
    delays = [float(aligned[v].attrs.get("input_delay_s", 0.0)) for v in aligned.data_vars
              if v not in ("valid", "segment")]
    if let_go is not None:
        delays.append(float(let_go.attrs.get("input_delay_s", 0.0)))
    times = sample_times(aligned)  # the first and the last, of a lazy axis too (memory)
    return StreamAlignment(
        stream=name, device=str(aligned.attrs.get("device", "")), is_reference=is_reference,
        offset_s=float(clock.offsets_s[0]), drift_ppm=clock.drift * 1e6,
        offset_u95_s=float(clock.offsets_u95_s[0]) if clock.offsets_u95_s else 0.0,
        drift_u95_ppm=clock.drift_u95 * 1e6, periods_decided_by=clock.periods_decided_by,
        residual_rms_s=float(np.sqrt(np.mean(residual**2))) if residual.size else 0.0,
        events_matched=matched, events_missing=missing, events_spurious=spurious,
        input_delay_s=max(delays, default=0.0), segments=len(clock.segments),
        gaps=tuple(stream_gaps(aligned)), invalid_samples=invalid_counts(aligned),
        span_s=(float(times[0]), float(times[-1])), residual_time=residual_time,
        residual_s=residual, pulse_time=empty, pulse_signal=empty, pulse_units="",
        edge_times=empty)


def _dropped_because(n_edges: int, span: tuple[float, float], events: np.ndarray) -> str:
    """Why a segment could not be aligned (span: its rough reference-clock times in s)."""
    if events.size and (span[1] < events[0] or span[0] > events[-1]):
        return ("not aligned: the segment lies outside the reference record (no reference "
                "events to match)")
    if n_edges < 2:
        return f"not aligned: {n_edges} reference-pulse edges in the segment (need 2)"
    return (f"not aligned: its {n_edges} reference-pulse edges could not be matched to the "
            "reference events")


def segment_table(stream: xr.Dataset, clock: ClockModel, edges: StreamPulses | None,
                  events: np.ndarray) -> tuple[dict[str, Any], ...]:
    """Per segment: offset, its 95 % interval, clock group, samples and samples dropped (why).

    ``edges`` are the stream's pulse edges (None for a stream aligned by its stamps) and
    ``events`` the reference events (s) they were matched with.
    """
    segment = stream["segment"].to_numpy()
    device_time = sample_times(stream)  # two times a segment: none of the lazy axis made
    offsets = dict(zip(clock.segments, clock.offsets_s, strict=True))
    fitted_groups = dict(zip(clock.segments, clock.clock_groups or clock.segments, strict=True))
    u95 = dict(zip(clock.segments, clock.offsets_u95_s or (0.0,) * len(clock.segments),
                   strict=True))
    rows = []
    for s in distinct_in_runs(segment):  # no sorted copy of the whole record
        mine = segment == s
        first, last = int(np.argmax(mine)), segment.size - 1 - int(np.argmax(mine[::-1]))
        samples = int(np.count_nonzero(mine))
        aligned = int(s) in offsets
        n_edges = int(np.count_nonzero(edges.segment == s)) if edges is not None else 0
        rows.append({
            "segment": int(s), "clock_group": fitted_groups.get(int(s)),
            "device_time_s": [float(device_time[first]), float(device_time[last])],
            "samples": samples,
            "clock_offset_s": offsets.get(int(s)), "clock_offset_u95_s": u95.get(int(s)),
            "samples_dropped": 0 if aligned else samples,
            "dropped_because": "" if aligned else _dropped_because(
                n_edges, (float(device_time[first] + clock.offsets_s[0]),
                          float(device_time[last] + clock.offsets_s[0])), events)})
    return tuple(rows)
