"""Scene files: one validation case as TOML, parsed into frozen dataclasses.

A scene names the run's data files and their channel maps, how the clocks are aligned, how the
model's drives are excited and what is compared with what (format ``rigval-scene/1``, every key in
``docs/scene.md``). :func:`load_scene` reads and checks a scene; every problem is a
:class:`~rigval.validation.errors.SceneError` whose ``where["key"]`` is the key path, e.g.
``comparisons[2].model.item``. Paths in a scene are relative to the scene file.

The ``[streams.X]`` tables are parsed by :mod:`rigval.acquisition.channel_map` (the channel maps).
Checks made here, before any data is read: files exist; every ``stream.channel`` reference names a
declared channel of the right sensor kind; each sensor has its required calibration keys and no
unknown ones; each comparison's model output exists in the mechanism (quantity, item, axis); the
unit of the converted measured channel equals the unit of the model quantity times
``scale_units``; thresholds parse. Whether each channel exists in its file is checked when the file
is read (:func:`rigval.validation.pipeline.run_scene`), also as a :class:`SceneError`.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import hashlib
import logging
import math
import re
import tomllib
import typing
from collections.abc import Iterator, Mapping
from pathlib import Path
from types import MappingProxyType
from typing import Any

from rigval.acquisition.channel_map import ChannelSpec, StreamSpec, parse_streams
from rigval.acquisition.errors import ChannelMapError, ConfigError, UnitError
from rigval.acquisition.tables import REQUIRED, TableReader
from rigval.acquisition.units import dimension, multiply, parse_unit
from rigval.model.errors import MechanismError
from rigval.model.mechanism import BUILTIN_PREFIX, mechanism_file
from rigval.model.mechanism_names import MechanismNames, mechanism_names
from rigval.model.output_values import ModelOutput
from rigval.processing.sensors import channel_units
from rigval.validation.errors import SceneError
from rigval.validation.metrics.compare import METRICS, score_names
from rigval.validation.metrics.thresholds import parse_threshold
from rigval.validation.note import read_note
from rigval.validation.scene_check import check_mechanism_names
from rigval.validation.scene_types import (
    MODEL_QUANTITIES,
    SCHEMA,
    AlignmentSpec,
    AngleSpec,
    ChannelRef,
    ComparisonSpec,
    DriverSpec,
    ModelSpec,
    OutputSpec,
    PredictionSpec,
    PulseSpec,
    Scene,
    SymmetrySpec,
)

__all__ = ["TODO", "channel_map_as_scene", "load_scene", "parse_scene", "todo_keys", "todo_label"]

logger = logging.getLogger(__name__)


#: Sensor kinds a comparison may measure (encoders and reference pulses serve the alignment).
_MEASURED_SENSORS = ("charge_accelerometer", "strain_bridge", "torsion_bridge", "physical",
                     "voltage", "linear", "iepe_accelerometer", "load_cell")



# ---------------------------------------------------------------------------------------------
# Parsing helpers: each takes the key path for its error messages.


_TABLES = TableReader(SceneError, docs="docs/scene.md")
_error = _TABLES.fail
_table = _TABLES.table
_check_keys = _TABLES.check_keys
_get = _TABLES.get


@functools.cache
def _fields(spec: type) -> Mapping[str, dataclasses.Field[Any]]:
    """Return the fields of a spec dataclass that are keys of its TOML table, by name."""
    return MappingProxyType({f.name: f for f in dataclasses.fields(spec)
                             if f.metadata.get("toml", True)})


def _keys(spec: type) -> set[str]:
    """Return the keys a spec's TOML table allows: its fields (see ``scene_types``)."""
    return set(_fields(spec))


def _default(spec: type, name: str) -> Any:
    """Return the default of a spec's key: its field's default, or :data:`REQUIRED` without one."""
    found = _fields(spec)[name]
    if found.default is not dataclasses.MISSING:
        return found.default
    if found.default_factory is not dataclasses.MISSING:
        return found.default_factory()
    return REQUIRED


@functools.cache
def _choices(spec: type, name: str) -> tuple[Any, ...] | None:
    """Return the values a key allows when its field is a ``Literal``, else None."""
    kind = typing.get_type_hints(spec)[name]
    return typing.get_args(kind) if typing.get_origin(kind) is typing.Literal else None


