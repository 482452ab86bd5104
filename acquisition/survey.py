"""What a lab's data files hold: streams, rates, devices and what each channel looks like.

:func:`guess_streams` reads each file and guesses, per stream, the device profile (from the file
format, gaps, rates and units) and, per channel, what it is (:func:`classify_channel`): an
encoder (integer counts), a reference pulse (two levels, short high or low phases) or a sensor
whose kind follows from its unit and name (``V/V`` bridge ratios: torsion, strain or load-cell
bridges; volts: accelerometers or a linear transducer; already-scaled units: ``physical``).
:func:`counts_per_pulse` and :func:`index_to_pulse_angle` estimate what an encoder counts
between reference pulses. The results are plain dataclasses; ``rigval init`` writes them as a
commented scene skeleton (docs/scene.md).
"""

from __future__ import annotations

import dataclasses
import logging
import math
import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from rigval.acquisition.devices import MODULES, rate_divider
from rigval.acquisition.errors import UnitError
from rigval.acquisition.reader import read
from rigval.acquisition.time_fallbacks import taken_as_utc, time_fallbacks
from rigval.acquisition.units import dimension, factor_or_none

__all__ = ["BRIDGE_UNITS", "ChannelGuess", "StreamGuess", "classify_channel", "counts_per_pulse",
           "guess_streams", "index_to_pulse_angle"]

logger = logging.getLogger(__name__)

#: Largest fraction of a pulse channel's samples between 25 % and 75 % of its range.
PULSE_MID_FRACTION = 0.02
#: Largest fraction of a pulse channel's samples in its less frequent level.
PULSE_DUTY = 0.35

#: Units of a bridge channel that holds the bridge ratio (the excitation divided out).
BRIDGE_UNITS: tuple[str, ...] = ("V/V", "mV/V")
#: Name fragments of transducers in volts and the unit they suggest.
_NAME_UNITS = (("torque", "N m"), ("tor", "N m"), ("force", "N"), ("load", "N"),
               ("press", "Pa"), ("acc", "m s-2"), ("disp", "m"), ("pos", "m"))


@dataclass(frozen=True)
class ChannelGuess:
    """What a channel looks like.

    Attributes
    ----------
    name : str
        Name for the scene (the file's channel name with characters other than letters, digits and
        ``_`` replaced by ``_``).
    source : str
        Channel name in the file.
    units : str
        Unit in the file (UDUNITS).
    role : {"encoder", "pulse", "sensor"}
        Encoder (integer counts), reference pulse, or a sensor to compare.
    sensor : str
        Guessed sensor kind (``docs/scene.md``).
    reason : str
        Why, for the comment.
    rising_edges : int
        Rising edges through 50 % of the range (pulses only).
    counts_span : float
        Last minus first count (encoders only).
    output_units : str
        Output unit of a ``linear`` channel guessed from its name (``""``: unknown).
    index_counts : int
        Encoders whose counter falls back to 0 once per turn (the index pulse Z reloads it):
        the counts per turn, 0 for none.
    index_counts_tol : int
        How far ``index_counts`` may be off, counts: the spread of the estimates of the complete
        turns seen; -1 when no complete turn was seen and ``index_counts`` is only a lower bound.
    """

    name: str
    source: str
    units: str
    role: str
    sensor: str
    reason: str
    rising_edges: int = 0
    counts_span: float = 0.0
    output_units: str = ""
    index_counts: int = 0
    index_counts_tol: int = 0


