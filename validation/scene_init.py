"""A commented scene skeleton from a lab's own data files (``rigval init``).

:func:`rigval.acquisition.survey.guess_streams` reads each file and guesses each stream's device
profile and each channel's role and sensor kind; :func:`skeleton_text` writes the scene from
those guesses: streams, channels with units and rates, the alignment block with the channels
that look like pulses and encoders, the model block and one comparison per sensor channel.
Whatever the files cannot tell (gauge factors, diameters, the angle of a driver at the reference
pulse, which model quantity a channel measures) is written as ``"TODO"`` with a comment saying
what is needed; :func:`rigval.validation.scene.load_scene` refuses a scene until every TODO is
filled. Every TODO sits on its own ``key = "TODO"`` line, so :func:`fill_todos` can fill them
from a script (key path -> value).

``angle_at_reference`` help (:func:`rigval.model.drives.law_angles_at_reference`): with a
mechanism, each driver's angle at the instant the main driver's law passes its ``theta0``, shown
in the skeleton's comments and printed by ``rigval init``.
"""

from __future__ import annotations

import os
import re
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from rigval.acquisition.devices import MODULES, rate_divider
from rigval.acquisition.errors import ConfigError, DataWarning, UnitError
from rigval.acquisition.start_time import start_time_text
from rigval.acquisition.survey import (
    BRIDGE_UNITS,
    ChannelGuess,
    StreamGuess,
    counts_per_pulse,
    index_to_pulse_angle,
)
from rigval.acquisition.tables import toml_value
from rigval.acquisition.units import dimension
from rigval.model.drives import law_angles_at_reference
from rigval.validation.scene import TODO
from rigval.validation.scene_types import SCHEMA

__all__ = ["MIN_CYCLES", "fill_todos", "skeleton_text"]

#: ``[angle] min_cycles`` of a skeleton: the fewest revolutions a comparison needs.
MIN_CYCLES = 3


class _Writer:
    def __init__(self) -> None:
        self.lines: list[str] = []

    def line(self, text: str = "") -> None:
        self.lines.append(text)

    def key(self, name: str, value: Any, comment: str = "") -> None:
        text = f"{name} = {toml_value(value)}"
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
                   main_cpr: int | None, main: bool = False) -> None:
    w.line(f"[streams.{stream.name}.channels.{channel.name}]")
    w.key("source", channel.source, f"unit in the file: {channel.units or '-'!r}, "
                                    f"{stream.fs:.9g} S/s")
    if (channel.units in BRIDGE_UNITS and stream.device != "WLS-9163"
            and rate_divider(MODULES["NI 9237"], stream.fs) is not None):
        w.key("module", "NI 9237", "bridge ratios at a 50 kS/s / n rate: input delay removed")
    w.key("sensor", channel.sensor, f"guessed: {channel.reason}")
    if channel.sensor == "encoder":
        if channel.index_counts:
            tol = channel.index_counts_tol  # -1: no complete turn, a lower bound
            w.key("index_reset", True, f"the counts fall back to 0 every {channel.index_counts} "
                                       f"counts ({'at least' if tol < 0 else f'+- {tol}'}): the "
                                       "index pulse reloads the counter")
        if main_cpr and main:
            w.todo("counts_per_rev", f"per turn of the encoder's shaft, after x4 decoding; "
                                     f"{main_cpr} counts per main-shaft revolution in this file, "
                                     "the main shaft's encoder: the value")
        elif main_cpr:
            w.todo("counts_per_rev", f"per turn of this encoder's own shaft, after x4 decoding; "
                                     f"{main_cpr} counts per main-shaft revolution in this file "
                                     "= the value x turns of its shaft per main-shaft revolution "
                                     f"({main_cpr} if one, {main_cpr / 2:g} if two)")
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
            and channel.units not in BRIDGE_UNITS:
        w.todo("excitation", "V, bridge excitation (the channel holds volts)")


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
        From :func:`rigval.acquisition.survey.guess_streams`.
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
              "start " + start_time_text(stream.start_time, zone_unknown=stream.timezone_missing,
                                         timezone=stream.reader.get("timezone")))
        w.key("device", stream.device, f"guessed: {stream.device_reason}")
        for option, value in stream.reader.items():
            w.key(f"reader.{option}", value)
        if stream.timezone_missing:
            w.todo("reader.timezone", "the file's times have no zone: e.g. "
                                      '"Europe/Berlin", or "UTC"')
        notes.append(f"stream {stream.name}: {stream.file.name}, {stream.fs:.9g} S/s, "
                     f"{stream.duration_s:.4g} s, device {stream.device} "
                     f"({stream.device_reason})")
        w.line()
        for channel in stream.channels:
            cpr = (counts_per_pulse(reference, channel.name, main_pulse.name)
                   if stream is reference and main_pulse and channel.role == "encoder"
                   else None)
            _channel_table(w, stream, channel, cpr, main=channel is main_encoder)
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
    _alignment_table(w, streams, reference, main_encoder, main_pulse, placeholders, notes)
    w.line("[angle]")
    w.key("points_per_revolution", 360, "comparison grid: 1 degree")
    w.key("interpolation", "cubic")
    w.key("min_cycles", MIN_CYCLES)
    for problem in _record_problems(streams, reference, main_pulse):
        warnings.warn(problem, DataWarning, stacklevel=2)
        w.line(f"# WARNING: {problem}")
    w.line()
    _model_table(w, reference, mech, notes, main_pulse)
    units_of = {(s.name, c.name): SENSOR_UNITS[c.sensor]({
        "units": c.output_units if c.sensor == "linear" else c.units, "youngs_modulus": TODO})
                for s in streams for c in s.channels if c.role == "sensor"
                and c.sensor in SENSOR_UNITS}
    _comparison_tables(w, streams, units_of, mech)
    return "\n".join(w.lines).rstrip() + "\n", notes