def _setting(table: Mapping[str, Any], spec: type, name: str, key: str,
             kind: type | tuple[type, ...]) -> Any:
    """Return a spec's key from its table, with the field's default and allowed values."""
    return _get(table, name, key, kind, _default(spec, name), _choices(spec, name))


def _file(scene_dir: Path, value: str, key: str) -> Path:
    path = (scene_dir / _TABLES.path(value, key)).resolve()
    if not path.is_file():
        raise _error(key, f"file not found: {path}",
                     hint="paths in a scene are relative to the scene file; check the name")
    return path


def _note(scene_dir: Path, value: str) -> Path:
    """Return the note file after checking it is a note (regular UTF-8 text, at most 64 KiB)."""
    path = _file(scene_dir, value, "note")
    read_note(path)
    return path


def _mechanism_path(scene_dir: Path, value: str, key: str) -> Path:
    if not value.startswith(BUILTIN_PREFIX):
        return _file(scene_dir, value, key)
    try:
        return mechanism_file(value)
    except MechanismError as error:
        raise _error(key, error.message, hint=f"{error.hint}; or give a path") from None


def _ref(value: Any, key: str, streams: Mapping[str, StreamSpec],
         sensors: tuple[str, ...] | None = None) -> ChannelRef:
    if not isinstance(value, str) or value.count(".") != 1:
        raise _error(key, f"expected 'stream.channel', got {value!r}")
    stream, channel = value.split(".")
    if stream not in streams:
        raise _error(key, f"unknown stream {stream!r}", hint=f"streams: {', '.join(streams)}")
    if channel not in streams[stream].channels:
        raise _error(key, f"unknown channel {channel!r} of stream {stream!r}",
                     hint=f"channels of {stream}: {', '.join(streams[stream].channels)}; "
                          f"declare it as [streams.{stream}.channels.{channel}]")
    sensor = streams[stream].channels[channel].sensor
    if sensors is not None and sensor not in sensors:
        raise _error(key, f"{value} is a {sensor!r} channel, expected {' or '.join(sensors)}")
    return ChannelRef(stream, channel)


#: Largest magnitudes of the scene's angles (rad), times (s), frequencies (Hz) and counts: far
#: beyond any run, so that a value outside is a typo or a unit mix-up (docs/scene.md, Numbers).
MAX_ANGLE_RAD, MAX_SECONDS, MAX_HZ, MAX_COUNT = 1e6, 1e7, 1e9, 1_000_000


def _bounded(value: float | None, key: str, largest: float, unit: str) -> float | None:
    """Return ``value`` (None passes) after checking its magnitude is at most ``largest``."""
    if value is not None and not abs(value) <= largest:
        raise _error(key, f"must be at most {largest:g} {unit} in magnitude, got {value!r}",
                     hint=f"write the value in {unit}; check its digits")
    return value


#: Plausible magnitudes of a comparison's ``scale`` (model quantity to measured unit).
MIN_SCALE, MAX_SCALE = 1e-12, 1e12
#: Largest relative uncertainties (fractions) and coverage factor of ``uncertainty``.
MAX_UNCERTAINTY = {"u_measurement_rel": 1.0, "u_measurement_rel_common": 1.0, "k": 10.0}

#: Fewest encoder counts per revolution (after x4 decoding): the drive speed and acceleration are
#: filtered at 8 harmonics of the revolution (processing.excitation), which takes at least two
#: counts per period of the 8th harmonic.
MIN_COUNTS_PER_REV = 16


def _check_channel_numbers(channel: ChannelSpec) -> None:
    """Range checks of channel-map numbers that depend on the scene's use of them."""
    counts = channel.params.get("counts_per_rev")
    if channel.sensor == "encoder" and counts is not None and counts < MIN_COUNTS_PER_REV:
        raise _error(f"{channel.key}.counts_per_rev",
                     f"must be at least {MIN_COUNTS_PER_REV}, got {counts}",
                     hint="give the encoder's counts per revolution after x4 decoding (lines "
                          "per revolution times 4), e.g. 8192 for a 2048-line encoder")