@dataclass(frozen=True)
class StreamGuess:
    """One stream of a file and its guessed device.

    Attributes
    ----------
    name : str
        Scene stream name.
    file : pathlib.Path
        The data file.
    format : str
        ``tdms``, ``csv`` or ``lvm``.
    reader : mapping
        Reader options the file needs (``group``).
    fs : float
        Sampling rate, Hz.
    samples : int
        Samples read.
    start_time : str
        The file's start stamp.
    gaps : int
        Gaps in the time axis.
    device : str
        Guessed device profile.
    device_reason : str
        Why.
    channels : tuple of ChannelGuess
        The numeric channels.
    pulse_times : mapping of str to numpy.ndarray
        Rising-edge times (s) of the pulse channels, for rate ratios and encoder estimates.
    encoder_counts : mapping of str to numpy.ndarray
        Counts of the encoder channels.
    timezone_missing : bool
        The file's times have no zone: the reader needs a ``timezone`` option.
    """

    name: str
    file: Path
    format: str
    reader: Mapping[str, Any]
    fs: float
    samples: int
    start_time: str
    gaps: int
    device: str
    device_reason: str
    channels: tuple[ChannelGuess, ...]
    pulse_times: Mapping[str, np.ndarray] = field(repr=False, default_factory=dict)
    encoder_counts: Mapping[str, np.ndarray] = field(repr=False, default_factory=dict)
    timezone_missing: bool = False

    @property
    def duration_s(self) -> float:
        """Recorded duration, s."""
        return self.samples / self.fs

    def of_role(self, role: str) -> list[ChannelGuess]:
        """Channels of a role, in file order."""
        return [c for c in self.channels if c.role == role]


def _plain_name(text: str) -> str:
    name = re.sub(r"[^A-Za-z0-9_]", "_", text.strip()).strip("_") or "channel"
    return name if not name[0].isdigit() else f"c{name}"


def _rising_edges(values: np.ndarray, time: np.ndarray) -> tuple[np.ndarray, float]:
    """Rising crossings of 50 % of the range (times, s) and the mid-range sample fraction."""
    finite = np.isfinite(values)
    if finite.sum() < 4:
        return np.empty(0), 1.0
    low, high = np.percentile(values[finite], [0.1, 99.9])
    span = high - low
    if not span > 0:
        return np.empty(0), 1.0
    level = (values - low) / span
    mid = float(np.mean((level[finite] > 0.25) & (level[finite] < 0.75)))
    upper = float(np.mean(level[finite] >= 0.5))
    if min(upper, 1.0 - upper) > PULSE_DUTY:
        return np.empty(0), 1.0  # two levels, but no short pulses: a square wave or steps
    above = np.where(finite, level >= 0.5, False)
    if upper > 0.5:  # short low pulses: the falling edge is the event
        above = ~above & finite
    rises = np.flatnonzero(~above[:-1] & above[1:]) + 1
    return time[rises], mid


