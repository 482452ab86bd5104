"""A stream's channel map applied: raw channels to physical units, one sensor kind each.

Each channel's ``sensor`` (:data:`rigval.acquisition.channel_map.SENSORS`, docs/scene.md) picks
a dataset-level conversion of :mod:`rigval.processing.conversions`: charge amplifier volts to m s-2,
bridge ratios to strain or stress, rosette ratios to shaft torque, linear scales, IEPE
accelerometers, load cells. Encoders (counts) and reference pulses stay as read; the alignment
turns them into angles and events. A channel whose unit in the file does not fit its declared
sensor, or that lacks a calibration value its unit needs, is a
:class:`~rigval.acquisition.errors.ChannelMapError` naming the channel's key path.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from types import MappingProxyType
from typing import Any

import xarray as xr

from rigval.acquisition.channel_map import ChannelSpec, StreamSpec
from rigval.acquisition.errors import ChannelMapError, ConfigError, UnitError
from rigval.acquisition.units import same_unit
from rigval.processing import conversions

__all__ = ["NULL_WINDOW_S", "SENSOR_UNITS", "channel_units", "convert_stream"]

logger = logging.getLogger(__name__)

#: Window (s from the first sample) averaged for ``null_offset = "first_second"``.
NULL_WINDOW_S = (0.0, 1.0)

#: Unit (UDUNITS) of a converted channel per sensor kind, from its parameters
#: (``strain_bridge``: stress with ``youngs_modulus``, else strain).
SENSOR_UNITS: Mapping[str, Callable[[Mapping[str, Any]], str]] = MappingProxyType({
    "charge_accelerometer": lambda p: "m s-2",
    "strain_bridge": lambda p: "Pa" if p.get("youngs_modulus") is not None else "1",
    "torsion_bridge": lambda p: "N m",
    "encoder": lambda p: "rad",
    "reference_pulse": lambda p: "V",
    "voltage": lambda p: "V",
    "physical": lambda p: str(p["units"]),
    "linear": lambda p: str(p["units"]),
    "iepe_accelerometer": lambda p: "m s-2",
    "load_cell": lambda p: "N",
})

_CONVERTED = "__converted"


def channel_units(channel: ChannelSpec) -> str:
    """Return the unit of a channel after conversion (UDUNITS), from its sensor kind."""
    return SENSOR_UNITS[channel.sensor](channel.params)


def _bridge(ds: xr.Dataset, channel: ChannelSpec, null: tuple[float, float] | None,
            overwrite: bool) -> xr.Dataset:
    """Strain (or stress with E) of a strain bridge, or the torque of a torsion rosette.

    ``overwrite``: the channel's values may become the result (:func:`convert_stream`).
    """
    p = channel.params
    if channel.sensor == "torsion_bridge":
        return conversions.torque_channel(
            ds, channel.name, rosette=p["bridge"], gauge_factor=p["gauge_factor"],
            shear_modulus=p["shear_modulus"], outer_diameter=p["outer_diameter"],
            inner_diameter=p["inner_diameter"], excitation_voltage=p.get("excitation"),
            unstrained=null, name=_CONVERTED, overwrite=overwrite)
    out = conversions.strain_channel(
        ds, channel.name, bridge_type=p["bridge"].lower(), gauge_factor=p["gauge_factor"],
        poisson=p["poisson"], gauge_resistance=p["gauge_resistance"],
        lead_resistance=p["lead_resistance"], excitation_voltage=p.get("excitation"),
        unstrained=null, name=_CONVERTED, overwrite=overwrite)
    if p.get("youngs_modulus") is None:
        return out
    # the strain is this function's own, dropped below: it becomes the stress (memory)
    out = conversions.axial_stress_channel(out, _CONVERTED, youngs_modulus=p["youngs_modulus"],
                                           name=f"{_CONVERTED}_stress", overwrite=True)
    return out.drop_vars(_CONVERTED).rename({f"{_CONVERTED}_stress": _CONVERTED})


def _convert_channel(ds: xr.Dataset, channel: ChannelSpec, overwrite: bool) -> xr.Dataset:
    """Return ``ds`` with the channel's converted values in the variable ``__converted``.

    ``overwrite``: the channel's values may become the converted ones (:func:`convert_stream`).
    """
    p = channel.params
    name = channel.name
    null = NULL_WINDOW_S if p.get("null_offset") == "first_second" else None
    if channel.sensor == "charge_accelerometer":
        return conversions.acceleration_channel(
            ds, name, charge_sensitivity=p["charge_sensitivity"],
            amplifier_gain=p["amplifier_gain"] * 1e3,  # map: V/pC; processing: mV/pC
            highpass_hz=p.get("highpass_hz") if p.get("correct_highpass") else None,
            name=_CONVERTED, overwrite=overwrite)
    if channel.sensor in ("strain_bridge", "torsion_bridge"):
        return _bridge(ds, channel, null, overwrite)
    if channel.sensor == "linear":
        try:
            return conversions.linear_channel(ds, name, slope=p["slope"], offset=p["offset"],
                                          units=p["units"], input_units=p["input_units"],
                                          name=_CONVERTED)
        except UnitError as error:
            raise ChannelMapError(f"{channel.key}.input_units: {error.message}",
                                  where={"key": f"{channel.key}.input_units"},
                                  hint=error.hint) from None
    if channel.sensor == "iepe_accelerometer":
        return conversions.iepe_acceleration_channel(ds, name, sensitivity=p["sensitivity"],
                                                 name=_CONVERTED)
    if channel.sensor == "load_cell":
        try:
            return conversions.load_cell_channel(
                ds, name, sensitivity=p["sensitivity"], capacity=p["capacity"],
                excitation_voltage=p.get("excitation"), unstrained=null, name=_CONVERTED)
        except ConfigError as error:
            if error.where.get("key") != "excitation_voltage":
                raise
            raise ChannelMapError(f"{channel.key}.excitation: {error.message}",
                                  where={"key": f"{channel.key}.excitation"},
                                  hint="give the bridge excitation in V for a channel read in "
                                       "volts") from None
    units = str(ds[name].attrs.get("units", "1"))
    if channel.sensor in ("voltage", "physical") and not same_unit(units,
                                                                  channel_units(channel)):
        raise UnitError(f"{channel.source!r} is in {units!r} in the file, the channel map says "
                        f"{channel_units(channel)!r}")
    return ds  # encoders and reference pulses: turned into angles and events where used


def convert_stream(stream: xr.Dataset, spec: StreamSpec, *, overwrite: bool = False
                   ) -> xr.Dataset:
    """Convert a stream's channels to physical units as its channel map says.

    Parameters
    ----------
    stream : xarray.Dataset
        The stream as :func:`rigval.acquisition.channel_map.load_stream` returns it (channel
        variables named as in the map).
    spec : StreamSpec
        The stream's channel map (a scene's ``[streams.X]`` table).
    overwrite : bool, default False
        The caller lets ``stream`` go after: a float64 channel of a charge accelerometer, strain
        or torsion bridge is converted in its own memory instead of a copy (memory: one
        whole-record array less per channel; the same values); ``stream`` must not be used
        afterwards.

    Returns
    -------
    xarray.Dataset
        The same samples; converted channels (float64) replace the raw ones under the same
        names, with ``units``, ``conversion`` and the calibration in their attributes, plus
        ``sensor`` and ``scene_key`` (the channel's key path).

    Raises
    ------
    ChannelMapError
        When a channel's unit in the file does not fit its declared sensor, or a needed
        calibration value (the excitation of a bridge read in volts) is missing; ``where``
        names the key path and the file.
    """
    out = stream
    for name, channel in spec.channels.items():
        try:
            converted = _convert_channel(out, channel, overwrite)
        except (UnitError, ConfigError) as error:
            if isinstance(error, ChannelMapError):
                raise
            raise ChannelMapError(f"{channel.key}: {error.message}",
                                  where={"key": f"{channel.key}.sensor", "file": str(spec.file)},
                                  hint=error.hint or "check the channel's sensor kind and its "
                                                     "unit in the file (rigval info FILE)"
                                  ) from None
        if _CONVERTED in converted:
            attrs = {**converted[_CONVERTED].attrs,
                     "long_name": stream[name].attrs.get("long_name", name),
                     "sensor": channel.sensor, "scene_key": channel.key}
            out = converted.drop_vars(_CONVERTED).assign(
                {name: converted[_CONVERTED].assign_attrs(attrs)})
    return out
