"""Conversions worked in place on their one copy equal the formulas with fresh arrays.

The accelerometer and bridge-ratio conversions scale, correct and NaN-fill their own copy of
the channel (memory); the values must equal the whole-record formulas they replaced, computed
here with new arrays, bit for bit, on a stream with a gap and invalid samples. Handed the
channel (``overwrite``, the angle stage's read), they convert it in its own memory: the same
values again, bit for bit.
"""

from __future__ import annotations

import numpy as np
import pytest

from rigval.acquisition.channel_map import parse_stream
from rigval.acquisition.schema import Channel, stream_dataset
from rigval.processing import accelerometer, bridge, conversions, sensors
from rigval.processing.filters import contiguous_runs

FS = 1000.0
N = 12_000


def _stream(units: str) -> tuple:
    """A channel with a segment change at 7000, invalid samples at its start and inside."""
    rng = np.random.default_rng(5)
    values = 0.3 * np.sin(np.arange(N) / FS * 6.0) + 0.01 + rng.normal(0.0, 1e-3, N)
    segment = (np.arange(N) >= 7000).astype(np.int32)
    valid = np.ones(N, dtype=bool)
    valid[:40] = False
    valid[3000:3100] = False
    ds = stream_dataset(np.arange(N) / FS, {"x": Channel(values.copy(), units, "x", "x")},
                        device="cDAQ-9172", start_time="2026-03-02T10:00:00Z",
                        source_file="x.tdms", source_sha256="0" * 64, fs_nominal=FS,
                        valid=valid, invalid_counts={"dropout": 140}, segment=segment)
    return ds, values, segment, valid


@pytest.mark.parametrize("highpass_hz", [None, 0.1])
def test_acceleration_in_its_copy_equals_a_new_output_array(highpass_hz: float | None) -> None:
    ds, values, segment, valid = _stream("mV")
    expected = np.full(N, np.nan)
    for start, stop in contiguous_runs(N, segment, valid):
        piece = values[start:stop] * 1e-3
        piece -= piece.mean()
        expected[start:stop] = accelerometer.acceleration_from_voltage(
            piece, charge_sensitivity=10.0, amplifier_gain=1.0, fs=FS, highpass_hz=highpass_hz)
    out = conversions.acceleration_channel(ds, "x", charge_sensitivity=10.0, amplifier_gain=1.0,
                                           highpass_hz=highpass_hz)
    assert np.array_equal(out["x_acceleration"].to_numpy(), expected, equal_nan=True)
    assert np.isnan(expected[:40]).all() and np.isfinite(expected[40:3000]).all()
    assert np.array_equal(ds["x"].to_numpy(), values)  # the channel itself untouched


@pytest.mark.parametrize(("units", "unstrained", "expected"), [
    ("mV/V", None, lambda v, w: v * 1e-3),
    ("mV", 1e-4, lambda v, w: v * 1e-3 / 2.5 - 1e-4),
    ("V", (0.5, 1.5), lambda v, w: v / 2.5 - float(np.mean((v / 2.5)[w]))),
])
def test_bridge_ratio_in_its_copy_equals_the_formula(units, unstrained, expected) -> None:
    ds, values, _, valid = _stream(units)
    time = np.arange(N) / FS
    window = (time >= 0.5) & (time <= 1.5) & valid
    ratio = conversions.bridge_ratio_values(ds, "x", excitation_voltage=2.5,
                                            unstrained=unstrained)
    assert np.array_equal(ratio, expected(values, window))
    assert np.array_equal(ds["x"].to_numpy(), values)


@pytest.mark.parametrize("bridge_type", ["quarter_i", "quarter_ii", "half_i", "half_ii",
                                         "full_i", "full_ii", "full_iii"])
def test_strain_in_the_ratio_memory_equals_the_formula(bridge_type: str) -> None:
    vr = np.random.default_rng(6).uniform(-2e-3, 2e-3, 5000)
    vr[[3, 7]] = [np.nan, 0.0]
    gf, nu, lead = 2.05, 0.29, 1.0 + 0.5 / 350.0
    formulas = {  # NI's equations, each written out with new arrays
        "quarter_i": lambda v: -4.0 * v / (gf * (1.0 + 2.0 * v)) * lead,
        "half_i": lambda v: -4.0 * v / (gf * ((1.0 + nu) - 2.0 * v * (nu - 1.0))) * lead,
        "half_ii": lambda v: -2.0 * v / gf * lead,
        "full_i": lambda v: -v / gf,
        "full_ii": lambda v: -2.0 * v / (gf * (nu + 1.0)),
        "full_iii": lambda v: -2.0 * v / (gf * ((nu + 1.0) - v * (nu - 1.0))),
    }
    formulas["quarter_ii"] = formulas["quarter_i"]
    kwargs = {"gauge_factor": gf, "poisson": nu, "gauge_resistance": 350.0,
              "lead_resistance": 0.5, "gain_adjust": 1.01}
    copied = bridge.strain_from_ratio(vr, bridge_type, **kwargs)
    own = vr.copy()
    in_place = bridge.strain_from_ratio(own, bridge_type, overwrite=True, **kwargs)
    assert np.shares_memory(in_place, own)
    assert np.array_equal(in_place, copied, equal_nan=True)
    expected = formulas[bridge_type](vr) * 1.01
    np.testing.assert_allclose(copied, expected, rtol=1e-15, atol=0)