def classify_channel(name: str, values: np.ndarray, units: str, time: np.ndarray
                     ) -> tuple[ChannelGuess, np.ndarray]:
    """Guess a channel's role and sensor kind from its values, unit and name.

    Parameters
    ----------
    name : str
        Channel name in the file.
    values : numpy.ndarray
        Its samples.
    units : str
        Its unit (UDUNITS, as the reader gives it).
    time : numpy.ndarray
        Sample times, s.

    Returns
    -------
    guess : ChannelGuess
        The guess with its reason.
    edges : numpy.ndarray
        Rising-edge times of a pulse channel (empty otherwise), s.
    """
    scene = _plain_name(name)
    lower = name.lower()
    finite = values[np.isfinite(values)]
    integer = finite.size > 0 and bool(np.all(finite == np.round(finite)))
    two_level = integer and np.unique(finite).size == 2
    if units in ("1", "") and integer and not two_level:
        index, tol, reloads = _index_period(finite)
        span = float(_unwrap(finite, index)[-1] - finite[0]) if finite.size else 0.0
        moved = "" if span else "; it never counts in this file"
        return ChannelGuess(scene, name, units, "encoder", "encoder",
                            f"integer counts without a unit (a counter){moved}{reloads}",
                            counts_span=span, index_counts=index, index_counts_tol=tol
                            ), np.empty(0)
    edges, mid = _rising_edges(values.astype(np.float64), time)
    if edges.size >= 2 and mid <= PULSE_MID_FRACTION:
        return ChannelGuess(scene, name, units, "pulse", "reference_pulse",
                            f"two levels with short pulses, {edges.size} pulses",
                            rising_edges=int(edges.size)), edges
    if two_level:
        return ChannelGuess(scene, name, units, "line", "physical",
                            "a digital line without short pulses; not compared"), np.empty(0)
    scaled = re.fullmatch(r"\s*([0-9.]+(?:[eE][-+]?\d+)?)\s+(.+)", units)
    if scaled:
        try:
            dimension(scaled.group(2))
            return ChannelGuess(scene, name, units, "sensor", "linear",
                                f"stored in {units!r}: a scaled unit",
                                output_units=scaled.group(2)), np.empty(0)
        except UnitError:
            pass
    if units in BRIDGE_UNITS:
        if "tor" in lower:
            kind, why = "torsion_bridge", "a bridge ratio named like a torque"
        elif any(k in lower for k in ("load", "force", "cell")):
            kind, why = "load_cell", "a bridge ratio named like a force"
        else:
            kind, why = "strain_bridge", "a bridge ratio"
        return ChannelGuess(scene, name, units, "sensor", kind, why), np.empty(0)
    if factor_or_none(units, "V") is not None:
        if "acc" in lower:
            return ChannelGuess(scene, name, units, "sensor", "charge_accelerometer",
                                "volts named like an accelerometer"), np.empty(0)
        hinted = next((u for hint, u in _NAME_UNITS if hint in lower), "")
        why = f", named like a {hinted!r} quantity" if hinted else ""
        return ChannelGuess(scene, name, units, "sensor", "linear",
                            f"volts: a transducer with a linear scale{why}",
                            output_units=hinted), np.empty(0)
    try:
        dimension(units)
    except UnitError:
        return ChannelGuess(scene, name, units, "sensor", "physical",
                            f"unit {units!r} unknown to rigval"), np.empty(0)
    return ChannelGuess(scene, name, units, "sensor", "physical",
                        f"already scaled to {units!r}"), np.empty(0)


def _device(fmt: str, gaps: int, fs: float, channels: Sequence[ChannelGuess]) -> tuple[str, str]:
    """Guess the device profile of a stream and say why."""
    ratio_only = all(c.units in BRIDGE_UNITS for c in channels) and bool(channels)
    at_9237 = rate_divider(MODULES["NI 9237"], fs) is not None
    if gaps:
        return "WLS-9163", f"{gaps} gap(s) in the time axis: a Wi-Fi carrier's dropouts"
    if ratio_only and at_9237 and not any(c.role == "encoder" for c in channels):
        return "WLS-9163", (f"only bridge ratios at {fs:.6g} Hz (an NI 9237 rate, 50 kS/s / n): "
                            "a single-module carrier")
    if fmt == "csv":
        return "WLS-9163", "a CSV export without counters"
    kinds = sorted({c.role if c.role != "sensor" else c.units for c in channels})
    return "cDAQ-9172", (f"a {fmt.upper()} stream without gaps ({', '.join(kinds)}): a wired "
                         "chassis; a Wi-Fi carrier would be WLS-9163")


def _stream_names(paths: Sequence[Path]) -> list[str]:
    stems = [p.stem for p in paths]
    prefix = ""
    if len(stems) > 1:
        prefix = stems[0]
        while prefix and not all(s.startswith(prefix) for s in stems):
            prefix = prefix[:-1]
    names = [_plain_name(s[len(prefix):] or s) for s in stems]
    return [n if names.count(n) == 1 else f"{n}_{i}" for i, n in enumerate(names)]


def guess_streams(paths: Sequence[str | os.PathLike[str]]) -> list[StreamGuess]:
    """Read data files and guess each stream's device and each channel's role.

    Parameters
    ----------
    paths : sequence of path-like
        TDMS, CSV or LVM files.

    Returns
    -------
    list of StreamGuess
        One per stream, in file order.

    Raises
    ------
    DataFileError
        A file that cannot be read.
    """
    files = [Path(p) for p in paths]
    out = []
    for path, base in zip(files, _stream_names(files), strict=True):
        streams = read(path)
        for index, (label, ds) in enumerate(streams.items()):
            name = base if len(streams) == 1 else f"{base}_{_plain_name(label)}"
            out.append(_guess_stream(name, path, ds, index))
    return out


