"""The scene as the plain settings each stage of the run takes, and stage errors as scene errors.

Processing and the model know nothing of scenes: the alignment takes
:class:`~rigval.processing.stream_alignment.AlignmentSettings`, the conversion a stream table, the
model a request of outputs and the drivers' encoders. This module is the one adapter from a
:class:`~rigval.validation.scene_types.Scene` to them (docs/scene.md names every key):

- :func:`alignment_settings`: ``[alignment]`` with its channel references resolved;
- :func:`model_settings`: the comparisons' and ``[predictions]``'s model outputs and the
  ``[model.drivers]`` encoders;
- :func:`check_sample_rates`: corner frequencies against the streams' rates, once read;
- :func:`convert_stream`: a stream to physical units.

Errors of the stages that are problems of the scene are translated here, by type, in one place
(:func:`scene_errors`): a :class:`~rigval.acquisition.errors.ChannelMapError` (the ``[streams]``
part) becomes a :class:`~rigval.validation.errors.SceneError` with the same key path, and a
:class:`~rigval.processing.errors.DriveRateError` (a drive filter corner above fs/2: the encoder
turns implausibly fast) one naming the encoders' ``counts_per_rev`` keys.
"""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import Any, Literal

import xarray as xr

from rigval.acquisition.channel_map import StreamSpec
from rigval.model.mechanism_types import Mechanism
from rigval.model.output_values import ModelOutput
from rigval.processing import sensors
from rigval.processing.errors import DriveRateError
from rigval.processing.stream_alignment import AlignmentSettings, ClockSettings
from rigval.validation.errors import SceneError
from rigval.validation.scene import channel_map_as_scene
from rigval.validation.scene_types import Scene

__all__ = [
    "LOWPASS_FRACTION",
    "DriveEncoder",
    "ModelSettings",
    "alignment_settings",
    "check_sample_rates",
    "convert_stream",
    "drive_encoders",
    "model_settings",
    "scene_errors",
]

logger = logging.getLogger(__name__)

#: Largest comparison low-pass corner as a fraction of the measured stream's rate: above it the
#: Butterworth design degenerates next to Nyquist, and the anti-alias filter of the angle
#: resampling already limits the band.
LOWPASS_FRACTION = 0.45


# ---------------------------------------------------------------------------------------------
# errors


@contextlib.contextmanager
def scene_errors(scene: Scene) -> Iterator[None]:
    """Re-raise the stages' errors that are problems of the scene as :class:`SceneError`.

    Parameters
    ----------
    scene : Scene
        The scene whose keys are named.

    Raises
    ------
    SceneError
        For a :class:`ChannelMapError` (same message, key path and hint:
        :func:`rigval.validation.scene.channel_map_as_scene`, as the parser does) or a
        :class:`DriveRateError` (the ``counts_per_rev`` keys of the main and drive encoders).
    """
    try:
        with channel_map_as_scene():
            yield
    except DriveRateError as error:
        refs = [scene.alignment.main_encoder] + [d.encoder for d in scene.model.drivers.values()]
        keys = list(dict.fromkeys(f"{scene.channel(ref).key}.counts_per_rev" for ref in refs))
        values = ", ".join(f"{key} = {scene.channel(ref).params['counts_per_rev']}"
                           for key, ref in zip(keys, refs, strict=False))
        raise SceneError(
            f"the drive speed from the encoders is implausibly high ({error.message}); the "
            f"encoder scale is probably wrong: {values}", where={"key": keys[0], "keys": keys},
            hint="give counts per revolution after x4 decoding (lines per revolution times 4)"
        ) from error


# ---------------------------------------------------------------------------------------------
# read and convert


def _rate(streams: Mapping[str, xr.Dataset], name: str) -> float | None:
    value = streams[name].attrs.get("fs_nominal") if name in streams else None
    return float(value) if value is not None and float(value) > 0 else None


