"""A commented scene skeleton from a lab's own data files (``rigval init``).

:func:`guess_streams` reads each file and guesses, per stream, the device profile (from the file
format, gaps, rates and units) and, per channel, what it is: an encoder (integer counts), a
reference pulse (two levels, short high or low phases) or a sensor whose kind follows from its
unit and name (``V/V`` bridge ratios: torsion, strain or load-cell bridges; volts: accelerometers
or a linear transducer; already-scaled units: ``physical``). :func:`skeleton_text` writes the
scene: streams, channels with units and rates, the alignment block with the channels that look
like pulses and encoders, the model block and one comparison per sensor channel. Whatever the
files cannot tell (gauge factors, diameters, the angle of a driver at the reference pulse, which
model quantity a channel measures) is written as ``"TODO"`` with a comment saying what is
needed; :func:`rigval.validation.scene.load_scene` refuses a scene until every TODO is filled.
Every TODO sits on its own ``key = "TODO"`` line, so :func:`fill_todos` can fill them from a
script (key path -> value).

``angle_at_reference`` help (:func:`law_angles_at_reference`): with a mechanism, each driver's
angle at the instant the main driver's law passes its ``theta0`` (where the reference pulse
fires when the mechanism file's drive laws start at the reference position), shown in the
skeleton's comments and printed by ``rigval init``.
"""

from __future__ import annotations

import dataclasses
import json
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
from rigval.acquisition.errors import ConfigError, UnitError
from rigval.acquisition.reader import read
from rigval.acquisition.units import dimension, factor_or_none
from rigval.validation.scene import SCHEMA, TODO

__all__ = ["ChannelGuess", "StreamGuess", "classify_channel", "fill_todos", "guess_streams",
           "law_angles_at_reference", "skeleton_text"]

logger = logging.getLogger(__name__)

#: Largest fraction of a pulse channel's samples between 25 % and 75 % of its range.
PULSE_MID_FRACTION = 0.02
#: Largest fraction of a pulse channel's samples in its less frequent level.
PULSE_DUTY = 0.35

_BRIDGE_UNITS = ("V/V", "mV/V")
#: Name fragments of transducers in volts and the unit they suggest.
_NAME_UNITS = (("torque", "N m"), ("tor", "N m"), ("force", "N"), ("load", "N"),
               ("press", "Pa"), ("acc", "m s-2"), ("disp", "m"), ("pos", "m"))


@dataclass(frozen=True)
class ChannelGuess:
    """What a channel looks like.

    Attributes
    ----------
    name : str
        Scene name (the file's channel name with characters other than letters, digits and
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
        Reader options (``group``; ``timezone`` as TODO when the file's times have no zone).
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

    @property
    def duration_s(self) -> float:
        """Recorded duration, s."""
        return self.samples / self.fs

    def of_role(self, role: str) -> list[ChannelGuess]:
        """Channels of a role, in file order."""
        return [c for c in self.channels if c.role == role]


def _scene_name(text: str) -> str:
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
    scene = _scene_name(name)
    lower = name.lower()
    finite = values[np.isfinite(values)]
    integer = finite.size > 0 and bool(np.all(finite == np.round(finite)))
    two_level = integer and np.unique(finite).size == 2
    if units in ("1", "") and integer and not two_level:
        steps = np.diff(finite)
        resets = int(np.sum(steps < -0.5 * (finite.max() - finite.min())))
        index = int(finite.max()) + 1 if resets and finite.min() >= 0 else 0
        span = float(_unwrap(finite, index)[-1] - finite[0]) if finite.size else 0.0
        moved = "" if span else "; it never counts in this file"
        reloads = f"; {resets} reloads to 0 (index pulse)" if index else ""
        return ChannelGuess(scene, name, units, "encoder", "encoder",
                            f"integer counts without a unit (a counter){moved}{reloads}",
                            counts_span=span, index_counts=index), np.empty(0)
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
    if units in _BRIDGE_UNITS:
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
    ratio_only = all(c.units in _BRIDGE_UNITS for c in channels) and bool(channels)
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
    names = [_scene_name(s[len(prefix):] or s) for s in stems]
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
            name = base if len(streams) == 1 else f"{base}_{_scene_name(label)}"
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
    if "timezone" in str(ds.attrs.get("time_fallbacks", "")):
        reader["timezone"] = TODO
    gaps = int(ds.attrs.get("gap_count", 0))
    device, why = _device(fmt, gaps, fs, channels)
    logger.debug("stream %s of %s (#%d): %s, %d channels", name, path, index, device,
                 len(channels))
    return StreamGuess(name, path, fmt, reader, fs, int(time.size),
                       str(ds.attrs.get("start_time", "")), gaps, device, why, tuple(channels),
                       pulses, counts)


def law_angles_at_reference(mechanism: Any) -> dict[str, float]:
    """Each driver's law angle (rad, in [0, 2 pi)) when the main driver passes its ``theta0``.

    The estimate of ``angle_at_reference`` when the main reference pulse fires at the main
    driver's law origin (the rig's reference position is the mechanism file's t = 0 position);
    check it against the rig.

    Parameters
    ----------
    mechanism : rigval.model.Mechanism
        The mechanism (its first driver is the main one).
    """
    if not mechanism.drivers:
        return {}
    main = mechanism.drivers[0]
    t_ref = main.times_at(np.array([main.theta0]))
    return {d.name: float(np.mod(d.motion(t_ref)[0][0], 2.0 * math.pi))
            for d in mechanism.drivers}


# ---------------------------------------------------------------------------------------------
# writing


def _toml(value: Any) -> str:
    """Return the TOML literal of a str, bool, int, float or list of them."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        if isinstance(value, float) and not math.isfinite(value):
            raise ConfigError(f"not a finite number: {value!r}")
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    raise ConfigError(f"cannot write {value!r} as a TOML value")


