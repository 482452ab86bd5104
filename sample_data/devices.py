"""Devices of the virtual rig: own clocks, Wi-Fi dropouts and restarts, module delay, ADC codes.

A device samples at ``fs_nominal`` on its own oscillator, which runs ``drift_ppm`` fast: sample k of
a gap-free segment is taken at true time ``true_start + k / (fs_nominal (1 + drift_ppm 1e-6))``.
The file records ``wf_start_time`` = true start + a software time-stamp error, and the nominal
``wf_increment = 1 / fs_nominal``. A wireless carrier loses its link now and then: the task is
restarted after a gap of tens to hundreds of ms, with a new software start time.

Modules delay their data: a sample taken at true time t holds the input at ``t - delay``. For the
NI 9237 (delta-sigma) the delay is ``(40 + 5/512) / fs + 4.5 us`` (NI KB, docs/references.md
[NI-9237]) and its anti-alias filter band-limits the signal to 0.45 fs (an edge becomes a
sine-integral step, 10-90 % rise of about one sample period, with the filter's ringing); the
NI 9215 (SAR) has neither, the NI 9411 digital input (encoders) a delay of 500 ns.

What a device records is a :class:`Stream` of :class:`SampledChannel` (written a
:class:`StreamPiece` at a time): :mod:`rigval.sample_data.streams` fills them,
:mod:`rigval.sample_data.faults` alters them, :mod:`rigval.sample_data.simulate` writes them.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigval.acquisition.devices import ni9237_input_delay
from rigval.acquisition.errors import ConfigError
from rigval.processing.arrays import FloatArray

__all__ = ["ANTI_ALIAS_BAND", "MODULES", "ClockSegment", "DeviceClock", "Module", "SampledChannel",
           "Stream", "StreamPiece", "dropout_segments"]

logger = logging.getLogger(__name__)


#: Pass band of a delta-sigma module's anti-alias (decimation) filter, as a fraction of its rate.
ANTI_ALIAS_BAND = 0.45


@dataclass(frozen=True)
class Module:
    """A C Series module as the virtual rig models it.

    Parameters
    ----------
    name : str
        Model, e.g. ``"NI 9237"``.
    bits : int
        ADC resolution (0 for a counter: counts are stored as they are).
    delta_sigma : bool
        True for a delta-sigma module (input delay and anti-alias filter).
    fixed_delay : float, default 0
        Input delay in s independent of the rate (digital input modules).
    """

    name: str
    bits: int
    delta_sigma: bool
    fixed_delay: float = 0.0

    @property
    def raw_dtype(self) -> np.dtype:
        """Numpy dtype of the raw samples NI-DAQmx logs for this module."""
        if self.bits == 0:
            return np.dtype("<u4")
        return np.dtype("<i2") if self.bits <= 16 else np.dtype("<i4")

    def delay(self, fs: float) -> float:
        """Input delay in s at rate fs (Hz)."""
        return ni9237_input_delay(fs) if self.delta_sigma else self.fixed_delay

    def filter_bandwidth(self, fs: float) -> float | None:
        """Return the anti-alias filter's band edge in Hz at rate fs (Hz); None for SAR modules.

        A delta-sigma module's decimation filter passes 0.45 fs and rejects everything the
        sample rate would alias (linear phase, its group delay is part of :meth:`delay`): its
        samples are those of a signal band-limited to 0.45 fs, modelled as an ideal low-pass.
        """
        return ANTI_ALIAS_BAND * fs if self.delta_sigma else None

    def quantise(self, values: ArrayLike, full_scale: float) -> tuple[NDArray, float]:
        """Return raw ADC codes and the scale slope (unit per code) for a +-full_scale range.

        Codes are ``round(value / slope)`` clipped to the ADC range, ``slope = full_scale /
        (2**(bits-1) - 1)``; the physical value is ``code * slope``.
        """
        if self.bits == 0:
            raise ConfigError(f"{self.name} is a counter; it stores counts, not ADC codes",
                              where={"key": "module"})
        top = 2 ** (self.bits - 1) - 1
        slope = full_scale / top
        codes = np.clip(np.rint(np.asarray(values, dtype=np.float64) / slope), -top - 1, top)
        return codes.astype(self.raw_dtype), slope


#: The modules of the reference rig ([paper] section 4.1).
MODULES: dict[str, Module] = {
    "NI 9215": Module("NI 9215", 16, False),
    "NI 9237": Module("NI 9237", 24, True),
    "NI 9411": Module("NI 9411", 0, False, 500e-9),
}


@dataclass(frozen=True)
class ClockSegment:
    """One gap-free stretch of a device's record.

    Parameters
    ----------
    true_start : float
        True time of the first sample in s.
    n_samples : int
        Number of samples.
    stamp_error : float
        Error of the software start time stamp the file records (s): recorded minus true.
    """

    true_start: float
    n_samples: int
    stamp_error: float


@dataclass(frozen=True)
class DeviceClock:
    """A device's sample clock and the gap-free segments it recorded.

    Parameters
    ----------
    fs_nominal : float
        Nominal rate in Hz (what the file's ``wf_increment`` says).
    drift_ppm : float
        Oscillator error in ppm (positive: runs fast, samples come early).
    segments : tuple of ClockSegment
        Gap-free stretches in time order.
    host_offset : float, default 0
        Offset (s) of the clock of the computer that stamps the start times; already included in
        every segment's ``stamp_error``.
    """

    fs_nominal: float
    drift_ppm: float
    segments: tuple[ClockSegment, ...]
    host_offset: float = 0.0

    @property
    def fs_true(self) -> float:
        """Actual sampling rate in Hz of true time."""
        return self.fs_nominal * (1.0 + self.drift_ppm * 1e-6)

    def sample_times(self, segment: int) -> FloatArray:
        """Return the true times (s) of the samples of one segment."""
        seg = self.segments[segment]
        return seg.true_start + np.arange(seg.n_samples) / self.fs_true


def dropout_segments(true_start: float, duration: float, fs_true: float, n_dropouts: int,
                     stamp_error_rms: float, rng: np.random.Generator,
                     gap_range: tuple[float, float] = (0.05, 0.4), *,
                     running_clock: bool = False,
                     fs_nominal: float | None = None) -> tuple[ClockSegment, ...]:
    """Split a record into gap-free segments at random Wi-Fi dropouts.

    Parameters
    ----------
    true_start : float
        True time of the first sample in s.
    duration : float
        Span of the record in s (true time, gaps included).
    fs_true : float
        Actual rate in Hz.
    n_dropouts : int
        Number of dropouts; each is followed by a task restart.
    stamp_error_rms : float
        Software time-stamp error (s rms) of each start, drawn per segment.
    rng : numpy.random.Generator
        Random source.
    gap_range : tuple of float, default (0.05, 0.4)
        Range of the gap length in s (link loss plus task restart).
    running_clock : bool, default False
        True: the device's clock runs on through each dropout (no restart): a segment starts a
        whole number k of sample periods after the first, and its recorded start time is the
        first one plus ``k / fs_nominal`` (the counted samples), not a new software stamp.
    fs_nominal : float, optional
        Nominal rate in Hz (needed with ``running_clock``).

    Returns
    -------
    tuple of ClockSegment
        The segments in time order.
    """
    cuts = np.sort(rng.uniform(0.15 * duration, 0.85 * duration, n_dropouts))
    gaps = rng.uniform(*gap_range, n_dropouts)
    starts = np.concatenate([[0.0], cuts + gaps])
    stops = np.concatenate([cuts, [duration]])
    if np.any(stops <= starts):
        raise ConfigError(f"{n_dropouts} dropouts do not fit in a {duration} s record",
                          where={"key": "dropouts"}, hint="use fewer dropouts or a longer run")
    errors = rng.normal(0.0, stamp_error_rms, n_dropouts + 1)
    if running_clock:
        if fs_nominal is None:
            raise ConfigError("a running clock needs the nominal rate", where={"key": "fs_nominal"})
        segments = []
        for a, b in zip(starts, stops, strict=True):
            k = int(np.ceil(a * fs_true))
            recorded = errors[0] + k / fs_nominal       # first recorded start + counted samples
            segments.append(ClockSegment(float(true_start + k / fs_true),
                                         int(np.floor((b - k / fs_true) * fs_true)),
                                         float(recorded - k / fs_true)))
        return tuple(segments)
    return tuple(ClockSegment(float(true_start + a), int(np.floor((b - a) * fs_true)), float(e))
                 for a, b, e in zip(starts, stops, errors, strict=True))


@dataclass(frozen=True)
class SampledChannel:
    """One channel as its device recorded it.

    Parameters
    ----------
    name : str
        Channel name.
    module : str
        Module model (key of :data:`~rigval.sample_data.devices.MODULES`).
    unit : str or None
        Unit string in the file (None for counters).
    raw : list of numpy.ndarray
        Raw codes or counts, one array per gap-free segment.
    slope : float
        Scale from raw to ``unit``.
    delay : float
        Module input delay in s.
    truth : numpy.ndarray or None
        Physical truth at the sample instants (segments concatenated), or None where the truth is
        kept elsewhere (pulses: edge lists; encoders: the drive law).
    truth_unit : str or None
        UDUNITS unit of ``truth``.
    """

    name: str
    module: str
    unit: str | None
    raw: list[NDArray]
    slope: float
    delay: float
    truth: FloatArray | None
    truth_unit: str | None


@dataclass(frozen=True)
class Stream:
    """One device's record: its clock and its channels.

    Parameters
    ----------
    name : str
        ``"cdaq"``, ``"wls1"`` or ``"wls2"``.
    device : str
        Device model.
    clock : DeviceClock
        Sample clock and segments.
    channels : tuple of SampledChannel
        Channels in file order.
    """

    name: str
    device: str
    clock: DeviceClock
    channels: tuple[SampledChannel, ...]


@dataclass(frozen=True)
class StreamPiece:
    """The samples of one stream within one window of true time.

    Parameters
    ----------
    stream : str
        Stream name.
    parts : tuple of (int, int)
        For each gap-free segment the window touches: the segment's index and the index of the
        piece's first sample within it, in time order.
    raw : mapping of str to list of numpy.ndarray
        Raw codes or counts per channel, one array per entry of ``parts``.
    truth : mapping of str to numpy.ndarray
        Physical truth at the piece's samples (parts concatenated) of the analog channels that
        have one.
    """

    stream: str
    parts: tuple[tuple[int, int], ...]
    raw: dict[str, list[NDArray]]
    truth: dict[str, FloatArray]