@contextlib.contextmanager
def channel_map_as_scene() -> Iterator[None]:
    """Re-raise a :class:`~rigval.acquisition.errors.ChannelMapError` as a :class:`SceneError`.

    The channel map is the scene's ``[streams]`` part, so its problems (found when it is parsed
    or when a stream is converted) are scene errors with the same message, key path and hint.
    """
    try:
        yield
    except ChannelMapError as error:
        raise SceneError(error.message, where=error.where, hint=error.hint,
                         **error.extra) from None


def _streams(doc: Mapping[str, Any], scene_dir: Path) -> dict[str, StreamSpec]:
    """Parse ``[streams]`` with the acquisition channel map; check files and units here."""
    with channel_map_as_scene():
        streams = parse_streams(_get(doc, "streams", "", dict), base_dir=scene_dir)
    for spec in streams.values():
        _file(scene_dir, str(spec.file), f"{spec.key}.file")
        if not spec.channels:
            raise _error(f"{spec.key}.channels", "no channels declared",
                         hint=f"add [{spec.key}.channels.NAME] tables")
        for channel in spec.channels.values():
            try:
                dimension(channel_units(channel))
            except UnitError as error:
                raise _error(f"{channel.key}.units", error.message, hint=error.hint) from None
            _check_channel_numbers(channel)
    return {name: dataclasses.replace(spec, file=spec.file.resolve())
            for name, spec in streams.items()}


def _alignment_spec(doc: Mapping[str, Any], streams: Mapping[str, StreamSpec]) -> AlignmentSpec:
    key = "alignment"
    table = _table(_get(doc, key, "", dict), key)
    _check_keys(table, key, _keys(AlignmentSpec))
    reference = _get(table, "reference", key, str, choices=tuple(streams))
    encoder = _ref(_get(table, "main_encoder", key, str), f"{key}.main_encoder", streams,
                   ("encoder",))
    pulse = _ref(_get(table, "main_reference_pulse", key, str), f"{key}.main_reference_pulse",
                 streams, ("reference_pulse",))
    for name, ref in (("main_encoder", encoder), ("main_reference_pulse", pulse)):
        if ref.stream != reference:
            raise _error(f"{key}.{name}", f"must be on the reference stream {reference!r}, "
                         f"got {ref}")
    pulses_table = _table(_get(table, "pulses", key, dict, {}), f"{key}.pulses")
    pulses = {}
    for stream, raw in pulses_table.items():
        pkey = f"{key}.pulses.{stream}"
        if stream not in streams or stream == reference:
            raise _error(pkey, f"expected a non-reference stream, got {stream!r}",
                         hint=f"streams: {', '.join(streams)}; reference: {reference}")
        entry = _table(raw, pkey)
        _check_keys(entry, pkey, _keys(PulseSpec))
        method = _setting(entry, PulseSpec, "method", pkey, str)
        channel = None
        if method == "pulses" or "channel" in entry:
            channel = _ref(f"{stream}.{_get(entry, 'channel', pkey, str)}", f"{pkey}.channel",
                           streams, ("reference_pulse",))
        per_rev = _setting(entry, PulseSpec, "per_revolution", pkey, int)
        if not 1 <= per_rev <= MAX_COUNT:
            raise _error(f"{pkey}.per_revolution", f"must be 1 to {MAX_COUNT}, got {per_rev}",
                         hint="count the pulses the sensor gives per main-shaft revolution")
        uncertainty = _setting(entry, PulseSpec, "start_time_uncertainty_s", pkey, float)
        if uncertainty is not None and not 0.0 < uncertainty <= MAX_SECONDS:
            raise _error(f"{pkey}.start_time_uncertainty_s",
                         f"must be a positive number of seconds up to {MAX_SECONDS:g}, "
                         f"got {uncertainty}")
        coarse = _bounded(_setting(entry, PulseSpec, "coarse_offset_s", pkey, float),
                          f"{pkey}.coarse_offset_s", MAX_SECONDS, "s")
        pulses[stream] = PulseSpec(
            channel=channel, per_revolution=per_rev,
            angle=_bounded(_setting(entry, PulseSpec, "angle", pkey, float), f"{pkey}.angle",
                           MAX_ANGLE_RAD, "rad"), method=method,
            coarse_offset_s=coarse, start_time_uncertainty_s=uncertainty)
    missing = [s for s in streams if s != reference and s not in pulses]
    if missing:
        raise _error(f"{key}.pulses.{missing[0]}", "missing: every stream other than the "
                     "reference needs a reference pulse channel to be aligned",
                     hint=f'add {missing[0]} = {{ channel = "...", per_revolution = 1 }}')
    return AlignmentSpec(reference=reference, main_encoder=encoder, main_reference_pulse=pulse,
                         pulses=MappingProxyType(pulses))


