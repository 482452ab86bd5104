"""Start stamps and clock groups: what a stream's own time attributes say about its clock.

A stream's ``start_time`` is a software stamp of its host (off by ms to seconds); the device
profile says how far (``start_time_uncertainty_s``) and how fast its oscillator may run off
(``clock_tolerance_ppm``, docs/formats.md). :func:`coarse_offset` turns the stamps of two
streams into the window :func:`rigval.processing.clock_fit.estimate_clock` searches;
:func:`clock_groups` tells which gaps the device clock ran through; :func:`stamps_clock` is the
clock of a stream aligned by its stamps alone.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import xarray as xr

from rigval.acquisition.devices import get_device
from rigval.acquisition.errors import ChannelNotFoundError
from rigval.acquisition.schema import parse_start_time, stream_gaps
from rigval.processing.clock_fit import ClockModel

__all__ = [
    "RUNNING_CLOCK_SAMPLES",
    "START_TIME_ERROR_S",
    "CoarseOffset",
    "clock_groups",
    "clock_tolerance",
    "coarse_offset",
    "stamp_uncertainty",
    "stamps_clock",
]

logger = logging.getLogger(__name__)

#: How far (s) a start time written by a device may be off: software time stamps.
START_TIME_ERROR_S = 5.0
#: Oscillator tolerance (1) of a stream whose device profile is unknown.
DEFAULT_CLOCK_TOLERANCE = 100e-6
#: A gap within this many samples of a whole number of samples was run through by the device
#: clock (no restart): CSV time columns with microseconds leave 0.002 sample at 1.6 kS/s.
RUNNING_CLOCK_SAMPLES = 0.01
#: Start times in or before this year mean "unknown" (NI writes 1904-01-01 for relative time).
UNKNOWN_START_YEAR = 1904


@dataclass(frozen=True)
class CoarseOffset:
    """A first guess of a stream's clock offset and the window to search around it.

    Attributes
    ----------
    offset_s : float
        Rough ``t_ref - t_dev`` in s.
    window_s : float
        How far in s the guess may be wrong (``max_offset_error_s`` of
        :func:`~rigval.processing.clock_fit.estimate_clock`).
    source : str
        Where the guess came from: ``"start stamps"``, ``"given offset"`` or
        ``"no start time"``.
    drift_bound : float
        How fast (1) the guess may go off with time since the starts: both clocks' oscillator
        tolerances (:func:`clock_tolerance`). A segment restarted hours in takes a new host
        stamp, while the reference's record has run off host time meanwhile.
    """

    offset_s: float
    window_s: float
    source: str
    drift_bound: float = 0.0


def stamp_uncertainty(stream: xr.Dataset) -> float:
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


def coarse_offset(reference: xr.Dataset, stream: xr.Dataset, *, offset_s: float | None = None,
                  uncertainty_s: float | None = None) -> CoarseOffset:
    """Return a first guess of ``t_ref - t_dev`` in s, the window to search around it, and why.

    Parameters
    ----------
    reference : xarray.Dataset
        The reference stream (its ``start_time`` and ``device`` attributes).
    stream : xarray.Dataset
        The stream to align.
    offset_s : float, optional
        A known offset in s to search around instead of the stamps' difference (a stream whose
        stamp is known to be wrong); window: ``uncertainty_s``, else the stream's stamp bound.
    uncertainty_s : float, optional
        Bound in s of the error of the stamps' difference (or of ``offset_s``); default: the
        sum of both streams' stamp bounds (:func:`stamp_uncertainty`).

    Returns
    -------
    CoarseOffset
        From ``offset_s`` when given; else from the start stamps; a stream or reference without
        a start time (1904-01-01, e.g. a CSV with relative time) is searched over the whole
        overlap of the two records.
    """
    drift = clock_tolerance(stream) + clock_tolerance(reference)
    if offset_s is not None:
        return CoarseOffset(offset_s, uncertainty_s or stamp_uncertainty(stream), "given offset",
                            drift)
    start = parse_start_time(stream.attrs["start_time"])
    ref_start = parse_start_time(reference.attrs["start_time"])
    if _known(start) and _known(ref_start):
        window = uncertainty_s or (stamp_uncertainty(stream) + stamp_uncertainty(reference))
        return CoarseOffset(float((start - ref_start) / np.timedelta64(1, "ns")) * 1e-9, window,
                            "start stamps", drift)
    ref_span = float(reference["time"].values[-1] - reference["time"].values[0])
    dev_span = float(stream["time"].values[-1] - stream["time"].values[0])
    logger.info("stream %s has no start time: searching offsets over the whole record",
                stream.attrs.get("stream", ""))
    return CoarseOffset(0.5 * (ref_span - dev_span), 0.5 * (ref_span + dev_span), "no start time")


def clock_groups(stream: xr.Dataset) -> dict[int, int]:
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


def clock_tolerance(stream: xr.Dataset) -> float:
    """Return a stream's oscillator tolerance (1) from its attributes or device profile."""
    if "clock_tolerance_ppm" in stream.attrs:
        return float(stream.attrs["clock_tolerance_ppm"]) * 1e-6
    try:
        return get_device(str(stream.attrs.get("device", ""))).clock_tolerance_ppm * 1e-6
    except ChannelNotFoundError:
        return DEFAULT_CLOCK_TOLERANCE


def stamps_clock(stream: xr.Dataset, reference: xr.Dataset, coarse: CoarseOffset) -> ClockModel:
    """Clock of a stream aligned by its start stamps alone.

    Offset: the coarse offset, good to its window; drift 0, good to both devices' oscillator
    tolerances (sample clocks are not disciplined by NTP/PTP of their hosts). The 95 %
    half-widths are those bounds; the standard errors are the bounds over 1.96.
    """
    segments = tuple(int(s) for s in np.unique(stream["segment"].to_numpy()))
    tolerance = clock_tolerance(stream) + clock_tolerance(reference)
    return ClockModel(segments, tuple(coarse.offset_s for _ in segments), 0.0, 0.0, 0, 0,
                      coarse.window_s / 1.96, tolerance / 1.96, (),
                      tuple(coarse.window_s for _ in segments), tolerance, "stamps",
                      tuple(0 for _ in segments))
