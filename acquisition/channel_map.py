"""The channel map of a scene: which file a stream comes from and which channel is which sensor.

A scene's ``[streams.X]`` table (``docs/scene.md``) names a data file, its device and reader
options, and in ``[streams.X.channels.NAME]`` the sensors with their calibration. This module
parses such a table (a plain ``dict`` from :mod:`tomllib`) into frozen dataclasses, checking every
key and value; each error is a :class:`~rigval.acquisition.errors.ChannelMapError` whose ``where``
names the key path (``streams.cdaq.channels.acc1.charge_sensitivity``).

:func:`load_stream` then reads the stream with :func:`~rigval.acquisition.reader.read_stream`,
keeps the mapped channels under their scene names and records the sensor and its parameters in
each channel's attributes (``sensor``, ``scene_key``, ``sensor_params`` naming the parameters and
one ``sensor_<param>`` attribute per parameter, see :func:`sensor_attrs`).

Sensor kinds and parameters (required ones marked ``*``; units in brackets):

=====================  =================================================================
sensor                 parameters
=====================  =================================================================
charge_accelerometer   charge_sensitivity* [pC/g], amplifier_gain* [V/pC],
                       highpass_hz [Hz], correct_highpass (bool, default false)
strain_bridge          bridge* (quarter_I, quarter_II, half_I, half_II, full_I, full_II,
                       full_III), gauge_factor*, excitation [V], gauge_resistance [ohm]
                       (120), lead_resistance [ohm] (0), poisson (0.3),
                       youngs_modulus [Pa], null_offset ("none" | "first_second")
torsion_bridge         bridge* ("full" | "half"), gauge_factor*, excitation [V],
                       outer_diameter* [m], inner_diameter [m] (0), shear_modulus* [Pa],
                       null_offset ("none" | "first_second")
encoder                counts_per_rev* (int, after x4 decoding), index_reset (bool, default
                       false: the index pulse Z resets the counter)
reference_pulse        threshold [V] (default: 50 % of the range), edge ("rising" | "falling")
voltage                none (the channel is used in volts)
physical               units* (UDUNITS string of the already-scaled values)
linear                 slope* [units per input_units], offset [units] (0), units* (UDUNITS
                       output unit), input_units ("V": the unit the slope is per)
iepe_accelerometer     sensitivity* [mV/g]
load_cell              sensitivity* [mV/V rated output], capacity* [N], excitation [V],
                       null_offset ("none" | "first_second")
=====================  =================================================================

Every channel also accepts ``source`` (the channel name in the file; default the table name),
``module`` (``"NI 9237"``: overrides the device's module for the input delay) and
``description``.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np
import xarray as xr

from rigval.acquisition.devices import DEVICES, MODULES, get_device, get_module
from rigval.acquisition.errors import ChannelMapError, ChannelNotFoundError, ConfigError
from rigval.acquisition.tables import TableReader, key_path

__all__ = ["SENSORS", "ChannelSpec", "StreamSpec", "load_stream", "parse_stream",
           "parse_streams", "sensor_attrs"]

_TABLES = TableReader(ChannelMapError, docs="docs/scene.md")
_COMMON = {"source", "sensor", "module", "description"}
_STREAM_KEYS = {"file", "device", "reader", "channels", "description"}


@dataclass(frozen=True)
class _Param:
    """Rule for one sensor parameter."""

    kind: str  # "positive", "nonnegative", "number", "bool", "int", "choice", "text"
    required: bool = False
    default: Any = None
    choices: tuple[str, ...] = ()
    #: plausible range of a number's magnitude, in the parameter's unit (docs/scene.md, Ranges)
    low: float = 0.0
    high: float = 1e15
    unit: str = ""


_NULL = _Param("choice", default="none", choices=("none", "first_second"))

#: Sensor kind -> parameter name -> rule.
SENSORS: Mapping[str, Mapping[str, _Param]] = MappingProxyType({
    "charge_accelerometer": {
        "charge_sensitivity": _Param("positive", True, low=1e-4, high=1e5, unit="pC/g"),
        "amplifier_gain": _Param("positive", True, low=1e-6, high=1e3, unit="V/pC"),
        "highpass_hz": _Param("nonnegative", high=1e6, unit="Hz"),
        "correct_highpass": _Param("bool", default=False),
    },
    "strain_bridge": {
        "bridge": _Param("choice", True, choices=("quarter_I", "quarter_II", "half_I", "half_II",
                                                  "full_I", "full_II", "full_III")),
        "gauge_factor": _Param("positive", True, low=0.1, high=500.0),
        "excitation": _Param("positive", low=1e-3, high=100.0, unit="V"),
        "gauge_resistance": _Param("positive", default=120.0, low=1.0, high=1e6, unit="ohm"),
        "lead_resistance": _Param("nonnegative", default=0.0, high=1e4, unit="ohm"),
        "poisson": _Param("nonnegative", default=0.3, high=0.5),
        "youngs_modulus": _Param("positive", low=1e5, high=2e12, unit="Pa"),
        "null_offset": _NULL,
    },
    "torsion_bridge": {
        "bridge": _Param("choice", True, choices=("full", "half")),
        "gauge_factor": _Param("positive", True, low=0.1, high=500.0),
        "excitation": _Param("positive", low=1e-3, high=100.0, unit="V"),
        "outer_diameter": _Param("positive", True, low=1e-4, high=100.0, unit="m"),
        "inner_diameter": _Param("nonnegative", default=0.0, high=100.0, unit="m"),
        "shear_modulus": _Param("positive", True, low=1e5, high=1e12, unit="Pa"),
        "null_offset": _NULL,
    },
    "encoder": {"counts_per_rev": _Param("int", True, high=1e9),
                "index_reset": _Param("bool", default=False)},
    "reference_pulse": {
        "threshold": _Param("number", high=1e6),
        "edge": _Param("choice", default="rising", choices=("rising", "falling")),
    },
    "voltage": {},
    "physical": {"units": _Param("text", True)},
    "linear": {"slope": _Param("number", True, low=1e-15, high=1e15),
               "offset": _Param("number", default=0.0, high=1e15),
               "units": _Param("text", True), "input_units": _Param("text", default="V")},
    "iepe_accelerometer": {"sensitivity": _Param("positive", True, low=1e-3, high=1e6,
                                                 unit="mV/g")},
    "load_cell": {"sensitivity": _Param("positive", True, low=1e-3, high=1e3, unit="mV/V"),
                  "capacity": _Param("positive", True, low=1e-3, high=1e10, unit="N"),
                  "excitation": _Param("positive", low=1e-3, high=100.0, unit="V"),
                  "null_offset": _NULL},
})


@dataclass(frozen=True)
class ChannelSpec:
    """One mapped channel: a physical channel named as a sensor with its calibration.

    Attributes
    ----------
    name : str
        Name in the scene (``acc1``); the variable name after :func:`load_stream`.
    source : str
        Channel name in the file (TDMS channel, CSV/LVM column).
    sensor : str
        Sensor kind (a key of :data:`SENSORS`).
    params : mapping
        Validated parameters with defaults filled in (read-only), in the units of the table in
        the module docstring.
    module : str or None
        Module override (``"NI 9237"``).
    description : str
        Free text.
    key : str
        Key path of the table (``streams.cdaq.channels.acc1``).
    """

    name: str
    source: str
    sensor: str
    params: Mapping[str, Any]
    module: str | None
    description: str
    key: str


@dataclass(frozen=True)
class StreamSpec:
    """One stream of a scene: a data file, its device, reader options and channel map.

    Attributes
    ----------
    name : str
        Stream name in the scene (``cdaq``).
    file : pathlib.Path
        Data file (relative paths resolved against the ``base_dir`` given to the parser).
    device : str or None
        Device profile name.
    reader : mapping
        Reader options passed to :func:`~rigval.acquisition.reader.read` (read-only).
    channels : mapping
        Scene channel name -> :class:`ChannelSpec` (read-only, in table order).
    key : str
        Key path of the table (``streams.cdaq``).
    """

    name: str
    file: Path
    device: str | None
    reader: Mapping[str, Any]
    channels: Mapping[str, ChannelSpec]
    key: str

    def channel(self, name: str) -> ChannelSpec:
        """Return a mapped channel by scene name.

        Raises
        ------
        ChannelNotFoundError
            Listing the mapped channels.
        """
        try:
            return self.channels[name]
        except KeyError:
            raise ChannelNotFoundError(f"stream {self.name!r} maps no channel {name!r}",
                                       where={"key": f"{self.key}.channels"},
                                       available=list(self.channels)) from None


def _check_value(value: Any, rule: _Param, key: str) -> Any:
    """Validate one parameter value; return it normalised (floats for numbers)."""
    def fail(expected: str) -> ConfigError:
        return _TABLES.fail(key, f"must be {expected}, got {value!r}",
                            hint="write the sensor's calibration value in SI units (docs/scene.md "
                                 "lists each sensor's keys)")

    if rule.kind == "bool":
        if not isinstance(value, bool):
            raise fail("true or false")
        return value
    if rule.kind == "text":
        if not isinstance(value, str) or not value.strip():
            raise fail("a non-empty string")
        return value
    if rule.kind == "choice":
        if value not in rule.choices:
            raise fail("one of " + ", ".join(repr(c) for c in rule.choices))
        return value
    if rule.kind == "int":
        if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
            raise fail("a positive integer")
        if value > rule.high:
            raise fail(f"at most {rule.high:g}")
        return value
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise fail("a finite number")
    if rule.kind == "positive" and value <= 0:
        raise fail("positive")
    if rule.kind == "nonnegative" and value < 0:
        raise fail("zero or positive")
    if not (value == 0 and rule.kind != "positive") and not rule.low <= abs(value) <= rule.high:
        unit = f" {rule.unit}" if rule.unit else ""
        raise _TABLES.fail(key, f"{value!r}{unit} is outside the plausible range "
                           f"{rule.low:g} to {rule.high:g}{unit}"
                           + (" in magnitude" if rule.kind == "number" else ""),
                           hint="check the unit and the digits against the calibration sheet "
                                "(docs/scene.md lists each sensor's keys and ranges)")
    return float(value)


def _parse_channel(name: str, table: Any, key: str) -> ChannelSpec:
    """Parse one ``[streams.X.channels.NAME]`` table."""
    table = _TABLES.table(table, key)
    sensor = _TABLES.get(table, "sensor", key, str, choices=tuple(SENSORS),
                         hint="give the channel's sensor kind (docs/scene.md, [streams])")
    rules = SENSORS[sensor]
    _TABLES.check_keys(table, key, _COMMON | set(rules),
                       [p for p, rule in rules.items() if rule.required],
                       what=f"for a {sensor} channel")
    params: dict[str, Any] = {}
    for param, rule in rules.items():
        if param in table:
            params[param] = _check_value(table[param], rule, f"{key}.{param}")
        elif rule.default is not None:
            params[param] = rule.default
    if sensor == "torsion_bridge" and params["inner_diameter"] >= params["outer_diameter"]:
        raise _TABLES.fail(f"{key}.inner_diameter", "must be smaller than outer_diameter "
                           f"({params['inner_diameter']} >= {params['outer_diameter']} m)")
    if sensor == "linear" and params["slope"] == 0:
        raise _TABLES.fail(f"{key}.slope", "must be non-zero (output units per input unit)")
    source = _TABLES.text(table.get("source", name), f"{key}.source")
    module = _known(table, "module", key, get_module, MODULES)
    description = _TABLES.get(table, "description", key, str, "")
    return ChannelSpec(name, source, sensor, MappingProxyType(params), module, str(description),
                       key)


def _known(table: Mapping[str, Any], name: str, key: str,
           lookup: Callable[[str], Any], known: Iterable[str]) -> str | None:
    """Return the canonical name of a device or module named at ``key.name`` (None if absent)."""
    value = table.get(name)
    if value is None:
        return None
    try:
        return str(lookup(str(value)).name)
    except ChannelNotFoundError:
        raise _TABLES.fail(key_path(key, name), f"unknown {name} {value!r}",
                           hint="known: " + ", ".join(known)) from None


def _check_reader_options(reader: Mapping[str, Any], path: Path, key: str) -> None:
    """Refuse reader options no reader knows (the file's format's reader when it exists)."""
    from rigval.acquisition.detect import FORMATS, detect_format
    from rigval.acquisition.errors import DataFileError
    from rigval.acquisition.reader import reader_options

    kind = None
    if path.is_file():
        try:
            kind = detect_format(path)
        except DataFileError:
            kind = None  # reported when the stream is read
    known = reader_options(kind)
    unknown = sorted(set(reader) - known)
    if not unknown:
        return
    if kind is None:
        raise _TABLES.fail(f"{key}.{unknown[0]}", "no reader has this option",
                           hint="options: " + ", ".join(sorted(known)))
    others = [other for other in FORMATS
              if other != kind and set(unknown) <= reader_options(other)]
    if others:  # options of another format's reader: the file is likely the wrong one
        stream_key = key.rsplit(".", 1)[0]
        raise _TABLES.fail(f"{stream_key}.file",
                           f"{path.name} is a {kind.upper()} file, but the reader options "
                           f"{', '.join(unknown)} are those of the {' or '.join(others)} reader",
                           hint=f"check that {stream_key}.file names the intended file, or "
                                f"give {kind} reader options: {', '.join(sorted(known))}")
    raise _TABLES.fail(f"{key}.{unknown[0]}", f"the {kind} reader has no such option",
                       hint="options: " + ", ".join(sorted(known)))


def parse_stream(table: Mapping[str, Any], key: str,
                 base_dir: str | os.PathLike[str] | None = None) -> StreamSpec:
    """Parse one ``[streams.X]`` table into a :class:`StreamSpec`.

    Parameters
    ----------
    table : mapping
        The table as :func:`tomllib.load` returns it.
    key : str
        Its key path, ``streams.X``; the last part is the stream name.
    base_dir : str or path-like, optional
        Folder relative file paths are resolved against (the scene file's folder).

    Returns
    -------
    StreamSpec
        The validated stream.

    Raises
    ------
    ChannelMapError
        Naming the key path of the first bad key or value.
    """
    table = _TABLES.check_keys(table, key, _STREAM_KEYS, ["file"],
                               what="in a stream table")
    path = Path(_TABLES.path(table["file"], f"{key}.file"))
    if base_dir is not None and not path.is_absolute():
        path = Path(base_dir) / path
    device = _known(table, "device", key, get_device, DEVICES)
    reader = _TABLES.get(table, "reader", key, dict, {})
    for reserved in ("channels", "device", "time_range"):
        if reserved in reader:
            raise _TABLES.fail(f"{key}.reader.{reserved}",
                               "is set by the scene, not the reader table")
    _check_reader_options(reader, path, f"{key}.reader")
    channels_table = _TABLES.get(table, "channels", key, dict, {})
    channels = {_TABLES.name(name, f"{key}.channels.{name}"):
                _parse_channel(name, sub, f"{key}.channels.{name}")
                for name, sub in channels_table.items()}
    sources = [c.source for c in channels.values()]
    doubled = sorted({s for s in sources if sources.count(s) > 1})
    if doubled:
        raise _TABLES.fail(f"{key}.channels", f"file channel {doubled[0]!r} is mapped twice",
                           hint="map each file channel to one scene channel")
    spec = StreamSpec(key.rsplit(".", 1)[-1], path, device, MappingProxyType(dict(reader)),
                      MappingProxyType(channels), key)
    _check_tdms_sources(spec)
    return spec


def _not_in_file(spec: StreamSpec, error: ChannelNotFoundError) -> ChannelMapError:
    """Return the error naming the key of a group or mapped channel the file does not hold."""
    available = [str(a) for a in error.extra.get("available", [])]
    if error.message.startswith("group "):
        key = f"{spec.key}.reader.group"
        hint = "groups in the file: " + ", ".join(available)
    else:
        missing = [c for c in spec.channels.values() if c.source not in available]
        key = f"{missing[0].key}.source" if missing else spec.key
        hint = "channels in the file: " + ", ".join(available)
    return ChannelMapError(f"{key}: {error.message}", where={**error.where, "key": key},
                           hint=hint)


def _check_tdms_sources(spec: StreamSpec) -> None:
    """Check from a TDMS file's metadata alone that its group and mapped channels are there.

    Before any sample is read, so that a scene naming a channel the file lacks is refused when
    it is loaded. Other formats, absent or damaged files and reader options of the wrong type
    are left to the read, which reports them.
    """
    from rigval.acquisition.detect import detect_format
    from rigval.acquisition.errors import RigvalError
    from rigval.acquisition.tdms_layout import scan_tdms
    from rigval.acquisition.tdms_plan import plan_tdms

    group = spec.reader.get("group")
    if not spec.channels or not (group is None or isinstance(group, str)) \
            or not spec.file.is_file():
        return
    try:
        if detect_format(spec.file) != "tdms":
            return
        plan_tdms(scan_tdms(spec.file), group=group,
                  channels=[c.source for c in spec.channels.values()])
    except ChannelNotFoundError as error:
        raise _not_in_file(spec, error) from None
    except RigvalError:
        return  # a damaged file: reported, with what can be recovered, when it is read


def parse_streams(table: Mapping[str, Any], key: str = "streams",
                  base_dir: str | os.PathLike[str] | None = None) -> dict[str, StreamSpec]:
    """Parse the scene's ``[streams]`` table: stream name -> :class:`StreamSpec`.

    Raises
    ------
    ChannelMapError
        If the table is empty or any stream is invalid (naming the key path).
    """
    if not _TABLES.table(table, key):
        raise _TABLES.fail(key, "must hold at least one stream",
                           hint=f"add a [{key}.NAME] table per data file")
    return {_TABLES.name(name, f"{key}.{name}"): parse_stream(sub, f"{key}.{name}", base_dir)
            for name, sub in table.items()}


def sensor_attrs(params: Mapping[str, Any]) -> dict[str, Any]:
    """Return a sensor's validated parameters as netCDF-storable channel attributes.

    ``sensor_params`` lists the parameter names (strings); each value is the attribute
    ``sensor_<name>``: numbers as they are (SI units, docs/scene.md), text and choices as strings,
    booleans as ``int8`` 0/1 (netCDF has no boolean attribute type).
    """
    attrs: dict[str, Any] = {"sensor_params": list(params)}
    for name, value in params.items():
        attrs[f"sensor_{name}"] = np.int8(value) if isinstance(value, bool) else value
    return attrs


def load_stream(spec: StreamSpec, *, time_range: tuple[float | None, float | None] | None = None,
                checksum: bool = True) -> xr.Dataset:
    """Read a scene stream: the mapped channels under their scene names, with sensor metadata.

    Parameters
    ----------
    spec : StreamSpec
        From :func:`parse_stream`.
    time_range : tuple of float or None, optional
        ``(t_from, t_to)`` in s since the stream's first sample.
    checksum : bool
        Compute ``source_sha256``.

    Returns
    -------
    xarray.Dataset
        The stream; channel ``attrs`` gain ``sensor``, the parameters (:func:`sensor_attrs`),
        ``scene_key`` and, with a module override, ``module``/``input_delay_s``;
        ``attrs["stream"]`` is the scene name.

    Raises
    ------
    ChannelMapError
        A reader option the reader does not know, or a mapped channel missing from the file
        (listing the file's channels).
    DataFileError
        The file cannot be read.
    """
    from rigval.acquisition.reader import read_stream

    modules = {c.source: c.module for c in spec.channels.values() if c.module}
    options = dict(spec.reader)
    if modules:
        options["modules"] = {**dict(options.get("modules", {})), **modules}
    sources = [c.source for c in spec.channels.values()] or None
    try:
        ds = read_stream(spec.file, device=spec.device, channels=sources, time_range=time_range,
                         checksum=checksum, **options)
    except ChannelNotFoundError as error:
        raise _not_in_file(spec, error) from None
    except ChannelMapError:
        raise
    except ConfigError as error:
        raise ChannelMapError(f"{spec.key}.reader: {error.message}",
                         where={**error.where, "key": f"{spec.key}.reader"},
                         hint=error.hint) from None
    rename = {c.source: c.name for c in spec.channels.values() if c.source != c.name}
    ds = ds.rename(rename)
    for channel in spec.channels.values():
        ds[channel.name].attrs.update({
            "sensor": channel.sensor,
            "scene_key": channel.key,
            **sensor_attrs(channel.params),
        })
        if channel.description:
            ds[channel.name].attrs["description"] = channel.description
    ds.attrs["stream"] = spec.name
    return ds