def _angle_spec(doc: Mapping[str, Any]) -> AngleSpec:
    key = "angle"
    table = _table(_get(doc, key, "", dict, {}), key)
    _check_keys(table, key, _keys(AngleSpec))
    points = _setting(table, AngleSpec, "points_per_revolution", key, int)
    if not 8 <= points <= 1_000_000:
        raise _error(f"{key}.points_per_revolution", f"expected 8 to 1000000, got {points}")
    cycles = _setting(table, AngleSpec, "min_cycles", key, int)
    if not 1 <= cycles <= MAX_COUNT:
        raise _error(f"{key}.min_cycles", f"must be 1 to {MAX_COUNT}, got {cycles}")
    return AngleSpec(points_per_revolution=points,
                     interpolation=_setting(table, AngleSpec, "interpolation", key, str),
                     min_cycles=cycles)


def _model_spec(doc: Mapping[str, Any], streams: Mapping[str, StreamSpec], reference: str
           ) -> ModelSpec:
    key = "model"
    table = _table(_get(doc, key, "", dict, {}), key)
    _check_keys(table, key, _keys(ModelSpec))
    drives = _setting(table, ModelSpec, "drives", key, str)
    drivers_table = _table(_setting(table, ModelSpec, "drivers", key, dict), f"{key}.drivers")
    drivers = {}
    for name, raw in drivers_table.items():
        dkey = f"{key}.drivers.{name}"
        entry = _table(raw, dkey)
        _check_keys(entry, dkey, _keys(DriverSpec))
        direction = _setting(entry, DriverSpec, "direction", dkey, int)
        encoder = _ref(_get(entry, "encoder", dkey, str), f"{dkey}.encoder", streams,
                       ("encoder",))
        if encoder.stream != reference:
            raise _error(f"{dkey}.encoder", f"must be on the reference stream {reference!r}, "
                         f"got {encoder}", hint="drive encoders share the reference clock")
        drivers[name] = DriverSpec(
            name=name, encoder=encoder,
            angle_at_reference=_bounded(
                _setting(entry, DriverSpec, "angle_at_reference", dkey, float),
                f"{dkey}.angle_at_reference", MAX_ANGLE_RAD, "rad"),
            direction=direction)
    if drives == "analytic" and drivers:
        raise _error(f"{key}.drivers", 'driver tables apply only to drives = "measured"',
                     hint='remove them or set drives = "measured"')
    return ModelSpec(drives=drives, drivers=MappingProxyType(drivers))


def _thresholds(table: Mapping[str, Any], metrics: tuple[str, ...], key: str
                ) -> Mapping[str, str]:
    known = score_names(metrics) if table else ()
    for metric, text in table.items():
        tkey = f'{key}."{metric}"'
        if isinstance(text, bool) or not isinstance(text, str):
            raise _error(tkey, f"expected a string such as '>= 0.8' or 'abs <= 0.1', got {text!r}")
        try:
            parse_threshold(text, tkey)
        except ConfigError as error:
            raise _error(tkey, error.message, hint=error.hint) from None
        if metric not in known:
            raise _error(tkey, f"unknown score {metric!r} for the metrics {', '.join(metrics)}",
                         hint=f"scores: {', '.join(known)}")
    return MappingProxyType(dict(table))


def _uncertainty(table: Mapping[str, Any], key: str) -> Mapping[str, float]:
    _check_keys(table, key, {"u_input", "u_measurement", "u_measurement_rel",
                             "u_measurement_rel_common", "k"})
    values = {}
    for name in table:
        value = _get(table, name, key, float)
        if not (math.isfinite(value) and value >= 0) or (name == "k" and value == 0):
            raise _error(f"{key}.{name}", f"must be a finite number >= 0 (k > 0), got {value}")
        largest = MAX_UNCERTAINTY.get(name, MAX_SCALE)
        if value > largest:
            raise _error(f"{key}.{name}", f"must be at most {largest:g}, got {value}",
                         hint="relative uncertainties are fractions (0.02 for 2 %); k is a "
                              "coverage factor (2 for 95 %)")
        values[name] = value
    return MappingProxyType(values)


