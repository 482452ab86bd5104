"""Stream time is CF-decodable to the nanosecond, lazy where the file gives blocks, typed tables.

Expectations are independent of rigval's time code: wall-clock times are the start as written
(integer nanoseconds from the 2**-64 s fraction) plus ``i * dt`` computed in integer or exact
rational nanoseconds; lazy time values and selections are compared with the same operations on
a plain float array built with numpy.
"""

from __future__ import annotations

import tracemalloc
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from nptdms import ChannelObject, GroupObject, RootObject, TdmsFile, TdmsWriter
from nptdms.timestamp import TdmsTimestamp

import rigval.acquisition as acquisition
from rigval.acquisition import iter_stream, read_stream
from rigval.acquisition.schema import (
    Channel,
    check_stream,
    invalid_counts,
    stream_dataset,
    stream_gaps,
)
from rigval.acquisition.time_index import BlockTimeIndex

FS = 51_200.0
#: 2025-11-26T07:00:00 plus a fraction of a second with sub-microsecond digits.
SECONDS_1904 = 3_846_985_200
FRACTION = 2**64 // 1_000_000 * 123 + 12_345_678_901_234


def _start_ns() -> int:
    """The written start time in ns since 1970 (the 2**-64 s fraction rounded to ns)."""
    since_1904 = Fraction(SECONDS_1904) + Fraction(FRACTION, 2**64)
    epoch_1970 = 2_082_844_800
    return round((since_1904 - epoch_1970) * 10**9)


def _write(path: Path, blocks: list[tuple[int, float]], channels: int = 2,
           seed: int = 0) -> tuple[Path, np.ndarray]:
    """Write blocks of ``(samples, start in s after the first)`` as TDMS segments."""
    rng = np.random.default_rng(seed)
    data = []
    with TdmsWriter(path) as writer:
        for k, (n, at) in enumerate(blocks):
            start = TdmsTimestamp(SECONDS_1904 + int(at), FRACTION + round((at % 1) * 2**64))
            values = rng.normal(size=(channels, n))
            data.append(values)
            props = {"wf_start_time": start, "wf_increment": 1 / FS, "wf_start_offset": 0.0}
            objects = [ChannelObject("task", f"ai{c}", values[c], props) for c in range(channels)]
            head = [RootObject({}), GroupObject("task")] if k == 0 else []
            writer.write_segment(head + objects)
    return path, np.concatenate(data, axis=1)


def _expected_seconds(blocks: list[tuple[int, float]]) -> np.ndarray:
    return np.concatenate([np.arange(n) / FS + at for n, at in blocks])


def test_time_decodes_to_wall_clock_to_the_nanosecond(tmp_path: Path) -> None:
    path, _ = _write(tmp_path / "t.tdms", [(4096, 0.0)])
    ds = read_stream(path)
    assert ds.attrs["Conventions"].startswith("CF-1.")
    assert ds["time"].attrs["units"].startswith("seconds since 2025-11-26 07:00:00.000123")
    assert ds["time"].attrs["calendar"] == "standard"
    # exact: start + i * 10**9 / 51200 ns = start + i * 19531.25 ns, rounded half to even
    exact = np.array([_start_ns() + round(Fraction(i * 10**9, 51_200)) for i in range(4096)])
    decoded = xr.decode_cf(ds)["time"].values.astype("datetime64[ns]").astype(np.int64)
    assert decoded[0] == _start_ns() and _start_ns() % 1000 != 0  # sub-microsecond start kept
    assert np.abs(decoded - exact).max() <= 1  # float seconds to ns: ties may round either way
    ds.to_netcdf(tmp_path / "t.nc", engine="netcdf4")
    with xr.open_dataset(tmp_path / "t.nc") as back:
        assert back["time"].dtype == np.dtype("datetime64[ns]")
        np.testing.assert_array_equal(back["time"].values.astype(np.int64), decoded)
        np.testing.assert_array_equal(back["ai0"].values, ds["ai0"].values)