class _Writer:
    def __init__(self) -> None:
        self.lines: list[str] = []

    def line(self, text: str = "") -> None:
        self.lines.append(text)

    def key(self, name: str, value: Any, comment: str = "") -> None:
        text = f"{name} = {_toml(value)}"
        self.lines.append(f"{text:<38} # {comment}" if comment else text)

    def todo(self, name: str, comment: str) -> None:
        self.key(name, TODO, comment)


_SENSOR_TODO: Mapping[str, tuple[tuple[str, str], ...]] = {
    "charge_accelerometer": (
        ("charge_sensitivity", "pC/g, calibration certificate (an IEPE sensor instead: "
                               'sensor = "iepe_accelerometer", sensitivity in mV/g)'),
        ("amplifier_gain", "V/pC, charge amplifier setting"),
        ("highpass_hz", "Hz, the charge amplifier's high-pass corner")),
    "strain_bridge": (
        ("bridge", "quarter_I, quarter_II, half_I, half_II, full_I, full_II or full_III"),
        ("gauge_factor", "from the gauge pack"),
        ("youngs_modulus", "Pa, to compare stress; delete the line to compare strain")),
    "torsion_bridge": (
        ("bridge", '"full" or "half" (two +-45 degree rosettes)'),
        ("gauge_factor", "from the gauge pack"),
        ("outer_diameter", "m, shaft outer diameter at the gauges"),
        ("inner_diameter", "m, bore (0 for a solid shaft)"),
        ("shear_modulus", "Pa, e.g. 8.0e10 for steel")),
    "load_cell": (
        ("sensitivity", "mV/V, rated output (calibration certificate)"),
        ("capacity", "N, rated capacity")),
    "linear": (
        ("slope", "output units per input unit (transducer datasheet)"),
        ("units", "UDUNITS output unit, e.g. \"N m\", \"N\", \"Pa\"")),
    "physical": (("units", "UDUNITS unit of the values as stored"),),
}