def _guess_stream(name: str, path: Path, ds: xr.Dataset, index: int) -> StreamGuess:
    fs = float(ds.attrs["fs_nominal"])
    time = ds["time"].to_numpy()
    channels, pulses, counts = [], {}, {}
    for var in ds.data_vars:
        if var in ("valid", "segment") or ds[var].dtype.kind not in "iuf":
            continue
        values = ds[var].to_numpy().astype(np.float64)
        guess, edges = classify_channel(str(var), values, str(ds[var].attrs.get("units", "")),
                                        time)
        taken = {c.name for c in channels} | {"reference_pulse"}
        if guess.name in taken:  # two file names that read the same as scene names
            suffix = 2
            while f"{guess.name}_{suffix}" in taken:
                suffix += 1
            guess = dataclasses.replace(guess, name=f"{guess.name}_{suffix}")
        channels.append(guess)
        if guess.role == "pulse":
            pulses[guess.name] = edges
        if guess.role == "encoder":
            counts[guess.name] = values
    fmt = str(ds.attrs.get("source_format", path.suffix.lstrip(".").lower()))
    reader: dict[str, Any] = {}
    if fmt == "tdms" and ds.attrs.get("tdms_group"):
        reader["group"] = str(ds.attrs["tdms_group"])
    gaps = int(ds.attrs.get("gap_count", 0))
    device, why = _device(fmt, gaps, fs, channels)
    logger.debug("stream %s of %s (#%d): %s, %d channels", name, path, index, device,
                 len(channels))
    return StreamGuess(name, path, fmt, reader, fs, int(time.size),
                       str(ds.attrs.get("start_time", "")), gaps, device, why, tuple(channels),
                       pulses, counts,
                       taken_as_utc(time_fallbacks(ds.attrs)))


def _index_period(counts: np.ndarray) -> tuple[int, int, str]:
    """Estimate the counts per turn of a counter the index pulse reloads to 0, and how sure.

    At a reload between samples ``k`` and ``k + 1`` the counter ran up to ``cpr - 1``, fell to 0
    at the index and advanced on, so ``cpr = counts[k] - counts[k + 1] + advance``, the advance in
    that sample being the mean increment of the eight samples on either side, within one count
    (the readings are floors) plus the change of that mean across the reload. The highest count
    plus one is only a lower bound: it is low by up to the counts advanced per sample. The first
    reload ends counts that started where the counter task did, not at an index; it only counts
    when it is the only one, and then ``cpr`` is known only to be at least the estimate.

    Parameters
    ----------
    counts : numpy.ndarray
        Finite integer counts of one channel.

    Returns
    -------
    cpr : int
        Counts per turn; 0 when the counts never fall back to 0 (no index reloads).
    tol : int
        Half-width of the counts per turn consistent with every complete turn, counts (0: exact);
        -1: ``cpr`` is a lower bound.
    text : str
        For the channel's reason, ``""`` without reloads.
    """
    if counts.size < 2 or counts.min() < 0:
        return 0, 0, ""
    steps = np.diff(counts)
    drops = np.flatnonzero(steps < -0.5 * (counts.max() - counts.min()))
    if not drops.size:
        return 0, 0, ""
    estimates = []
    for k in drops:
        before, after = steps[max(k - 8, 0):k], steps[k + 1:k + 9]
        before, after = before[before >= 0], after[after >= 0]
        rates = [float(np.mean(part)) for part in (before, after) if part.size]
        advance = float(np.mean(rates)) if rates else 0.0
        # the counts are floors: each reading hides up to one count, and the speed may change
        wobble = 1.0 + (abs(rates[0] - rates[-1]) if rates else 0.0)
        estimates.append((counts[k] - counts[k + 1] + advance, wobble))
    floor = int(counts.max()) + 1
    if drops.size == 1:
        cpr = max(floor, round(estimates[0][0]))
        return cpr, -1, (f"; 1 reload to 0 (index pulse) and no complete turn: at least {cpr} "
                         "counts per turn")
    # each turn gives cpr within its wobble (open interval); where the phases differ from turn
    # to turn the intervals intersect closer: the whole numbers left are the candidates
    turns = np.array(estimates[1:])
    low = max(math.floor(np.max(turns[:, 0] - turns[:, 1])) + 1, floor)
    high = math.ceil(np.min(turns[:, 0] + turns[:, 1])) - 1
    if low > high:  # inconsistent turns (the speed changed within a sample): their spread
        low = max(math.floor(np.min(turns[:, 0] - turns[:, 1])) + 1, floor)
        high = max(math.ceil(np.max(turns[:, 0] + turns[:, 1])) - 1, low)
    cpr = min(max(round(float(np.median(turns[:, 0]))), low), high)
    tol = max(high - cpr, cpr - low)
    return cpr, tol, (f"; {drops.size} reloads to 0 (index pulse): {cpr} +- {tol} counts per "
                      f"turn from {drops.size - 1} complete turn(s)")