def _model_output(value: Any, key: str) -> ModelOutput:
    table = _table(value, key)
    _check_keys(table, key, _keys(ModelOutput))
    quantity = _get(table, "quantity", key, str, choices=tuple(MODEL_QUANTITIES))
    item = _get(table, "item", key, str)
    _, axes, _ = MODEL_QUANTITIES[quantity]
    if quantity == "joint_axial_force":
        if "axis" in table:
            raise _error(f"{key}.axis", "joint_axial_force is along the body's axis; remove "
                                        "the key", hint="name the body (and toward) instead")
        return ModelOutput(quantity, item, None, _get(table, "body", key, str),
                           _get(table, "toward", key, str, None))
    for extra in ("body", "toward"):
        if extra in table:
            raise _error(f"{key}.{extra}", f"applies to joint_axial_force only, not {quantity}")
    if axes is None:
        if "axis" in table:
            raise _error(f"{key}.axis", f"{quantity} has no axis; remove the key")
        return ModelOutput(quantity, item, None)
    return ModelOutput(quantity, item, _get(table, "axis", key, str, choices=axes))


def _comparison_specs(doc: Mapping[str, Any], streams: Mapping[str, StreamSpec]
                 ) -> tuple[ComparisonSpec, ...]:
    items = _get(doc, "comparisons", "", list)
    if not items:
        raise _error("comparisons", "no comparisons", hint="add a [[comparisons]] table")
    specs: list[ComparisonSpec] = []
    for index, raw in enumerate(items):
        key = f"comparisons[{index}]"
        table = _table(raw, key)
        _check_keys(table, key, _keys(ComparisonSpec))
        name = _TABLES.name(_get(table, "name", key, str), f"{key}.name")
        if name in {s.name for s in specs}:
            raise _error(f"{key}.name", f"duplicate comparison name {name!r}")
        measured, summed, signs = _measured(table, key, streams)
        output = _model_output(_get(table, "model", key, dict), f"{key}.model")
        scale = _setting(table, ComparisonSpec, "scale", key, float)
        if not MIN_SCALE <= abs(scale) <= MAX_SCALE:
            raise _error(f"{key}.scale", f"must be non-zero and within {MIN_SCALE:g} to "
                         f"{MAX_SCALE:g} in magnitude, got {scale}",
                         hint="the factor from the model quantity to the measured unit "
                              "(e.g. -1/A in m-2); check its unit and digits")
        scale_units = _setting(table, ComparisonSpec, "scale_units", key, str)
        lowpass = _setting(table, ComparisonSpec, "lowpass_hz", key, float)
        if lowpass is not None and not 0 < lowpass <= MAX_HZ:
            raise _error(f"{key}.lowpass_hz", f"must be positive, up to {MAX_HZ:g}, got {lowpass}")
        metrics = tuple(_setting(table, ComparisonSpec, "metrics", key, list))
        for i, metric in enumerate(metrics):
            if metric not in METRICS or metric == "vv20":
                raise _error(f"{key}.metrics[{i}]", f"unknown metric {metric!r}",
                             hint=f"metrics: {', '.join(m for m in METRICS if m != 'vv20')} "
                                  "(V&V 20 always runs; give its inputs in uncertainty)")
        uncertainty = _uncertainty(
            _table(_setting(table, ComparisonSpec, "uncertainty", key, dict),
                   f"{key}.uncertainty"), f"{key}.uncertainty")
        thresholds = _thresholds(
            _table(_setting(table, ComparisonSpec, "thresholds", key, dict), f"{key}.thresholds"),
            (*metrics, "vv20"), f"{key}.thresholds")
        measured_units = channel_units(streams[measured.stream].channels[measured.channel])
        try:
            model_dim = multiply(output.units, scale_units)
        except UnitError as error:
            raise _error(f"{key}.scale_units", error.message, hint=error.hint) from None
        if model_dim != parse_unit(measured_units):
            raise _error(
                f"{key}.model", f"unit mismatch: {measured} is in {measured_units!r} but "
                f"{output} is in {output.units!r} (times scale_units {scale_units!r})",
                hint="compare like with like, or set scale and scale_units to convert the model "
                     "quantity (e.g. scale = -1/A, scale_units = 'm-2' turns N into Pa)")
        specs.append(ComparisonSpec(
            name=name, measured=measured, model=output, key=key, scale=scale,
            scale_units=scale_units, lowpass_hz=lowpass,
            remove_offset=_setting(table, ComparisonSpec, "remove_offset", key, bool),
            metrics=metrics, uncertainty=uncertainty,
            nrmse_normaliser=_setting(table, ComparisonSpec, "nrmse_normaliser", key, str),
            thresholds=thresholds, summed=summed, signs=signs))
    return tuple(specs)