def check_sample_rates(scene: Scene, streams: Mapping[str, xr.Dataset]) -> None:
    """Raise a SceneError naming the key of a corner frequency its stream's rate cannot carry.

    A scene states corner frequencies before any file is read; whether they fit is known only
    from each stream's nominal rate ``fs_nominal``. A charge amplifier's ``highpass_hz`` must
    lie below fs/2 of its stream (the digital inverse of the high-pass is defined only there); a
    comparison's ``lowpass_hz`` below :data:`LOWPASS_FRACTION` fs of its measured stream.

    Parameters
    ----------
    scene : Scene
        The scene.
    streams : mapping of str to xarray.Dataset
        The streams as read (attribute ``fs_nominal`` in Hz); streams without a nominal rate
        (irregular time stamps) are not checked.

    Raises
    ------
    SceneError
        ``where["key"]`` is the scene key; the message gives the limit in Hz.
    """
    for name, spec in scene.streams.items():
        fs = _rate(streams, name)
        if fs is None:
            continue
        for channel in spec.channels.values():
            corner = channel.params.get("highpass_hz")
            if corner is not None and corner >= fs / 2:
                key = f"{channel.key}.highpass_hz"
                raise SceneError(
                    f"{key}: {corner:g} Hz is not below fs/2 = {fs / 2:g} Hz of stream {name!r} "
                    f"({spec.file.name} at {fs:g} Hz)", where={"key": key, "file": spec.file},
                    hint="give the amplifier's high-pass corner in Hz (typically 0.1 to 10 Hz)")
    for comparison in scene.comparisons:
        fs = _rate(streams, comparison.measured.stream)
        corner = comparison.lowpass_hz
        if fs is None or corner is None:
            continue
        limit = LOWPASS_FRACTION * fs
        if corner >= limit:
            key = f"{comparison.key}.lowpass_hz"
            raise SceneError(
                f"{key}: {corner:g} Hz is not below {LOWPASS_FRACTION:g} fs = {limit:g} Hz of "
                f"stream {comparison.measured.stream!r} (fs = {fs:g} Hz, Nyquist {fs / 2:g} Hz)",
                where={"key": key}, hint=f"give a corner below {limit:g} Hz, or remove the key "
                                         "to compare the unfiltered signal")


def convert_stream(stream: xr.Dataset, spec: StreamSpec, *, overwrite: bool = False
                   ) -> xr.Dataset:
    """Convert a stream's channels to physical units as its scene table says.

    Parameters
    ----------
    stream : xarray.Dataset
        The stream as :func:`rigval.acquisition.channel_map.load_stream` returns it.
    spec : StreamSpec
        The scene's stream table.
    overwrite : bool, default False
        The caller lets ``stream`` go after: channels may be converted in their own memory
        (:func:`rigval.processing.sensors.convert_stream`).

    Returns
    -------
    xarray.Dataset
        As :func:`rigval.processing.sensors.convert_stream` returns it.

    Raises
    ------
    SceneError
        When a channel's unit in the file does not fit its declared sensor, or a needed
        calibration value is missing (``where["key"]`` is the channel's key path).
    """
    with channel_map_as_scene():
        return sensors.convert_stream(stream, spec, overwrite=overwrite)


# ---------------------------------------------------------------------------------------------
# align


def alignment_settings(scene: Scene) -> AlignmentSettings:
    """Return the scene's alignment settings with its channel references resolved.

    The main encoder's direction is that of the drivers it feeds (+1 when none does); the
    reference stream must hold ``[angle] min_cycles`` good reference pulses.
    """
    table = scene.alignment
    directions = [d.direction for d in scene.model.drivers.values()
                  if d.encoder == table.main_encoder]
    streams = {
        name: ClockSettings(
            method="stamps" if pulse.method == "stamps" else "pulses",
            pulse=scene.channel(pulse.channel) if pulse.channel is not None else None,
            per_revolution=pulse.per_revolution, angle=pulse.angle,
            coarse_offset_s=pulse.coarse_offset_s,
            start_time_uncertainty_s=pulse.start_time_uncertainty_s,
            key=f"alignment.pulses.{name}")
        for name, pulse in table.pulses.items()}
    return AlignmentSettings(
        reference=table.reference, encoder=scene.channel(table.main_encoder),
        reference_pulse=scene.channel(table.main_reference_pulse), streams=streams,
        direction=float(directions[0] if directions else 1), min_pulses=scene.angle.min_cycles,
        min_pulses_key="angle.min_cycles", key="alignment")


