"""Dataset-level sensor conversions: raw channels of a stream to physical quantities.

Each function takes a stream (or aligned stream), converts one channel with the numpy functions
of :mod:`~rigval.processing.bridge`, :mod:`~rigval.processing.torsion`,
:mod:`~rigval.processing.stress`, :mod:`~rigval.processing.accelerometer` and
:mod:`~rigval.processing.encoder`, and returns a copy with one new variable that carries
``units``, ``long_name``, ``source_channel`` (of the raw channel), ``conversion`` (formula and
parameters) and the raw channel's sensor metadata, and a ``history`` line. Nothing is changed in
place, unless the caller hands the raw channel over (``overwrite``: a stream it lets go after,
whose channel then becomes the converted one, no whole-record copy). Bridge channels may hold
the ratio (``"V/V"``, ``"mV/V"``) or the output voltage (``"V"``, ``"mV"``, then the excitation
is needed); the offset null is a value in V/V or the mean over a time window (a quiet,
unloaded period, or whole cycles).
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from rigval.acquisition.errors import ChannelNotFoundError, ConfigError, UnitError
from rigval.acquisition.schema import append_history
from rigval.acquisition.units import factor_or_none
from rigval.processing import accelerometer, bridge, encoder, stress, torsion, transducers
from rigval.processing.arrays import writable_float64
from rigval.processing.bridge import BridgeType
from rigval.processing.filters import contiguous_runs
from rigval.processing.torsion import Rosette

__all__ = [
    "acceleration_channel",
    "axial_bending_channels",
    "axial_stress_channel",
    "bridge_ratio_values",
    "encoder_angle_channel",
    "iepe_acceleration_channel",
    "linear_channel",
    "load_cell_channel",
    "strain_channel",
    "torque_channel",
]

logger = logging.getLogger(__name__)


Null = float | tuple[float, float] | None

#: Samples whose strain is computed at a time (its denominator's working array: 8 MiB).
_BLOCK = 1 << 20


def _channel(ds: xr.Dataset, name: str) -> xr.DataArray:
    if name not in ds:
        raise ChannelNotFoundError(f"no channel {name!r} in the stream",
                                   where={"file": ds.attrs.get("source_file"), "channel": name},
                                   available=[v for v in ds.data_vars
                                              if v not in ("valid", "segment")])
    return ds[name]


def _own_float64(values: np.ndarray, overwrite: bool) -> NDArray[np.float64]:
    """Return ``values`` when handed over (``overwrite``) as writeable float64, else a float64 copy.

    The caller scales the result in place: a copy first, or the channel's own memory when the
    caller lets the stream go after (memory); the same operations either way.
    """
    if overwrite and writable_float64(values):
        return values
    return values.astype(np.float64)


def _volts(ds: xr.Dataset, channel: str, sensor: str, *, overwrite: bool = False
           ) -> tuple[xr.DataArray, NDArray[np.float64]]:
    """Return a channel in volts: the variable and a float64 copy of its values in V.

    Parameters
    ----------
    ds : xarray.Dataset
        Stream holding the channel.
    channel : str
        Channel in V or mV (``units`` attribute).
    sensor : str
        The sensor the error names (``"accelerometer"``, ``"IEPE"``).
    overwrite : bool, default False
        The values become the channel's own memory, scaled in place, when it is float64
        (:func:`_own_float64`).

    Raises
    ------
    UnitError
        When the channel is not in a unit of voltage.
    """
    var = _channel(ds, channel)
    units = str(var.attrs.get("units", ""))
    per_volt = factor_or_none(units, "V")
    if per_volt is None:
        raise UnitError(f"{sensor} channel {channel!r} has units {units!r}, expected V or mV",
                        where={"channel": channel})
    volts = _own_float64(var.to_numpy(), overwrite)  # the caller scales and centres in place
    volts *= per_volt
    return var, volts


def bridge_ratio_values(ds: xr.Dataset, channel: str, *, excitation_voltage: float | None = None,
                        unstrained: Null = None, overwrite: bool = False) -> NDArray[np.float64]:
    """Return the offset-nulled bridge ratio Vr (V/V) of a bridge channel.

    Parameters
    ----------
    ds : xarray.Dataset
        Stream holding the channel.
    channel : str
        Bridge channel in V/V, mV/V, V or mV (``units`` attribute).
    excitation_voltage : float, optional
        Excitation in V; needed when the channel holds volts.
    unstrained : float or (float, float), optional
        Offset null: the unloaded ratio in V/V, or a time window ``(start_s, stop_s)`` whose valid
        samples are averaged; None for no offset null.
    overwrite : bool, default False
        The channel's float64 values are made the ratio in place (:func:`_own_float64`): the
        caller lets the stream go after.

    Returns
    -------
    numpy.ndarray
        Vr in V/V.
    """
    var = _channel(ds, channel)
    units = str(var.attrs.get("units", ""))
    # its own copy (or the handed-over channel), scaled in place (memory; the same operations
    # in the same order)
    ratio = _own_float64(var.to_numpy(), overwrite)
    per_ratio = factor_or_none(units, "V/V")  # V/V, mV/V, 1 (docs/formats.md units)
    per_volt = factor_or_none(units, "V")
    if per_ratio is not None:
        ratio *= per_ratio
    elif per_volt is not None:
        if excitation_voltage is None:
            raise ConfigError(f"channel {channel!r} holds {units}; the excitation voltage is "
                              "needed", where={"channel": channel, "key": "excitation_voltage"})
        ratio *= per_volt
        ratio /= excitation_voltage
    else:
        raise UnitError(f"bridge channel {channel!r} has units {units!r}; expected a bridge "
                        "ratio (V/V, mV/V) or a voltage (V, mV)", where={"channel": channel},
                        hint="check the reader's scaling: DAQmx strain channels are already "
                             "strain (units '1'); convert raw bridge channels only")
    if unstrained is None:
        return ratio
    if isinstance(unstrained, tuple):
        time = ds["time"].to_numpy()
        window = (time >= unstrained[0]) & (time <= unstrained[1]) & ds["valid"].to_numpy()
        if not window.any():
            raise ConfigError(f"the offset-null window {unstrained} s holds no valid sample",
                              where={"channel": channel, "key": "unstrained"})
        ratio -= float(np.mean(ratio[window]))
        return ratio
    ratio -= float(unstrained)
    return ratio


def _with_variable(ds: xr.Dataset, name: str, values: NDArray[np.float64], source: xr.DataArray,
                   source_name: str, *, units: str, long_name: str, conversion: str,
                   parameters: Mapping[str, Any]) -> xr.Dataset:
    sensor = {k: v for k, v in source.attrs.items()
              if k not in ("units", "long_name", "scaling", "source_channel")}
    attrs = {**sensor, "units": units, "long_name": long_name,
             "source_channel": source.attrs.get("source_channel", source_name),
             "scaling": source.attrs.get("scaling", "none"), "conversion": conversion,
             **{f"conversion_{k}": v for k, v in parameters.items() if v is not None}}
    out = ds.copy()
    out[name] = ("time", values, attrs)
    append_history(out, f"processing.conversions {source_name} -> {name}: {conversion}")
    return out


def strain_channel(ds: xr.Dataset, channel: str, *, bridge_type: BridgeType,
                   gauge_factor: float, name: str | None = None, poisson: float = 0.3,
                   gauge_resistance: float = 120.0, lead_resistance: float = 0.0,
                   gain_adjust: float = 1.0, excitation_voltage: float | None = None,
                   unstrained: Null = None, overwrite: bool = False) -> xr.Dataset:
    """Add the strain (1) of a bridge channel with NI's equation for its bridge type.

    Parameters
    ----------
    ds : xarray.Dataset
        Stream.
    channel : str
        Bridge channel (V/V, mV/V, V or mV).
    bridge_type : str
        NI configuration (:data:`~rigval.processing.bridge.BRIDGE_TYPES`).
    gauge_factor : float
        Gauge factor (1).
    name : str, optional
        Output variable; default ``<channel>_strain``.
    poisson, gauge_resistance, lead_resistance, gain_adjust : float
        As in :func:`~rigval.processing.bridge.strain_from_ratio` (1, ohm, ohm, 1).
    excitation_voltage : float, optional
        Excitation in V for channels in volts.
    unstrained : float or (float, float), optional
        Offset null (see :func:`bridge_ratio_values`).
    overwrite : bool, default False
        The bridge channel's float64 values become the strain (the caller lets ``ds`` go after;
        memory).

    Returns
    -------
    xarray.Dataset
        Copy of ``ds`` with the strain variable.
    """
    ratio = bridge_ratio_values(ds, channel, excitation_voltage=excitation_voltage,
                                unstrained=unstrained, overwrite=overwrite)
    # block by block into the ratio's memory, this function's own (or handed over): the
    # denominator's array is a block's, not the record's (memory); element by element the
    # same operations (identical values)
    eps = ratio
    for lo in range(0, ratio.size, _BLOCK):
        eps[lo:lo + _BLOCK] = bridge.strain_from_ratio(
            ratio[lo:lo + _BLOCK], bridge_type, gauge_factor=gauge_factor, poisson=poisson,
            gauge_resistance=gauge_resistance, lead_resistance=lead_resistance,
            gain_adjust=gain_adjust, overwrite=True)
    return _with_variable(
        ds, name or f"{channel}_strain", eps, ds[channel], channel, units="1",
        long_name=f"strain from {channel}", conversion=f"NI {bridge_type} bridge equation",
        parameters={"gauge_factor": gauge_factor, "poisson": poisson,
                    "gauge_resistance_ohm": gauge_resistance,
                    "lead_resistance_ohm": lead_resistance, "gain_adjust": gain_adjust,
                    "unstrained": str(unstrained)})


def torque_channel(ds: xr.Dataset, channel: str, *, rosette: Rosette, gauge_factor: float,
                   shear_modulus: float, outer_diameter: float, inner_diameter: float = 0.0,
                   name: str | None = None, sign: float = 1.0, gauge_resistance: float = 120.0,
                   lead_resistance: float = 0.0, excitation_voltage: float | None = None,
                   unstrained: Null = None, overwrite: bool = False) -> xr.Dataset:
    """Return a copy of ``ds`` with the shaft torque (N m) of a torsion rosette bridge channel.

    Parameters
    ----------
    ds, channel, gauge_factor, excitation_voltage, unstrained
        As in :func:`strain_channel`; the channel holds the rosette bridge.
    rosette : {"half", "full"}
        Bridge form (:mod:`~rigval.processing.torsion`).
    shear_modulus : float
        G in Pa.
    outer_diameter, inner_diameter : float
        Shaft diameters in m (inner 0: solid).
    name : str, optional
        Output variable; default ``<channel>_torque``.
    sign : float, default 1
        Torque sign convention (calibration constant).
    gauge_resistance, lead_resistance : float
        Ohm (half bridge lead correction).
    overwrite : bool, default False
        The bridge channel's float64 values become the ratio in place (the caller lets ``ds``
        go after; memory).
    """
    ratio = bridge_ratio_values(ds, channel, excitation_voltage=excitation_voltage,
                                unstrained=unstrained, overwrite=overwrite)
    torque = torsion.torque_from_ratio(ratio, rosette, gauge_factor=gauge_factor,
                                       shear_modulus=shear_modulus, outer_diameter=outer_diameter,
                                       inner_diameter=inner_diameter,
                                       gauge_resistance=gauge_resistance,
                                       lead_resistance=lead_resistance, sign=sign,
                                       overwrite=True)  # the ratio: a copy, or given up
    return _with_variable(
        ds, name or f"{channel}_torque", torque, ds[channel], channel, units="N m",
        long_name=f"shaft torque from {channel}",
        conversion=f"T = G gamma pi (D^4 - d^4) / (16 D), {rosette} rosette bridge",
        parameters={"gauge_factor": gauge_factor, "shear_modulus_pa": shear_modulus,
                    "outer_diameter_m": outer_diameter, "inner_diameter_m": inner_diameter,
                    "sign": sign, "unstrained": str(unstrained)})


def axial_stress_channel(ds: xr.Dataset, channel: str, *, youngs_modulus: float,
                         name: str | None = None, overwrite: bool = False) -> xr.Dataset:
    """Add the axial stress ``sigma = E eps`` (Pa) of a strain channel (units ``"1"``).

    With ``overwrite`` a float64 strain becomes the stress in place (the caller lets the strain
    go; memory), the same product.
    """
    var = _channel(ds, channel)
    if str(var.attrs.get("units")) != "1":
        raise UnitError(f"channel {channel!r} has units {var.attrs.get('units')!r}, expected "
                        "strain ('1')", where={"channel": channel},
                        hint="convert the bridge channel first with strain_channel")
    strain = var.to_numpy()
    sigma = (np.multiply(strain, youngs_modulus, out=strain)
             if overwrite and writable_float64(strain)
             else stress.axial_stress(strain, youngs_modulus))
    return _with_variable(ds, name or f"{channel}_stress", sigma, var, channel, units="Pa",
                          long_name=f"axial stress from {channel}", conversion="sigma = E eps",
                          parameters={"youngs_modulus_pa": youngs_modulus})


def axial_bending_channels(ds: xr.Dataset, top: str, bottom: str, *, name: str,
                           youngs_modulus: float | None = None,
                           section_modulus: float | None = None) -> xr.Dataset:
    """Add the axial and bending parts of two strain channels on opposite faces of a member.

    Parameters
    ----------
    ds : xarray.Dataset
        Stream with both strain channels (units ``"1"``).
    top, bottom : str
        Strain channels at 0 and 180 degrees round the member.
    name : str
        Prefix of the outputs ``<name>_axial_strain`` and ``<name>_bending_strain`` (1); with
        ``youngs_modulus`` also ``<name>_axial_stress`` (Pa), and with ``section_modulus`` too
        ``<name>_bending_moment`` (N m).
    youngs_modulus : float, optional
        E in Pa.
    section_modulus : float, optional
        W in m^3 (:func:`~rigval.processing.stress.tube_section_modulus`).

    Returns
    -------
    xarray.Dataset
        Copy of ``ds`` with the new variables.
    """
    for channel in (top, bottom):
        if str(_channel(ds, channel).attrs.get("units")) != "1":
            raise UnitError(f"channel {channel!r} has units {ds[channel].attrs.get('units')!r}, "
                            "expected strain ('1')", where={"channel": channel},
                            hint="convert the bridge channels first with strain_channel")
    axial, bending = stress.axial_and_bending(ds[top].to_numpy(), ds[bottom].to_numpy())
    pair = f"{top} and {bottom}"
    out = _with_variable(ds, f"{name}_axial_strain", axial, ds[top], top, units="1",
                         long_name=f"axial strain from {pair}",
                         conversion=f"(eps_{top} + eps_{bottom}) / 2", parameters={})
    out = _with_variable(out, f"{name}_bending_strain", bending, ds[top], top, units="1",
                         long_name=f"bending strain from {pair}",
                         conversion=f"(eps_{top} - eps_{bottom}) / 2", parameters={})
    if youngs_modulus is not None:
        out = _with_variable(out, f"{name}_axial_stress",
                             stress.axial_stress(axial, youngs_modulus), ds[top], top,
                             units="Pa", long_name=f"axial stress from {pair}",
                             conversion="sigma = E (eps_top + eps_bottom) / 2",
                             parameters={"youngs_modulus_pa": youngs_modulus})
        if section_modulus is not None:
            out = _with_variable(out, f"{name}_bending_moment",
                                 stress.bending_moment(bending, youngs_modulus, section_modulus),
                                 ds[top], top, units="N m",
                                 long_name=f"bending moment from {pair}",
                                 conversion="M = E W (eps_top - eps_bottom) / 2",
                                 parameters={"youngs_modulus_pa": youngs_modulus,
                                             "section_modulus_m3": section_modulus})
    return out


def acceleration_channel(ds: xr.Dataset, channel: str, *, charge_sensitivity: float,
                         amplifier_gain: float, highpass_hz: float | None = None,
                         name: str | None = None, remove_offset: bool = True,
                         overwrite: bool = False) -> xr.Dataset:
    """Add the acceleration (m s-2) of a charge-amplifier channel (V or mV).

    Parameters
    ----------
    ds : xarray.Dataset
        Stream.
    channel : str
        Amplifier output channel.
    charge_sensitivity : float
        S_q in pC/g.
    amplifier_gain : float
        G_amp in mV/pC.
    highpass_hz : float, optional
        Amplifier high-pass corner to correct (per gap-free run); None leaves it in.
    name : str, optional
        Output variable; default ``<channel>_acceleration``.
    remove_offset : bool, default True
        Subtract each run's mean voltage first (a charge amplifier passes no DC; an offset would
        turn into a ramp under the high-pass correction).
    overwrite : bool, default False
        The channel's float64 values become the acceleration (the caller lets ``ds`` go after;
        memory).

    Returns
    -------
    xarray.Dataset
        Copy of ``ds`` with the acceleration variable (NaN at invalid samples).
    """
    var, volts = _volts(ds, channel, "accelerometer", overwrite=overwrite)
    fs = float(ds.attrs["fs_nominal"])
    # each run's acceleration replaces its volts in the one array; NaN between the runs
    converted_to = 0
    for start, stop in contiguous_runs(volts.size, ds["segment"].to_numpy(),
                                       ds["valid"].to_numpy()):
        volts[converted_to:start] = np.nan
        piece = volts[start:stop]
        if remove_offset:
            piece -= piece.mean()
        accelerometer.acceleration_from_voltage(
            piece, charge_sensitivity=charge_sensitivity, amplifier_gain=amplifier_gain, fs=fs,
            highpass_hz=highpass_hz, overwrite=True)  # into the piece: no run-long array
        converted_to = stop
    volts[converted_to:] = np.nan
    return _with_variable(
        ds, name or f"{channel}_acceleration", volts, var, channel, units="m s-2",
        long_name=f"acceleration from {channel}",
        conversion="a = V / (S_q G_amp) g0" + (", high-pass corrected" if highpass_hz else ""),
        parameters={"charge_sensitivity_pc_per_g": charge_sensitivity,
                    "amplifier_gain_mv_per_pc": amplifier_gain, "highpass_hz": highpass_hz,
                    "offset_removed": str(remove_offset)})


def encoder_angle_channel(ds: xr.Dataset, channel: str, *, counts_per_rev: float,
                          name: str | None = None, gear_ratio: float = 1.0,
                          direction: float = 1.0, bits: int = 32,
                          index_reset: bool = False) -> xr.Dataset:
    """Add the raw (quantised, unwrapped) angle in rad of an encoder counter channel.

    ``bits`` is the counter width; ``index_reset`` undoes Z index reloads
    (:func:`~rigval.processing.encoder.remove_index_resets`). For derivatives use
    :func:`~rigval.processing.excitation.drive_excitation`, never differences of this angle.
    """
    var = _channel(ds, channel)
    counts = encoder.unwrap_counts(var.to_numpy(), bits=bits)  # its own int64 array
    if index_reset:
        counts, _ = encoder.remove_index_resets(counts, counts_per_rev * gear_ratio,
                                                overwrite=True)
    angle = encoder.counts_to_angle(counts, counts_per_rev, gear_ratio=gear_ratio,
                                    direction=direction, overwrite=True)
    return _with_variable(ds, name or f"{channel}_angle", angle, var, channel, units="rad",
                          long_name=f"angle from {channel}",
                          conversion="2 pi direction counts / (CPR gear_ratio)",
                          parameters={"counts_per_rev": counts_per_rev,
                                      "gear_ratio": gear_ratio, "direction": direction})


def linear_channel(ds: xr.Dataset, channel: str, *, slope: float, offset: float = 0.0,
                   units: str, input_units: str = "V", name: str | None = None) -> xr.Dataset:
    """Add ``slope x + offset`` of a channel, with ``x`` in ``input_units``.

    Parameters
    ----------
    ds : xarray.Dataset
        Stream.
    channel : str
        Input channel; its ``units`` must be ``input_units`` or another unit of the same
        dimension (``mV`` for ``V``, ``mV/V`` for ``V/V``, ``mA`` for ``A``), rescaled first
        (:func:`rigval.acquisition.units.factor_between`).
    slope : float
        Output units per input unit (finite, non-zero).
    offset : float, default 0
        Output at zero input, in ``units``.
    units : str
        Output unit (UDUNITS).
    input_units : str, default "V"
        The unit ``slope`` is per.
    name : str, optional
        Output variable; default ``<channel>_scaled``.

    Raises
    ------
    UnitError
        When the channel's unit cannot be expressed in ``input_units``.
    """
    var = _channel(ds, channel)
    file_units = str(var.attrs.get("units", ""))
    factor = 1.0 if file_units == input_units else factor_or_none(file_units, input_units)
    if factor is None:
        raise UnitError(f"channel {channel!r} is in {file_units!r}; the linear scale expects "
                        f"{input_units!r}", where={"channel": channel, "key": "input_units"},
                        hint="set input_units to the channel's unit in the file (rigval info "
                             "FILE) and the slope per that unit")
    values = transducers.linear_scale(var.to_numpy().astype(np.float64) * factor, slope=slope,
                                      offset=offset)
    return _with_variable(ds, name or f"{channel}_scaled", values, var, channel, units=units,
                          long_name=f"{channel} scaled", conversion="y = slope x + offset",
                          parameters={"slope": slope, "offset": offset,
                                      "input_units": input_units})


def iepe_acceleration_channel(ds: xr.Dataset, channel: str, *, sensitivity: float,
                              name: str | None = None) -> xr.Dataset:
    """Add the acceleration (m s-2) of an IEPE accelerometer channel (V or mV).

    Parameters
    ----------
    ds : xarray.Dataset
        Stream.
    channel : str
        Sensor output (V or mV).
    sensitivity : float
        S in mV/g.
    name : str, optional
        Output variable; default ``<channel>_acceleration``.
    """
    var, volts = _volts(ds, channel, "IEPE")
    accel = transducers.iepe_acceleration(volts, sensitivity=sensitivity)
    return _with_variable(ds, name or f"{channel}_acceleration", accel, var, channel,
                          units="m s-2", long_name=f"acceleration from {channel}",
                          conversion="a = V / (S / 1000) g0",
                          parameters={"sensitivity_mv_per_g": sensitivity})


def load_cell_channel(ds: xr.Dataset, channel: str, *, sensitivity: float, capacity: float,
                      excitation_voltage: float | None = None, unstrained: Null = None,
                      name: str | None = None) -> xr.Dataset:
    """Add the force (N) of a bridge load cell channel (V/V, mV/V, V or mV).

    Parameters
    ----------
    ds, channel, excitation_voltage, unstrained
        As in :func:`strain_channel`; the channel holds the load cell's bridge.
    sensitivity : float
        Rated output in mV/V.
    capacity : float
        Rated capacity in N.
    name : str, optional
        Output variable; default ``<channel>_force``.
    """
    ratio = bridge_ratio_values(ds, channel, excitation_voltage=excitation_voltage,
                                unstrained=unstrained)
    force = transducers.load_cell_force(ratio, sensitivity=sensitivity, capacity=capacity)
    return _with_variable(ds, name or f"{channel}_force", force, ds[channel], channel,
                          units="N", long_name=f"force from {channel}",
                          conversion="F = Vr / (S / 1000) F_rated",
                          parameters={"sensitivity_mv_per_v": sensitivity,
                                      "capacity_n": capacity, "unstrained": str(unstrained)})