def _measured_terms(value: Any, key: str) -> tuple[list[Any], list[float], list[str]]:
    """Split ``measured`` into channel texts, signs and key paths.

    A list (``["wls1.tor1", "wls1.tor2"]``, an item may start with ``-``) or an expression
    with ``+`` and ``-`` between spaces (``"wls1.tor1 - wls1.tor2"``).
    """
    if isinstance(value, str):
        parts = re.split(r"\s+([+-])\s+", value.strip())
        items = [parts[0]] + [f"{op}{ref}" if op == "-" else ref
                              for op, ref in zip(parts[1::2], parts[2::2], strict=True)]
        keys = [f"{key}.measured"] * len(items)
    else:
        items, keys = list(value), [f"{key}.measured[{i}]" for i in range(len(value))]
    texts: list[Any] = []
    signs: list[float] = []
    for item in items:
        sign = 1.0
        if isinstance(item, str) and item.startswith("-"):
            sign, item = -1.0, item[1:].strip()
        texts.append(item)
        signs.append(sign)
    if signs and signs[0] < 0:
        raise _error(keys[0], "the first channel cannot be subtracted",
                     hint="put a channel that is added first, or set scale = -1")
    return texts, signs, keys


def _measured(table: Mapping[str, Any], key: str, streams: Mapping[str, StreamSpec]
              ) -> tuple[ChannelRef, tuple[ChannelRef, ...], tuple[float, ...]]:
    """Return the ``measured`` channel, the further channels summed with it and their signs."""
    value = table.get("measured")
    if not isinstance(value, list | str):
        _get(table, "measured", key, str)  # raises: missing or of the wrong type
    if not value:
        raise _error(f"{key}.measured", "empty list of channels",
                     hint='give "stream.channel", "a.x + a.y" or a list of them to be summed')
    texts, signs, keys = _measured_terms(value, key)
    if len(texts) == 1 and isinstance(value, str):
        return _ref(texts[0], keys[0], streams, _MEASURED_SENSORS), (), ()
    refs = [_ref(item, ikey, streams, _MEASURED_SENSORS)
            for item, ikey in zip(texts, keys, strict=True)]
    first = channel_units(streams[refs[0].stream].channels[refs[0].channel])
    for i, ref in enumerate(refs[1:], start=1):
        if ref.stream != refs[0].stream:
            raise _error(keys[i], f"summed channels must be on one stream, got "
                         f"{refs[0]} and {ref}", hint="sum channels of one device only")
        units = channel_units(streams[ref.stream].channels[ref.channel])
        if units != first:
            raise _error(keys[i], f"summed channels must share a unit, got "
                         f"{first!r} and {units!r}", hint="sum like with like")
    if len(set(refs)) != len(refs):
        raise _error(keys[0], "a channel appears twice", hint="give each channel once")
    return refs[0], tuple(refs[1:]), tuple(signs[1:]) if min(signs) < 0 else ()


def _prediction_spec(doc: Mapping[str, Any], comparisons: tuple[ComparisonSpec, ...]
                 ) -> PredictionSpec:
    key = "predictions"
    table = _table(_get(doc, key, "", dict, {}), key)
    _check_keys(table, key, _keys(PredictionSpec))
    default_points = tuple(dict.fromkeys(c.model.item for c in comparisons
                                         if c.model.quantity.startswith("point_")))
    points = _get(table, "points", key, list, list(default_points))
    supports = _setting(table, PredictionSpec, "supports", key, list)
    for name, values in (("points", points), ("supports", supports or [])):
        for i, value in enumerate(values):
            if not isinstance(value, str):
                raise _error(f"{key}.{name}[{i}]", f"expected a name, got {value!r}")
    return PredictionSpec(points=tuple(points),
                          supports=None if supports is None else tuple(supports))