def _channel_table(w: _Writer, stream: StreamGuess, channel: ChannelGuess,
                   main_cpr: int | None) -> None:
    w.line(f"[streams.{stream.name}.channels.{channel.name}]")
    w.key("source", channel.source, f"unit in the file: {channel.units or '-'!r}, "
                                    f"{stream.fs:.9g} S/s")
    if (channel.units in _BRIDGE_UNITS and stream.device != "WLS-9163"
            and rate_divider(MODULES["NI 9237"], stream.fs) is not None):
        w.key("module", "NI 9237", "bridge ratios at a 50 kS/s / n rate: input delay removed")
    w.key("sensor", channel.sensor, f"guessed: {channel.reason}")
    if channel.sensor == "encoder":
        if channel.index_counts:
            w.key("index_reset", True, f"the counts fall back to 0 every {channel.index_counts} "
                                       "counts: the index pulse reloads the counter")
        if main_cpr:
            w.todo("counts_per_rev", f"after x4 decoding; {main_cpr} counts per main-shaft "
                                     "revolution in this file")
        else:
            w.todo("counts_per_rev", "after x4 decoding (encoder datasheet)")
        return
    if channel.sensor == "reference_pulse":
        return
    if channel.sensor == "physical" and channel.units:
        try:
            dimension(channel.units)
            w.key("units", channel.units, "as stored in the file")
            return
        except UnitError:
            pass
    scaled = re.fullmatch(r"\s*([0-9.]+(?:[eE][-+]?\d+)?)\s+(.+)", channel.units)
    if channel.sensor == "linear" and scaled and scaled.group(2) == channel.output_units:
        w.key("slope", float(scaled.group(1)), f"{channel.units!r} is {scaled.group(1)} "
                                               f"{scaled.group(2)!r}")
        w.key("units", channel.output_units)
        w.key("input_units", channel.units, "as stored in the file")
        return
    for name, comment in _SENSOR_TODO.get(channel.sensor, ()):
        if name == "units" and channel.output_units:
            w.key(name, channel.output_units, "guessed from the channel's name")
        else:
            w.todo(name, comment)
    if channel.sensor == "charge_accelerometer":
        w.key("correct_highpass", True, "undo the amplifier's high-pass (phase at 1 Hz)")
    if channel.sensor == "linear" and channel.units != "V":
        w.key("input_units", channel.units, "the unit the slope is per")
    if channel.sensor in ("strain_bridge", "torsion_bridge", "load_cell") \
            and channel.units not in _BRIDGE_UNITS:
        w.todo("excitation", "V, bridge excitation (the channel holds volts)")


def _unwrap(counts: np.ndarray, index_counts: int) -> np.ndarray:
    """Return the counts with the index reloads undone (``index_counts`` per turn; 0: none)."""
    if not index_counts or counts.size < 2:
        return counts
    drops = np.diff(counts) < -0.5 * index_counts
    return counts + index_counts * np.concatenate([[0], np.cumsum(drops)])


def _encoder(stream: StreamGuess, name: str) -> ChannelGuess:
    return next(c for c in stream.channels if c.name == name)


def _counts_per_pulse(stream: StreamGuess, encoder: str, pulse: str) -> int | None:
    """Median count increment between consecutive pulses (same stream), or None."""
    edges = stream.pulse_times.get(pulse)
    counts = stream.encoder_counts.get(encoder)
    if edges is None or counts is None or edges.size < 2:
        return None
    counts = _unwrap(counts, _encoder(stream, encoder).index_counts)
    time = np.arange(counts.size) / stream.fs
    steps = np.abs(np.diff(np.interp(edges, time, counts)))
    value = float(np.median(steps))
    return round(value) if value >= 1 else None


_QUANTITY_BY_UNIT = (("m s-2", "point_acceleration", "point"),
                     ("N m", "driver_torque", "driver"),
                     ("N", "joint_force", "joint"),
                     ("Pa", "joint_force", "joint"),
                     ("1", "joint_force", "joint"))