def _handed_over(units: str) -> tuple:
    """The stream of :func:`_stream` twice: one to convert as before, one whose channel is given."""
    ds, values, _, _ = _stream(units)
    given = ds.copy(deep=True)
    return ds, given, values


@pytest.mark.parametrize("highpass_hz", [None, 0.1])
def test_acceleration_in_the_handed_over_channel_equals_its_copy(highpass_hz) -> None:
    ds, given, values = _handed_over("mV")
    kwargs = {"charge_sensitivity": 10.0, "amplifier_gain": 1.0, "highpass_hz": highpass_hz}
    copied = conversions.acceleration_channel(ds, "x", **kwargs)["x_acceleration"].to_numpy()
    channel = given["x"].to_numpy()
    converted = conversions.acceleration_channel(given, "x", overwrite=True,
                                                 **kwargs)["x_acceleration"].to_numpy()
    assert np.shares_memory(converted, channel)
    assert converted.tobytes() == copied.tobytes()
    assert np.array_equal(ds["x"].to_numpy(), values)  # without overwrite: untouched


@pytest.mark.parametrize(("sensor", "params", "units"), [
    ("charge_accelerometer", {"charge_sensitivity": 9.61, "amplifier_gain": 0.01,
                              "highpass_hz": 0.1, "correct_highpass": True}, "V"),
    ("strain_bridge", {"bridge": "half_I", "gauge_factor": 2.02, "excitation": 2.5,
                       "gauge_resistance": 120.0, "lead_resistance": 0.0, "poisson": 0.3,
                       "youngs_modulus": 210e9}, "V/V"),
    ("strain_bridge", {"bridge": "full_III", "gauge_factor": 2.02, "excitation": 2.5,
                       "gauge_resistance": 120.0, "lead_resistance": 0.0, "poisson": 0.3,
                       "null_offset": "first_second"}, "mV"),
    ("torsion_bridge", {"bridge": "full", "gauge_factor": 2.07, "excitation": 2.5,
                        "outer_diameter": 0.1, "inner_diameter": 0.06,
                        "shear_modulus": 80e9}, "mV/V"),
])
def test_stream_converted_in_its_own_memory_equals_the_copy(sensor, params, units) -> None:
    # the scene's sensors as the angle stage converts a channel it read: overwrite gives the
    # values of the conversion on a copy, bit for bit, and the channel's memory is reused
    # where the sensor converts in place
    spec = parse_stream({"file": "x.tdms", "device": "cDAQ-9172",
                         "channels": {"x": {"source": "x", "sensor": sensor, **params}}},
                        "streams.s")
    ds, given, values = _handed_over(units)
    copied = sensors.convert_stream(ds, spec)["x"].to_numpy()
    channel = given["x"].to_numpy()
    converted = sensors.convert_stream(given, spec, overwrite=True)["x"].to_numpy()
    assert converted.tobytes() == copied.tobytes()
    assert np.isfinite(copied).sum() > N // 2
    assert np.array_equal(ds["x"].to_numpy(), values)
    if sensor != "torsion_bridge":  # the torque is a new array from the ratio made in place
        assert np.shares_memory(converted, channel)


@pytest.mark.parametrize("bridge_type", ["quarter_i", "half_i", "full_iii"])
def test_strain_block_by_block_equals_the_whole_ratio(monkeypatch, bridge_type: str) -> None:
    # the strain is computed a block at a time (its denominators' memory): the values of the
    # formula on the whole ratio at once, bit for bit, across block edges and NaN samples
    ds, _, _, _ = _stream("mV/V")
    kwargs = {"gauge_factor": 2.05, "poisson": 0.29, "gauge_resistance": 350.0,
              "lead_resistance": 0.5, "gain_adjust": 1.01}
    whole = bridge.strain_from_ratio(conversions.bridge_ratio_values(ds, "x"), bridge_type,
                                     **kwargs)
    monkeypatch.setattr(conversions, "_BLOCK", 1000)
    blocks = conversions.strain_channel(ds, "x", bridge_type=bridge_type, name="eps",
                                        **kwargs)["eps"].to_numpy()
    assert blocks.tobytes() == whole.tobytes()