def _symmetry_specs(doc: Mapping[str, Any], comparisons: tuple[ComparisonSpec, ...],
              streams: Mapping[str, StreamSpec]) -> tuple[SymmetrySpec, ...]:
    """Return the ``[[symmetry]]`` pairs: two comparisons of one unit, calibration stated."""
    tables = _get(doc, "symmetry", "", list, [])
    by_name = {c.name: c for c in comparisons}
    names: set[str] = set()
    out = []
    for i, raw in enumerate(tables):
        key = f"symmetry[{i}]"
        table = _table(raw, key)
        _check_keys(table, key, _keys(SymmetrySpec))
        name = _get(table, "name", key, str)
        if name in names:
            raise _error(f"{key}.name", f"pair name {name!r} is used twice",
                         hint="give each [[symmetry]] pair its own name")
        names.add(name)
        pair = _get(table, "comparisons", key, list)
        if len(pair) != 2 or not all(isinstance(n, str) for n in pair) or pair[0] == pair[1]:
            raise _error(f"{key}.comparisons", f"expected two comparison names, got {pair!r}",
                         hint='e.g. comparisons = ["tor1", "tor2"]')
        for n in pair:
            if n not in by_name:
                raise _error(f"{key}.comparisons", f"no comparison named {n!r}",
                             hint=f"comparisons: {', '.join(by_name)}")
        first, second = (by_name[n] for n in pair)
        units = [channel_units(streams[c.measured.stream].channels[c.measured.channel])
                 for c in (first, second)]
        if units[0] != units[1] or first.scale != second.scale:
            raise _error(f"{key}.comparisons", f"{pair[0]} and {pair[1]} differ in unit or "
                         f"scale ({units[0]!r} x {first.scale:g}, {units[1]!r} x "
                         f"{second.scale:g})", hint="pair two channels of one kind")
        rel = _get(table, "u_measurement_rel", key, float)
        common = _setting(table, SymmetrySpec, "u_measurement_rel_common", key, float)
        for field_name, value in (("u_measurement_rel", rel),
                                  ("u_measurement_rel_common", common)):
            if not (math.isfinite(value) and value >= 0):
                raise _error(f"{key}.{field_name}", f"must be a finite number >= 0, got {value}")
        if common > rel:
            raise _error(f"{key}.u_measurement_rel_common",
                         f"the common part {common} exceeds the whole {rel}",
                         hint="state the common part of the calibration, at most the whole")
        out.append(SymmetrySpec(name=name, comparisons=(pair[0], pair[1]), key=key,
                                kind=_setting(table, SymmetrySpec, "kind", key, str),
                                u_measurement_rel=rel, u_measurement_rel_common=common))
    return tuple(out)


def _output_spec(doc: Mapping[str, Any]) -> OutputSpec:
    key = "output"
    table = _table(_get(doc, key, "", dict, {}), key)
    _check_keys(table, key, _keys(OutputSpec))
    return OutputSpec(raw=_setting(table, OutputSpec, "raw", key, bool),
                      aligned=_setting(table, OutputSpec, "aligned", key, bool))


#: The marker ``rigval init`` writes for a value the files cannot tell.
TODO = "TODO"


def todo_label(doc: Mapping[str, Any], key: str) -> str:
    """Return a TODO's key path with its comparison's name: ``comparisons[3] (tor1).scale``.

    Parameters
    ----------
    doc : mapping
        The parsed scene.
    key : str
        A key path from :func:`todo_keys`.
    """
    match = re.match(r"comparisons\[(\d+)\]", key)
    comparisons = doc.get("comparisons")
    if not match or not isinstance(comparisons, list):
        return key
    table = comparisons[int(match.group(1))] if int(match.group(1)) < len(comparisons) else {}
    name = table.get("name") if isinstance(table, Mapping) else None
    return key if not isinstance(name, str) else f"{match.group(0)} ({name}){key[match.end():]}"