def skeleton_text(streams: Sequence[StreamGuess], scene_path: str | os.PathLike[str],
                  mechanism: str | None = None) -> tuple[str, list[str]]:
    """Return the scene skeleton text and the lines ``rigval init`` prints.

    Parameters
    ----------
    streams : sequence of StreamGuess
        From :func:`guess_streams`.
    scene_path : path-like
        Where the scene will be written (data file paths are written relative to its folder).
    mechanism : str, optional
        ``builtin:NAME`` or a mechanism file; None writes it as TODO.

    Returns
    -------
    text : str
        The TOML text.
    notes : list of str
        The guesses and estimates, one line each.
    """
    from rigval.processing.sensors import SENSOR_UNITS

    scene_dir = Path(scene_path).resolve().parent
    mech = _mechanism(mechanism, scene_dir)
    notes: list[str] = []
    w = _Writer()
    names = [s.file.name for s in streams]
    w.line("# Scene skeleton written by rigval init from " + ", ".join(dict.fromkeys(names)))
    w.line("# Values marked TODO are what the files cannot tell; rigval validate refuses the")
    w.line("# scene until each is filled. Every key: docs/scene.md.")
    w.key("schema", SCHEMA)
    w.key("title", "Run " + ", ".join(dict.fromkeys(Path(n).stem for n in names)))
    if mech is None:
        w.todo("mechanism", '"builtin:pendulum" or the mechanism file (docs/mechanism.md)')
    else:
        w.key("mechanism", mech[0])
    w.line()
    reference = _reference(streams)
    main_encoder = reference.of_role("encoder")[0] if reference and reference.of_role(
        "encoder") else None
    main_pulse = reference.of_role("pulse")[0] if reference and reference.of_role(
        "pulse") else None
    placeholders: dict[str, str] = {}
    for stream in streams:
        w.line(f"[streams.{stream.name}]")
        w.key("file", Path(os.path.relpath(stream.file.resolve(), scene_dir)).as_posix(),
              f"{stream.format}, {stream.samples} samples at {stream.fs:.9g} S/s, "
              f"start {stream.start_time}")
        w.key("device", stream.device, f"guessed: {stream.device_reason}")
        for option, value in stream.reader.items():
            if value == TODO:
                w.todo(f"reader.{option}", "the file's times have no zone: e.g. "
                                           '"Europe/Berlin", or "UTC"')
            else:
                w.key(f"reader.{option}", value)
        notes.append(f"stream {stream.name}: {stream.file.name}, {stream.fs:.9g} S/s, "
                     f"{stream.duration_s:.4g} s, device {stream.device} "
                     f"({stream.device_reason})")
        w.line()
        for channel in stream.channels:
            cpr = (_counts_per_pulse(reference, channel.name, main_pulse.name)
                   if stream is reference and main_pulse and channel.role == "encoder"
                   else None)
            _channel_table(w, stream, channel, cpr)
            w.line()
            notes.append(f"  {channel.name}: {channel.units or '-'} -> {channel.sensor} "
                         f"({channel.reason})")
        if not stream.of_role("pulse") and (stream is reference
                                            or stream.device == "WLS-9163"):
            placeholders[stream.name] = "reference_pulse"
            w.line("# No channel of this file looks like a once-per-revolution pulse, which the")
            w.line("# alignment needs: name the file channel that carries it.")
            w.line(f"[streams.{stream.name}.channels.reference_pulse]")
            w.todo("source", "the pulse channel's name in the file")
            w.key("sensor", "reference_pulse")
            w.line()
    _alignment(w, streams, reference, main_encoder, main_pulse, placeholders, notes)
    w.line("[angle]")
    w.key("points_per_revolution", 360, "comparison grid: 1 degree")
    w.key("interpolation", "cubic")
    w.key("min_cycles", 3)
    w.line()
    _model(w, reference, mech, notes, main_pulse)
    units_of = {(s.name, c.name): SENSOR_UNITS[c.sensor]({
        "units": c.output_units if c.sensor == "linear" else c.units, "youngs_modulus": TODO})
                for s in streams for c in s.channels if c.role == "sensor"
                and c.sensor in SENSOR_UNITS}
    _comparisons(w, streams, units_of, mech)
    return "\n".join(w.lines).rstrip() + "\n", notes


def _mechanism(mechanism: str | None, scene_dir: Path) -> tuple[str, Any] | None:
    """Return the mechanism as written in the scene and the loaded mechanism, or None."""
    if mechanism is None:
        return None
    from rigval.model.mechanism import BUILTIN_PREFIX, load_mechanism, mechanism_file

    if mechanism.startswith(BUILTIN_PREFIX):
        return mechanism, load_mechanism(mechanism_file(mechanism))
    path = mechanism_file(mechanism).resolve()
    return Path(os.path.relpath(path, scene_dir)).as_posix(), load_mechanism(path)


def _reference(streams: Sequence[StreamGuess]) -> StreamGuess | None:
    """Return the stream with an encoder and a pulse, else one with an encoder, else the first."""
    for want in (("encoder", "pulse"), ("encoder",)):
        for stream in streams:
            if all(stream.of_role(r) for r in want):
                return stream
    return streams[0] if streams else None