def test_real_sub_microsecond_start_round_trips_through_netcdf(realdata_dir: Path,
                                                               tmp_path: Path) -> None:
    path = realdata_dir / "npTDMS/raw_timestamps.tdms"
    channel = TdmsFile.read(path, raw_timestamps=True)["Untitled"]["Untitled"]
    stamp = channel.properties["wf_start_time"]
    since_1904 = Fraction(stamp.seconds) + Fraction(stamp.second_fractions, 2**64)
    start_ns = round((since_1904 - 2_082_844_800) * 10**9)
    assert start_ns % 1000 != 0
    dt_ns = Fraction(channel.properties["wf_increment"]) * 10**9
    ds = read_stream(path)
    ds.to_netcdf(tmp_path / "raw.nc", engine="netcdf4")
    with xr.open_dataset(tmp_path / "raw.nc") as back:
        got = back["time"].values.astype("datetime64[ns]").astype(np.int64)
    exact = np.array([start_ns + round(i * dt_ns) for i in range(got.size)])
    assert got.size == len(channel) and np.abs(got - exact).max() <= 1


def test_lazy_time_equals_the_blocks_and_selects_like_pandas(tmp_path: Path) -> None:
    blocks = [(3000, 0.0), (2000, 3000 / FS + 1.25), (500, 3000 / FS + 1.25 + 2000 / FS + 0.5)]
    path, data = _write(tmp_path / "gaps.tdms", blocks)
    ds = read_stream(path)
    check_stream(ds)
    assert isinstance(ds.xindexes["time"], BlockTimeIndex)
    plain_time = _expected_seconds(blocks)
    np.testing.assert_allclose(ds["time"].values, plain_time, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(ds["ai1"].values, data[1])
    plain = xr.Dataset({"ai1": ("time", data[1])}, coords={"time": ds["time"].values})
    for a, b in [(0.01, 0.02), (0.05, 1.3), (3000 / FS, 3000 / FS + 1.25), (1.2, 1.5),
                 (-1.0, 0.0), (2.0, 9.0), (None, 0.5), (1.5, None)]:
        got = ds.sel(time=slice(a, b))
        want = plain.sel(time=slice(a, b))
        np.testing.assert_array_equal(got["time"].values, want["time"].values)
        np.testing.assert_array_equal(got["ai1"].values, want["ai1"].values)
    window = ds.isel(time=slice(2990, 3010))
    assert isinstance(window.xindexes["time"], BlockTimeIndex)
    np.testing.assert_array_equal(window["time"].values, ds["time"].values[2990:3010])
    np.testing.assert_array_equal(window["segment"].values, [0] * 10 + [1] * 10)
    picked = ds.isel(time=[5, 3001, 5499])
    np.testing.assert_array_equal(picked["time"].values, ds["time"].values[[5, 3001, 5499]])
    near = ds.sel(time=[1.3, 3000 / FS + 1.25], method="nearest")
    np.testing.assert_array_equal(near["ai1"].values,
                                  plain.sel(time=[1.3, 3000 / FS + 1.25], method="nearest")["ai1"])
    xr.testing.assert_equal(ds[["ai1"]], plain)


def test_gap_table_is_typed_data(tmp_path: Path) -> None:
    blocks = [(3000, 0.0), (2000, 3000 / FS + 1.25)]
    ds = read_stream(_write(tmp_path / "gap.tdms", blocks)[0])
    assert ds.attrs["gap_count"] == 1 and "gaps" not in ds.attrs
    assert float(ds.attrs["gap_start_s"][0]) == pytest.approx(2999 / FS, abs=1e-12)
    assert float(ds.attrs["gap_end_s"][0]) == pytest.approx(3000 / FS + 1.25, abs=1e-12)
    missing = int(ds.attrs["gap_missing_samples"][0])
    assert missing == round(1.25 * FS) == ds.attrs["missing_samples"]
    assert len(ds.to_dataframe()) == 5000  # one row per sample: the tables are not dimensions
    assert stream_gaps(ds)[0]["duration_s"] == pytest.approx(1.25, abs=1e-9)
    ds.to_netcdf(tmp_path / "gap.nc", engine="netcdf4")
    with xr.open_dataset(tmp_path / "gap.nc", decode_times=False) as back:
        assert stream_gaps(back) == stream_gaps(ds)
        assert invalid_counts(back) == {}
        np.testing.assert_array_equal(back["segment"].values, ds["segment"].values)


def test_windows_concatenate_to_the_whole_stream(tmp_path: Path) -> None:
    blocks = [(3000, 0.0), (2000, 3000 / FS + 1.25)]
    path, _ = _write(tmp_path / "w.tdms", blocks)
    whole = read_stream(path)
    windows = list(iter_stream(path, chunk_samples=1024))
    joined = xr.concat([w[["ai0", "ai1", "valid", "segment"]] for w in windows], dim="time",
                       coords="minimal")
    assert isinstance(joined.xindexes["time"], BlockTimeIndex)
    np.testing.assert_array_equal(joined["time"].values, whole["time"].values)
    np.testing.assert_array_equal(joined["segment"].values, whole["segment"].values)
    np.testing.assert_array_equal(joined["ai0"].values, whole["ai0"].values)


def test_reading_needs_about_the_channel_data_in_memory(tmp_path: Path) -> None:
    n, channels, segments = 1 << 19, 4, 64
    path = tmp_path / "big.tdms"
    props = {"wf_start_time": TdmsTimestamp(SECONDS_1904, FRACTION), "wf_increment": 1 / FS}
    with TdmsWriter(path) as writer:  # segments of 64 KiB per channel, as a DAQ writes them
        for k in range(segments):
            values = np.full((channels, n // segments), float(k))
            writer.write_segment([ChannelObject("task", f"ai{c}", values[c], props if k == 0
                                                else {}) for c in range(channels)])
    read_stream(path, checksum=False)  # imports and one-time set-up outside the measurement
    tracemalloc.start()
    try:
        ds = read_stream(path, checksum=False)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    data = n * channels * 8
    assert ds.sizes["time"] == n
    # time, valid and segment add nothing per sample: the 4 channels (16 MiB) plus 15 %
    assert peak <= 1.15 * data, f"peak {peak / 2**20:.1f} MiB for {data / 2**20:.0f} MiB of data"


def test_invalid_counts_are_a_table() -> None:
    time = np.arange(5) / 100.0
    valid = np.array([True, False, False, True, False])
    ds = stream_dataset(time, {"c": Channel(np.zeros(5), "V", "c", "c")}, device="x",
                        start_time="2026-01-01T00:00:00Z", source_file="f", source_sha256="0",
                        fs_nominal=100.0, valid=valid,
                        invalid_counts={"overrange": 2, "unaligned segment": 1})
    assert invalid_counts(ds) == {"overrange": 2, "unaligned segment": 1}
    assert int(ds.attrs["invalid_count"].sum()) == int((~ds["valid"]).sum())


@pytest.mark.parametrize("engine", ["netcdf4", "h5netcdf"])
def test_one_gap_and_one_reason_survive_netcdf(tmp_path: Path, engine: str) -> None:
    time = np.r_[np.arange(50), np.arange(80, 100)] / 100.0
    valid = np.ones(time.size, dtype=bool)
    valid[3] = False
    ds = stream_dataset(time, {"c": Channel(np.zeros(time.size), "V", "c", "c")}, device="x",
                        start_time="2026-01-01T00:00:00.5Z", source_file="f",
                        source_sha256="0", fs_nominal=100.0, valid=valid,
                        invalid_counts={"overrange": 1})
    ds.to_netcdf(tmp_path / "one.nc", engine=engine)
    with xr.open_dataset(tmp_path / "one.nc", engine=engine) as back:
        assert stream_gaps(back) == stream_gaps(ds)
        assert stream_gaps(back)[0]["missing_samples"] == 30
        assert invalid_counts(back) == {"overrange": 1}
        assert back["time"].values[0] == np.datetime64("2026-01-01T00:00:00.5")


def test_dir_lists_the_lazily_imported_readers() -> None:
    names = dir(acquisition)
    assert {"read", "read_stream", "iter_stream", "read_tdms", "read_csv", "read_lvm",
            "iter_tdms"} <= set(names)
    assert set(acquisition.__all__) <= set(names)