# ---------------------------------------------------------------------------------------------
# model


@dataclass(frozen=True)
class DriveEncoder:
    """A measured driver: the encoder channel of the reference stream it follows.

    Parameters
    ----------
    driver : str
        Driver name in the mechanism file.
    channel : str
        Encoder channel (scene name) on the reference stream.
    counts_per_rev : float
        Counts per revolution after x4 decoding.
    direction : float
        +1 when the driver angle grows with the count, else -1.
    index_reset : bool
        The counter reloads 0 at every index pulse.
    angle_at_reference : float
        Driver angle in rad when the main reference pulse fires.
    """

    driver: str
    channel: str
    counts_per_rev: float
    direction: float
    index_reset: bool
    angle_at_reference: float


@dataclass(frozen=True)
class ModelSettings:
    """What the model of a run computes and how its drives are excited.

    Parameters
    ----------
    drives : {"measured", "analytic"}
        Drive angles from the encoders, or the mechanism file's laws.
    request : mapping
        :func:`rigval.model.solve` keywords: ``outputs`` and, where needed, ``points`` and
        ``joints``; only what the comparisons and predictions name.
    encoders : tuple of DriveEncoder
        Per driver (measured drives only).
    compared : mapping of str to ModelOutput
        The model output of each comparison, by comparison name.
    """

    drives: Literal["measured", "analytic"]
    request: Mapping[str, Any]
    encoders: tuple[DriveEncoder, ...]
    compared: Mapping[str, ModelOutput]


def _request(scene: Scene, mechanism: Mechanism) -> dict[str, Any]:
    """Return the :func:`rigval.model.solve` request: only what the scene compares or predicts."""
    outputs = {c.model.quantity for c in scene.comparisons}
    points = {c.model.item for c in scene.comparisons if c.model.quantity.startswith("point_")}
    joints = {c.model.item for c in scene.comparisons
              if c.model.quantity in ("joint_force", "joint_axial_force")}
    if "joint_axial_force" in outputs:  # derived from joint forces and body angles
        outputs = (outputs - {"joint_axial_force"}) | {"joint_force", "position"}
    if scene.predictions.points:
        outputs |= {"point_position", "point_velocity", "point_acceleration"}
        points |= set(scene.predictions.points)
    if scene.predictions.supports is None or scene.predictions.supports:
        outputs.add("support_force")
    request: dict[str, Any] = {"outputs": sorted(outputs)}
    if points:
        request["points"] = [p for p in mechanism.point_names if p in points]
    if joints:
        request["joints"] = [j for j in mechanism.joint_names if j in joints]
    return request


def model_settings(scene: Scene, mechanism: Mechanism) -> ModelSettings:
    """Return the model settings of a scene.

    Parameters
    ----------
    scene : Scene
        The scene (its comparisons, ``[predictions]`` and ``[model]``).
    mechanism : rigval.model.Mechanism
        Its mechanism (for the order of points and joints).
    """
    return ModelSettings(drives=scene.model.drives, request=_request(scene, mechanism),
                         encoders=drive_encoders(scene),
                         compared={c.name: c.model for c in scene.comparisons})


def drive_encoders(scene: Scene) -> tuple[DriveEncoder, ...]:
    """Return the scene's measured drivers, in the order of ``[model.drivers]``.

    The scene alone says them, so the align stage averages the drives before the mechanism is
    loaded (:func:`rigval.validation.model_run.measured_drives`).
    """
    return tuple(
        DriveEncoder(driver=name, channel=driver.encoder.channel,
                     counts_per_rev=float(scene.channel(driver.encoder).params["counts_per_rev"]),
                     direction=float(driver.direction),
                     index_reset=bool(scene.channel(driver.encoder).params.get("index_reset",
                                                                               False)),
                     angle_at_reference=driver.angle_at_reference)
        for name, driver in scene.model.drivers.items())