def _alignment(w: _Writer, streams: Sequence[StreamGuess], reference: StreamGuess | None,
               encoder: ChannelGuess | None, pulse: ChannelGuess | None,
               placeholders: Mapping[str, str], notes: list[str]) -> None:
    w.line("[alignment]")
    if reference is None:
        return
    w.key("reference", reference.name, "the stream whose clock is the timeline")
    if encoder is None:
        w.todo("main_encoder", f"no counter in {reference.name}: the main-shaft encoder as "
                               "stream.channel")
    else:
        w.key("main_encoder", f"{reference.name}.{encoder.name}", "guessed: first counter")
    pulse_name = pulse.name if pulse else placeholders.get(reference.name)
    w.key("main_reference_pulse", f"{reference.name}.{pulse_name}",
          "phi_F = 0 at its rising edge")
    main_rate = (reference.pulse_times[pulse.name].size / reference.duration_s
                 if pulse else None)
    w.line()
    for stream in streams:
        if stream is reference:
            continue
        own = stream.of_role("pulse")
        w.line(f"[alignment.pulses.{stream.name}]")
        if not own and stream.name not in placeholders:
            w.key("method", "stamps", "no pulse channel: aligned by the start stamps, as on one "
                                      "chassis; a pulse channel gives a fitted clock")
            notes.append(f"stream {stream.name}: no pulse channel, aligned by its start stamp "
                         '(method = "stamps")')
            w.line()
            continue
        channel = own[0].name if own else placeholders[stream.name]
        w.key("channel", channel)
        rate = stream.pulse_times[own[0].name].size / stream.duration_s if own else None
        if rate and main_rate:
            per_rev = max(1, round(rate / main_rate))
            w.key("per_revolution", per_rev, f"estimated: {rate:.4g} pulses/s here, "
                                             f"{main_rate:.4g}/s on the main pulse")
            notes.append(f"pulses of {stream.name}.{channel}: {per_rev} per revolution "
                         "(estimated from the pulse rates)")
        else:
            w.todo("per_revolution", "pulses per main-shaft revolution")
        w.todo("angle", "rad, phi_F at which this sensor fires (0 when it sits with the main "
                        "reference sensor)")
        w.line()