def todo_keys(doc: Mapping[str, Any], key: str = "") -> list[str]:
    """Return the key path of every string value that starts with ``TODO``, in document order.

    Parameters
    ----------
    doc : mapping
        A parsed TOML document or table.
    key : str
        Key path of ``doc`` (empty for the document).
    """
    found: list[str] = []

    def visit(value: Any, path: str) -> None:
        if isinstance(value, str) and value.strip().startswith(TODO):
            found.append(path)
        elif isinstance(value, Mapping):
            for name, sub in value.items():
                visit(sub, f"{path}.{name}" if path else str(name))
        elif isinstance(value, list):
            for index, sub in enumerate(value):
                visit(sub, f"{path}[{index}]")

    visit(doc, key)
    return found


def parse_scene(text: str, path: str | Path, *, names: MechanismNames | None = None) -> Scene:
    """Parse scene text (TOML) into a :class:`Scene`.

    Parameters
    ----------
    text : str
        The TOML text.
    path : str or pathlib.Path
        Where the scene lives; relative paths in it are resolved against its folder.
    names : MechanismNames, optional
        The mechanism's names, to check the model references (see :func:`load_scene`).

    Returns
    -------
    Scene
        The checked scene.

    Raises
    ------
    SceneError
        With ``where["key"]`` the key path of the first problem.
    """
    path = Path(path).resolve()
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise SceneError(f"not valid TOML: {error}", where={"file": str(path)},
                         hint="check quotes, brackets and '=' on the line named") from None
    todo = todo_keys(doc)
    if todo:
        raise SceneError(
            f"{len(todo)} value(s) still marked TODO:\n"
            + "".join(f"  {todo_label(doc, key)}\n" for key in todo),
            where={"key": todo[0], "file": str(path)}, keys=todo,
            hint="fill each value (the comment next to it in the skeleton written by rigval "
                 "init says what it is); docs/scene.md describes every key")
    _check_keys(doc, "", _keys(Scene) | {"schema"})
    schema = _get(doc, "schema", "", str)
    if schema != SCHEMA:
        raise _error("schema", f"expected {SCHEMA!r}, got {schema!r}")
    scene_dir = path.parent
    streams = _streams(doc, scene_dir)
    comparisons = _comparison_specs(doc, streams)
    note = _get(doc, "note", "", str, None)
    alignment = _alignment_spec(doc, streams)
    scene = Scene(
        path=path, text=text, sha256=hashlib.sha256(text.encode()).hexdigest(),
        title=_get(doc, "title", "", str, path.stem),
        mechanism=_mechanism_path(scene_dir, _get(doc, "mechanism", "", str), "mechanism"),
        note=_note(scene_dir, note) if note is not None else None,
        streams=MappingProxyType(streams), alignment=alignment,
        angle=_angle_spec(doc), model=_model_spec(doc, streams, alignment.reference),
        comparisons=comparisons,
        predictions=_prediction_spec(doc, comparisons), output=_output_spec(doc),
        symmetry=_symmetry_specs(doc, comparisons, streams))
    if names is not None:
        check_mechanism_names(scene, names)
    return scene


def load_scene(path: str | Path, *, check_mechanism: bool = True) -> Scene:
    """Read and check a scene file.

    Parameters
    ----------
    path : str or pathlib.Path
        The scene file (TOML).
    check_mechanism : bool
        Load the mechanism and check the comparisons' model items, the drivers and the predicted
        points and supports against it.

    Returns
    -------
    Scene
        The checked scene, with every path resolved.

    Raises
    ------
    SceneError
        For a missing or unreadable scene, or any problem in it (``where["key"]`` names the key).
    MechanismError
        If the mechanism file itself is invalid.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as error:
        raise SceneError(f"cannot read the scene file: {error}", where={"file": str(path)},
                         hint="check the path") from None
    scene = parse_scene(text, path)
    if check_mechanism:
        try:
            names = mechanism_names(scene.mechanism)
        except MechanismError as error:
            if error.where.get("key"):
                raise
            # the file as a whole (unreadable, not TOML): the scene's key that names it
            raise SceneError(error.message, where={"key": "mechanism", **error.where},
                             hint=error.hint) from None
        check_mechanism_names(scene, names)
        if scene.model.drives == "analytic":  # the laws the model runs: a main drive that turns
            from rigval.model.drives import cycle_period
            from rigval.model.mechanism import load_mechanism

            cycle_period(load_mechanism(scene.mechanism))
    logger.debug("scene %s: %d streams, %d comparisons", path, len(scene.streams),
                 len(scene.comparisons))
    return scene
