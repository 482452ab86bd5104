"""Scene channel maps applied to streams: raw channels to physical units.

Each channel's ``sensor`` (``docs/scene.md``) picks a conversion of :mod:`rigval.processing`:
charge amplifier volts to m s-2, bridge ratios to strain or stress, rosette ratios to shaft torque.
Encoders (counts) and reference pulses (volts) stay as read; the pipeline turns them into angles
and events. A channel whose unit in the file does not fit its declared sensor is a
:class:`~rigval.acquisition.errors.SceneError` naming the channel's key.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr

from rigval.acquisition.channel_map import ChannelSpec, StreamSpec
from rigval.acquisition.errors import SceneError
from rigval.processing.accelerometer import acceleration_from_voltage
from rigval.processing.bridge import strain_from_ratio
from rigval.processing.filters import contiguous_runs
from rigval.processing.torsion import torque_from_ratio
from rigval.validation.scene import channel_units
from rigval.validation.units import dimension

__all__ = ["convert_stream"]

logger = logging.getLogger(__name__)

#: Seconds at the start of a record averaged for ``null_offset = "first_second"``.
NULL_SECONDS = 1.0


def _volts(values: np.ndarray, units: str, channel: ChannelSpec) -> np.ndarray:
    """Return values in V, accepting V and mV; anything else is a scene error."""
    scale = {"V": 1.0, "mV": 1e-3}.get(units.strip())
    if scale is None:
        raise SceneError(
            f"{channel.key}: the file gives {channel.source!r} in {units!r}, but a "
            f"{channel.sensor} channel is read in volts", where={"key": f"{channel.key}.sensor"},
            hint='check the channel, or declare sensor = "physical" with its units')
    return values * scale


def _ratio(values: np.ndarray, units: str, channel: ChannelSpec) -> np.ndarray:
    """Return a bridge signal as the voltage ratio Vr (V/V); volts are divided by the excitation."""
    text = units.strip()
    if text in ("V/V", "1", "V V-1"):
        return values
    if text == "mV/V":
        return values * 1e-3
    excitation = channel.params.get("excitation")
    if excitation is None:
        raise SceneError(f"{channel.key}.excitation: the file gives {channel.source!r} in "
                         f"{units!r}; the bridge excitation is needed to form V/V",
                         where={"key": f"{channel.key}.excitation"},
                         hint="add excitation = <volts> to the channel table")
    return _volts(values, units, channel) / float(excitation)


def _null(values: np.ndarray, time: np.ndarray, valid: np.ndarray, channel: ChannelSpec
          ) -> np.ndarray:
    """Subtract the mean of the first second of valid samples (``null_offset``)."""
    if channel.params.get("null_offset", "none") != "first_second":
        return values
    first = valid & (time <= time[0] + NULL_SECONDS)
    return values - float(np.mean(values[first])) if first.any() else values


def _convert(values: np.ndarray, units: str, channel: ChannelSpec, stream: xr.Dataset
             ) -> tuple[np.ndarray, dict[str, Any]]:
    """Return converted values and their scaling note for one channel."""
    p = channel.params
    time = stream["time"].to_numpy()
    valid = stream["valid"].to_numpy()
    if channel.sensor == "charge_accelerometer":
        volts = _volts(values, units, channel)
        out = np.full(volts.size, np.nan)
        corner = p["highpass_hz"] if p["correct_highpass"] else None
        fs = float(stream.attrs["fs_nominal"])
        for start, stop in contiguous_runs(volts.size, stream["segment"].to_numpy(), valid):
            part = volts[start:stop]
            if corner is not None:
                part = part - float(np.mean(part))  # the inverse high-pass ramps on an offset
            out[start:stop] = acceleration_from_voltage(
                part, charge_sensitivity=p["charge_sensitivity"],
                amplifier_gain=p["amplifier_gain"] * 1e3, fs=fs, highpass_hz=corner)
        note = (f"charge amplifier: {p['charge_sensitivity']} pC/g, {p['amplifier_gain']} V/pC"
                + (f", high-pass {corner} Hz undone" if corner else ""))
        return out, {"scaling": note}
    if channel.sensor == "strain_bridge":
        ratio = _null(_ratio(values, units, channel), time, valid, channel)
        strain = strain_from_ratio(ratio, p["bridge"].lower(), gauge_factor=p["gauge_factor"],
                                   poisson=p["poisson"], gauge_resistance=p["gauge_resistance"],
                                   lead_resistance=p["lead_resistance"])
        if p["youngs_modulus"] is None:
            return strain, {"scaling": f"NI {p['bridge']} bridge, GF {p['gauge_factor']}"}
        return strain * p["youngs_modulus"], {
            "scaling": f"NI {p['bridge']} bridge, GF {p['gauge_factor']}, "
                       f"E {p['youngs_modulus']:g} Pa"}
    if channel.sensor == "torsion_bridge":
        ratio = _null(_ratio(values, units, channel), time, valid, channel)
        torque = torque_from_ratio(ratio, p["bridge"], gauge_factor=p["gauge_factor"],
                                   shear_modulus=p["shear_modulus"],
                                   outer_diameter=p["outer_diameter"],
                                   inner_diameter=p["inner_diameter"])
        return torque, {"scaling": f"{p['bridge']} rosette bridge, GF {p['gauge_factor']}, "
                                   f"G {p['shear_modulus']:g} Pa, D {p['outer_diameter']} m, "
                                   f"d {p['inner_diameter']} m"}
    if channel.sensor == "voltage":
        return _volts(values, units, channel), {}
    if channel.sensor == "physical":
        if dimension(units) != dimension(channel_units(channel)):
            raise SceneError(
                f"{channel.key}: the file gives {channel.source!r} in {units!r}, the scene says "
                f"{channel_units(channel)!r}", where={"key": f"{channel.key}.units"},
                hint="set units to the file's unit or convert the channel")
        return values, {}
    return values, {}  # encoders and reference pulses: converted where they are used


def convert_stream(stream: xr.Dataset, spec: StreamSpec) -> xr.Dataset:
    """Convert a stream's channels to physical units as its scene table says.

    Parameters
    ----------
    stream : xarray.Dataset
        The stream as read, its channel variables named as in the scene.
    spec : StreamSpec
        The scene's stream table.

    Returns
    -------
    xarray.Dataset
        The same samples; converted channels in float64 with ``units`` set to the scene unit,
        the calibration in the attributes and the conversion in ``scaling``.

    Raises
    ------
    SceneError
        When a channel's unit in the file does not fit its declared sensor.
    """
    out = stream.copy()
    for name, channel in spec.channels.items():
        var = stream[name]
        units = str(var.attrs.get("units", "1"))
        values, extra = _convert(var.to_numpy().astype(np.float64), units, channel, stream)
        attrs: Mapping[str, Any] = {
            **var.attrs,
            **{k: int(v) if isinstance(v, bool) else v for k, v in channel.params.items()
               if v is not None},
            "sensor": channel.sensor, "units_in_file": units, **extra,
            "units": units if channel.sensor == "encoder" else channel_units(channel),
        }
        out[name] = xr.DataArray(values, dims=var.dims, attrs=dict(attrs))
    return out