def _record_problems(streams: Sequence[StreamGuess], reference: StreamGuess | None,
                     main_pulse: ChannelGuess | None) -> list[str]:
    """Return why these files can never validate: encoders that never move, too few turns."""
    problems = [f"{stream.name}.{channel.name}: the counts never change in this file: the "
                "encoder did not turn or is not connected, so no revolution can be compared"
                for stream in streams for channel in stream.of_role("encoder")
                if channel.counts_span == 0]
    if reference is not None and main_pulse is not None:
        turns = max(reference.pulse_times[main_pulse.name].size - 1, 0)
        if turns < MIN_CYCLES:
            problems.append(
                f"{reference.name}.{main_pulse.name}: {turns} complete revolution(s) between "
                f"the reference pulses in {reference.duration_s:.3g} s, fewer than [angle] "
                f"min_cycles = {MIN_CYCLES}: rigval validate will refuse the record; record "
                f"at least {MIN_CYCLES + 1} reference pulses")
    return problems


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


def _alignment_table(w: _Writer, streams: Sequence[StreamGuess], reference: StreamGuess | None,
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


def _model_table(w: _Writer, reference: StreamGuess | None, mech: tuple[str, Any] | None,
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
        past_index = index_to_pulse_angle(reference, encoder, main_pulse)
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


#: What the stated uncertainty ``u_measurement_rel`` of a comparison covers, by sensor kind.
_UNCERTAINTY_COVERS = {
    "charge_accelerometer": "the charge sensitivity and the amplifier gain (calibration "
                            "certificates)",
    "iepe_accelerometer": "the sensitivity (calibration certificate)",
    "strain_bridge": "the gauge factor, Young's modulus and the cross-section",
    "torsion_bridge": "the torsion bridge calibration (gauge factor, diameters, shear modulus)",
    "load_cell": "the rated output and capacity (calibration certificate)",
}

#: Sensor kinds whose bridge is nulled before a run (``remove_offset`` comment).
_NULLED_BRIDGES = ("strain_bridge", "torsion_bridge", "load_cell")


def _uncertainty(w: _Writer, sensor: str, *, share: bool = False) -> None:
    """Write the comparison's stated uncertainty as TODO, with what it must cover."""
    covers = _UNCERTAINTY_COVERS.get(sensor, "the sensor's calibration")
    if share:
        covers += ("; and that of this shaft's share of the drive torque, in quadrature (1 % "
                   "calibration and a share of 50 +- 3 %, i.e. 3.5 % of it: 0.036)")
    w.todo("uncertainty.u_measurement_rel",
           f"fraction (0.02 for 2 %), part of V&V 20 u_val: {covers}")


def _offset(w: _Writer, sensor: str) -> None:
    """Write ``remove_offset`` where the sensor's zero is not the model's zero."""
    if sensor in ("charge_accelerometer", "iepe_accelerometer"):
        w.key("remove_offset", True, "an accelerometer's zero is unknown")
    elif sensor in _NULLED_BRIDGES:
        w.key("remove_offset", True, "a bridge nulled with the machine at rest lost the load "
                                     "at rest, which the model has; false only if it was "
                                     "nulled unloaded")


def _summed_torques(stream: StreamGuess) -> tuple[ChannelGuess, ChannelGuess] | None:
    """Return the two torsion channels of a stream that carries exactly two (one drive)."""
    shafts = [c for c in stream.of_role("sensor") if c.sensor == "torsion_bridge"]
    return (shafts[0], shafts[1]) if len(shafts) == 2 else None


def _comparison_tables(w: _Writer, streams: Sequence[StreamGuess],
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
            share = False
            if match is None:
                w.todo("model.quantity", "point_acceleration, joint_force, driver_torque, ... "
                                         "(docs/scene.md)")
                w.todo("model.item", "the point, joint, body or driver")
            else:
                _, quantity, kind = match
                w.key("model.quantity", quantity, f"guessed from the unit {units!r}")
                _item(w, kind, names)
                if quantity == "driver_torque":
                    share = True
                    w.todo("scale", "the share of the driver torque this shaft carries (0.5 "
                                    "for one of two equal shafts)")
                else:
                    w.todo("model.axis", '"x" or "y"')
                if units in ("Pa", "1"):
                    w.todo("scale", "-1/A (A the cross-section, m2) for stress; -1/(E A) for "
                                    "strain")
                    w.key("scale_units", "m-2" if units == "Pa" else "N-1")
            _offset(w, channel.sensor)
            _uncertainty(w, channel.sensor, share=share)
            _thresholds(w)
        pair = _summed_torques(stream)
        if pair is not None:
            first, second = pair
            w.line(f"# {first.name} and {second.name} are recorded by one device: if they are "
                   "the two shafts of one drive,")
            w.line("# their sum is the whole drive torque, whatever the split between them "
                   "(delete this table if not).")
            w.line("[[comparisons]]")
            w.key("name", f"{first.name}_{second.name}_sum")
            w.key("measured", [f"{stream.name}.{first.name}", f"{stream.name}.{second.name}"],
                  "both shafts: the whole drive torque")
            w.key("model.quantity", "driver_torque")
            _item(w, "driver", names)
            _offset(w, "torsion_bridge")
            _uncertainty(w, "torsion_bridge")
            _thresholds(w)
    if not any(s.of_role("sensor") for s in streams):
        w.line("# No channel to compare was found; add [[comparisons]] tables.")


def _item(w: _Writer, kind: str, names: Mapping[str, Sequence[str]]) -> None:
    """Write ``model.item`` as TODO, listing the mechanism's names of that kind when known."""
    listed = names.get(kind)
    w.todo("model.item", f"one of: {', '.join(listed)}" if listed else
           f"the {kind}'s name in the mechanism file (rigval init --mechanism lists them)")


def _thresholds(w: _Writer) -> None:
    """Write the pass/fail threshold every comparison starts with, and end the table."""
    w.key('thresholds."vv20.curve.normalised_error"', "<= 2",
          "fails when a model error is detected (|E| > 2 u_val)")
    w.line()


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
                       f"{toml_value(values[key])}{match.group(4)}"
                done.add(key)
        lines.append(line)
    unknown = sorted(set(values) - done)
    if unknown:
        raise ConfigError(f"{unknown[0]}: not a TODO of the skeleton", where={"key": unknown[0]},
                          hint="TODO keys: use the key paths rigval validate lists")
    return "\n".join(lines) + ("\n" if text.endswith("\n") else "")