def _unwrap(counts: np.ndarray, index_counts: int) -> np.ndarray:
    """Return the counts with the index reloads undone (``index_counts`` per turn; 0: none)."""
    if not index_counts or counts.size < 2:
        return counts
    drops = np.diff(counts) < -0.5 * index_counts
    return counts + index_counts * np.concatenate([[0], np.cumsum(drops)])


def _encoder(stream: StreamGuess, name: str) -> ChannelGuess:
    return next(c for c in stream.channels if c.name == name)


def counts_per_pulse(stream: StreamGuess, encoder: str, pulse: str) -> int | None:
    """Median count increment between consecutive pulses of one stream.

    Parameters
    ----------
    stream : StreamGuess
        The stream holding both channels.
    encoder, pulse : str
        Names of an encoder and a pulse channel of ``stream``.

    Returns
    -------
    int or None
        Counts per pulse period (index reloads undone), None with fewer than two pulses or less
        than one count per pulse.
    """
    edges = stream.pulse_times.get(pulse)
    counts = stream.encoder_counts.get(encoder)
    if edges is None or counts is None or edges.size < 2:
        return None
    counts = _unwrap(counts, _encoder(stream, encoder).index_counts)
    time = np.arange(counts.size) / stream.fs
    steps = np.abs(np.diff(np.interp(edges, time, counts)))
    value = float(np.median(steps))
    return round(value) if value >= 1 else None


def index_to_pulse_angle(stream: StreamGuess, encoder: ChannelGuess,
                         pulse: ChannelGuess | None) -> float | None:
    """Angle from an index-reset encoder's index to the reference pulse.

    The counts at the pulse edges after the first reload, as angles on the circle of
    ``index_counts``, averaged on the circle.

    Parameters
    ----------
    stream : StreamGuess
        The stream holding both channels.
    encoder : ChannelGuess
        An encoder of ``stream``.
    pulse : ChannelGuess or None
        A pulse channel of ``stream``.

    Returns
    -------
    float or None
        Angle in counting direction, rad in [0, 2 pi); None without a pulse, without index
        reloads or without a pulse after the first reload.
    """
    if pulse is None or not encoder.index_counts:
        return None
    counts = stream.encoder_counts[encoder.name]
    edges = stream.pulse_times.get(pulse.name, np.empty(0))
    drops = np.flatnonzero(np.diff(counts) < -0.5 * encoder.index_counts)
    edges = edges[edges * stream.fs > drops[0] + 1]
    if not edges.size:
        return None
    at = counts[np.minimum(np.round(edges * stream.fs).astype(int), counts.size - 1)]
    mean = np.mean(np.exp(2j * np.pi * at / encoder.index_counts))
    return float(np.mod(np.angle(mean), 2.0 * np.pi))