def _past_index(stream: StreamGuess, encoder: ChannelGuess, pulse: ChannelGuess | None
                ) -> float | None:
    """Angle (rad) from an index-reset encoder's index to the reference pulse, or None.

    The counts at the pulse edges after the first reload, as angles on the circle of
    ``index_counts``, averaged on the circle.
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


def _model(w: _Writer, reference: StreamGuess | None, mech: tuple[str, Any] | None,
           notes: list[str], main_pulse: ChannelGuess | None = None) -> None:
    w.line("[model]")
    encoders = reference.of_role("encoder") if reference else []
    if mech is None:
        w.key("drives", "analytic", '"measured" when an encoder measures every driver')
        w.line()
        return
    mechanism = mech[1]
    drivers = mechanism.drivers
    if not drivers or len(encoders) < len(drivers):
        w.key("drives", "analytic", f"{len(encoders)} encoder(s) on the reference stream for "
                                    f"{len(drivers)} driver(s): the mechanism file's laws")
        w.line()
        return
    w.key("drives", "measured", "every driver follows its encoder")
    w.line()
    estimates = law_angles_at_reference(mechanism)
    for driver, encoder in zip(drivers, encoders, strict=False):
        w.line(f"[model.drivers.{driver.name}]")
        w.key("encoder", f"{reference.name}.{encoder.name}",  # type: ignore[union-attr]
              "guessed in file order: check")
        estimate = estimates[driver.name]
        w.todo("angle_at_reference", f"rad; from the drive law: {estimate:.6g} (if the "
                                     "reference pulse fires at the law's start position)")
        notes.append(f"angle_at_reference of {driver.name}: {estimate:.6g} rad from the drive "
                     f"law of {Path(mechanism.source).name} (the angle when "
                     f"{drivers[0].name} passes theta0); check against the rig")
        past_index = _past_index(reference, encoder, main_pulse)
        if past_index is not None:
            w.line(f"# {encoder.name} reloads at its index: the reference pulse fires "
                   f"{past_index:.6g} rad (in counting direction) past the index, so "
                   "angle_at_reference = the driver's angle at the index + direction x "
                   f"{past_index:.6g}")
            notes.append(f"angle_at_reference of {driver.name}: its angle at the index of "
                         f"{encoder.name} + direction x {past_index:.6g} rad (from the counts at "
                         "the reference pulses)")
        trend = encoder.counts_span
        direction = -1 if trend * driver.omega < 0 else 1
        w.key("direction", direction, "from the counts' trend and the law's speed"
              if trend else "the counts do not move in this file: check")
        w.line()


def _comparisons(w: _Writer, streams: Sequence[StreamGuess],
                 units_of: Mapping[tuple[str, str], str], mech: tuple[str, Any] | None) -> None:
    names = {}
    if mech is not None:
        m = mech[1]
        names = {"point": m.point_names, "joint": m.joint_names, "driver": m.driver_names,
                 "body": m.body_names}
    for stream in streams:
        for channel in stream.of_role("sensor"):
            units = units_of.get((stream.name, channel.name), "")
            w.line("[[comparisons]]")
            w.key("name", channel.name)
            w.key("measured", f"{stream.name}.{channel.name}")
            match = next((q for q in _QUANTITY_BY_UNIT if q[0] == units), None)
            if match is None:
                w.todo("model.quantity", "point_acceleration, joint_force, driver_torque, ... "
                                         "(docs/scene.md)")
                w.todo("model.item", "the point, joint, body or driver")
            else:
                _, quantity, kind = match
                w.key("model.quantity", quantity, f"guessed from the unit {units!r}")
                listed = ", ".join(names.get(kind, ())) or f"the {kind}"
                w.todo("model.item", f"one of: {listed}")
                if quantity == "driver_torque":
                    w.todo("scale", "the share of the driver torque this shaft carries (0.5 "
                                    "for one of two equal shafts)")
                else:
                    w.todo("model.axis", '"x" or "y"')
                if units in ("Pa", "1"):
                    w.todo("scale", "-1/A (A the cross-section, m2) for stress; -1/(E A) for "
                                    "strain")
                    w.key("scale_units", "m-2" if units == "Pa" else "N-1")
            if units == "m s-2":
                w.key("remove_offset", True, "an accelerometer's zero is unknown")
            w.key("uncertainty.u_measurement_rel", 0.02,
                  "sensor calibration (fraction), part of V&V 20 u_val: state yours")
            w.key('thresholds."vv20.curve.normalised_error"', "<= 2",
                  "fails when a model error is detected (|E| > 2 u_val)")
            w.line()
    if not any(s.of_role("sensor") for s in streams):
        w.line("# No channel to compare was found; add [[comparisons]] tables.")


def fill_todos(text: str, values: Mapping[str, Any]) -> str:
    """Replace the TODO values of a skeleton by key path.

    Parameters
    ----------
    text : str
        Scene text written by :func:`skeleton_text` (each TODO on its own ``key = "TODO"`` line).
    values : mapping of str to value
        Key path (``streams.cdaq.channels.str1.gauge_factor``, ``comparisons[0].model.item``)
        to its value (str, number, bool or list).

    Returns
    -------
    str
        The text with those values; comments kept. TODOs not in ``values`` stay.

    Raises
    ------
    ConfigError
        For a key path that is not a TODO of the text (naming it).
    """
    header = ""
    counts: dict[str, int] = {}
    done: set[str] = set()
    lines = []
    assignment = re.compile(r'^(\s*)([A-Za-z0-9_.\-]+)(\s*=\s*)"TODO[^"]*"(.*)$')
    for line in text.splitlines():
        stripped = line.strip()
        if stripped.startswith("[[") and stripped.endswith("]]"):
            table = stripped[2:-2].strip()
            counts[table] = counts.get(table, -1) + 1
            header = f"{table}[{counts[table]}]"
        elif stripped.startswith("[") and stripped.endswith("]"):
            header = stripped[1:-1].strip()
        match = assignment.match(line)
        if match:
            key = f"{header}.{match.group(2)}" if header else match.group(2)
            if key in values:
                line = f"{match.group(1)}{match.group(2)}{match.group(3)}" \
                       f"{_toml(values[key])}{match.group(4)}"
                done.add(key)
        lines.append(line)
    unknown = sorted(set(values) - done)
    if unknown:
        raise ConfigError(f"{unknown[0]}: not a TODO of the skeleton", where={"key": unknown[0]},
                          hint="TODO keys: use the key paths rigval validate lists")
    return "\n".join(lines) + ("\n" if text.endswith("\n") else "")
