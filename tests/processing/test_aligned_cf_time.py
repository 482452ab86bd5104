"""Aligned streams carry CF time: ``seconds since <reference start>`` decodes to wall clock.

The independent expectation: when a device's clock model matches its start stamps (it started
``LAG`` s after the reference, clocks exact), the decoded aligned time of every sample equals the
decoded raw time of the same sample, which comes from the device's own start stamp.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from rigval.acquisition.schema import Channel, stream_dataset
from rigval.processing import clock_fit, timeline

FS, LAG = 100.0, 2.5
REF_START, DEV_START = "2026-11-21T06:00:00.125Z", "2026-11-21T06:00:02.625Z"


def _stream(start: str, device: str) -> xr.Dataset:
    time = np.arange(400) / FS
    return stream_dataset(time, {"x": Channel(np.sin(time), "V", "x", "x", "none", {})},
                          device=device, start_time=start, source_file="x.csv",
                          source_sha256="0" * 64, fs_nominal=FS)


def _decoded(ds: xr.Dataset, path: Path) -> xr.Dataset:
    xr.DataTree.from_dict({"/aligned/s": ds}).to_netcdf(path, engine="netcdf4")
    with xr.open_datatree(path, engine="netcdf4", decode_times=False) as tree:
        return xr.decode_cf(tree["/aligned/s"].to_dataset()).load()


def test_aligned_time_decodes_to_the_wall_clock_of_each_sample(tmp_path: Path) -> None:
    ref, dev = _stream(REF_START, "ref"), _stream(DEV_START, "dev")
    clock = clock_fit.ClockModel((0,), (LAG,), 0.0, 0.0, 10, 10)
    aligned = clock_fit.align_stream(dev, clock, name="dev",
                                     reference_start=ref.attrs["start_time"])
    assert aligned["time"].attrs["units"] == "seconds since 2026-11-21 06:00:00.125000000"
    np.testing.assert_allclose(aligned["time"].to_numpy(), LAG + dev["time"].to_numpy())
    decoded = _decoded(aligned, tmp_path / "a.nc")
    raw = _decoded(dev, tmp_path / "raw.nc")
    assert decoded["time"].dtype.kind == "M" and decoded["device_time"].dtype.kind == "M"
    # decoding rounds float seconds to whole ns: LAG + t and t differ in their last bit
    ns = (decoded["time"].to_numpy() - raw["time"].to_numpy()) / np.timedelta64(1, "ns")
    assert np.abs(ns).max() <= 1
    np.testing.assert_array_equal(decoded["device_time"].to_numpy(), raw["time"].to_numpy())
    assert decoded["time"].to_numpy()[0] == np.datetime64("2026-11-21T06:00:02.625")


def test_reference_stream_and_common_timeline_use_the_reference_origin(tmp_path: Path) -> None:
    ref, dev = _stream(REF_START, "ref"), _stream(DEV_START, "dev")
    aligned = {"ref": clock_fit.align_stream(ref, clock_fit.identity_clock()),
               "dev": clock_fit.align_stream(
                   dev, clock_fit.ClockModel((0,), (LAG,), 0.0, 0.0, 10, 10),
                   reference_start=ref.attrs["start_time"])}
    assert aligned["ref"]["time"].attrs["units"] == aligned["dev"]["time"].attrs["units"]
    common = timeline.common_timeline(aligned, "ref", channels={"ref": ["x"], "dev": ["x"]})
    assert list(common.attrs["streams"]) == ["ref", "dev"]
    assert common["dev_x"].attrs["segments"].tolist() == [0]
    assert common["dev_x"].attrs["unaligned_segments"].size == 0
    decoded = _decoded(common, tmp_path / "c.nc")
    start = np.datetime64("2026-11-21T06:00:00.125")
    np.testing.assert_array_equal(decoded["time"].to_numpy()[:3],
                                  start + np.array([0, 10, 20], dtype="timedelta64[ms]"))
    assert decoded["dev_x"].attrs["segment_clock_offset_s"] == LAG  # one entry comes back scalar


def test_aligned_time_index_shares_the_time_array() -> None:
    """The index over the reference times is no second copy of them; same values and labels."""
    ref, dev = _stream(REF_START, "ref"), _stream(DEV_START, "dev")
    clock = clock_fit.ClockModel((0,), (LAG,), 1e-5, 0.0, 10, 10)
    aligned = clock_fit.align_stream(dev, clock, name="dev",
                                     reference_start=ref.attrs["start_time"])
    expected = clock.to_reference(dev["time"].to_numpy(), dev["segment"].to_numpy())
    values = aligned["time"].to_numpy()
    np.testing.assert_array_equal(values, expected)
    assert np.shares_memory(aligned.xindexes["time"].index.to_numpy(), values)
    assert float(aligned.sel(time=expected[7])["x"]) == float(dev["x"][7])
    np.testing.assert_array_equal(aligned["device_time"].to_numpy(), dev["time"].to_numpy())
