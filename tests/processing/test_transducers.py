"""Linear, IEPE and load-cell conversions against their closed forms, with unit handling."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from rigval.acquisition.errors import ConfigError, UnitError
from rigval.processing import conversions, transducers

G0 = 9.80665  # m s-2, standard gravity (ISO 80000-3)


def _stream(values: np.ndarray, units: str) -> xr.Dataset:
    n = values.size
    return xr.Dataset(
        {"x": ("time", values, {"units": units, "source_channel": "/'g'/'x'"}),
         "valid": ("time", np.ones(n, dtype=bool)),
         "segment": ("time", np.zeros(n, dtype=np.int32))},
        coords={"time": np.arange(n) / 1000.0}, attrs={"fs_nominal": 1000.0})


def test_linear_closed_form_and_millivolt_input() -> None:
    rng = np.random.default_rng(3)
    volts = rng.uniform(-10, 10, 500)
    # a pressure transducer: 250 kPa per V, -12.5 kPa at 0 V
    out = conversions.linear_channel(_stream(volts, "V"), "x", slope=2.5e5, offset=-1.25e4,
                                 units="Pa", name="p")
    np.testing.assert_allclose(out["p"].to_numpy(), 2.5e5 * volts - 1.25e4, rtol=1e-14)
    assert out["p"].attrs["units"] == "Pa"
    # the same signal written in mV: rescaled to V before the slope per V applies
    out_mv = conversions.linear_channel(_stream(volts * 1e3, "mV"), "x", slope=2.5e5,
                                    offset=-1.25e4, units="Pa", name="p")
    np.testing.assert_allclose(out_mv["p"].to_numpy(), out["p"].to_numpy(), rtol=1e-12)
    # slope per mV/V on a channel in V/V
    ratio = volts * 1e-4
    out_r = conversions.linear_channel(_stream(ratio, "V/V"), "x", slope=3.0, units="N",
                                   input_units="mV/V", name="f")
    np.testing.assert_allclose(out_r["f"].to_numpy(), 3.0 * ratio * 1e3, rtol=1e-12)


def test_linear_refuses_an_input_unit_it_cannot_express() -> None:
    with pytest.raises(UnitError, match="expects 'V'") as info:
        conversions.linear_channel(_stream(np.ones(4), "V/V"), "x", slope=1.0, units="N")
    assert info.value.where["key"] == "input_units"
    with pytest.raises(ConfigError, match="non-zero"):
        transducers.linear_scale([1.0], slope=0.0)


def test_iepe_closed_form() -> None:
    volts = np.array([-0.5, 0.0, 0.1, 2.0])
    sensitivity = 100.0  # mV/g: 1 g per 0.1 V
    out = conversions.iepe_acceleration_channel(_stream(volts, "V"), "x", sensitivity=sensitivity,
                                            name="a")
    np.testing.assert_allclose(out["a"].to_numpy(), volts / 0.1 * G0, rtol=1e-14)
    assert out["a"].attrs["units"] == "m s-2"
    out_mv = conversions.iepe_acceleration_channel(_stream(volts * 1e3, "mV"), "x",
                                               sensitivity=sensitivity, name="a")
    np.testing.assert_allclose(out_mv["a"].to_numpy(), out["a"].to_numpy(), rtol=1e-14)
    with pytest.raises(UnitError, match="expected V or mV"):
        conversions.iepe_acceleration_channel(_stream(volts, "V/V"), "x", sensitivity=100.0)
    with pytest.raises(ConfigError, match="sensitivity"):
        transducers.iepe_acceleration(volts, sensitivity=-1.0)


def test_load_cell_closed_form_ratio_and_volts() -> None:
    force = np.linspace(-20e3, 50e3, 71)  # N
    capacity, sensitivity, excitation = 50e3, 2.0, 10.0  # N, mV/V, V
    ratio = force / capacity * sensitivity * 1e-3  # V/V, the rated output at the capacity
    out = conversions.load_cell_channel(_stream(ratio * 1e3, "mV/V"), "x", sensitivity=sensitivity,
                                    capacity=capacity, name="f")
    np.testing.assert_allclose(out["f"].to_numpy(), force, rtol=1e-12, atol=1e-9)
    assert out["f"].attrs["units"] == "N"
    out_v = conversions.load_cell_channel(_stream(ratio * excitation, "V"), "x",
                                      sensitivity=sensitivity, capacity=capacity,
                                      excitation_voltage=excitation, name="f")
    np.testing.assert_allclose(out_v["f"].to_numpy(), force, rtol=1e-12, atol=1e-9)
    # offset null over the first 10 ms (samples 0..10): the mean of that window is removed
    nulled = conversions.load_cell_channel(_stream(ratio + 1e-4, "V/V"), "x",
                                       sensitivity=sensitivity, capacity=capacity,
                                       unstrained=(0.0, 0.010), name="f")
    expected = force - force[:11].mean()
    np.testing.assert_allclose(nulled["f"].to_numpy(), expected, rtol=1e-9, atol=1e-6)
    with pytest.raises(ConfigError, match="excitation"):
        conversions.load_cell_channel(_stream(ratio, "V"), "x", sensitivity=2.0, capacity=1.0)
