"""Every real NI file of the test data (``realdata_dir`` fixture) reads; values, lengths and time
axes are checked.

TDMS values and lengths are compared with nptdms; time axes with the files' own wf_* properties
read through nptdms (``raw_timestamps=True`` keeps sub-microsecond start times). LVM values are
compared with an independent line-by-line parse in this test.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from nptdms import TdmsFile

from rigval.acquisition import read, read_stream
from rigval.acquisition.errors import DataWarning
from rigval.acquisition.schema import check_stream, parse_start_time
from rigval.acquisition.time_fallbacks import TimeFallback, time_fallbacks

TDMS_FILES = ["npTDMS/Digital_Input.tdms", "npTDMS/raw1.tdms", "npTDMS/big_endian.tdms",
              "npTDMS/raw_timestamps.tdms", "nidaqmx-python/data_ai.tdms",
              "nidaqmx-python/data_ci1.tdms", "nidaqmx-python/data_ci2.tdms",
              "nidaqmx-python/TestData.tdms"]


def _start_ns(channel: object) -> np.datetime64:
    return channel.properties["wf_start_time"].as_datetime64("ns")  # type: ignore[attr-defined]


@pytest.mark.parametrize("name", TDMS_FILES)
def test_tdms_values_lengths_and_time_axis_match_nptdms(realdata_dir: Path, name: str) -> None:
    path = realdata_dir / name
    streams = read(path)
    reference = TdmsFile.read(path, raw_timestamps=True)
    seen = 0
    for ds in streams.values():
        check_stream(ds)
        group = reference[ds.attrs["tdms_group"]]
        for var in ds.data_vars:
            if var in ("valid", "segment"):
                continue
            channel = group[var]
            expected = channel[:]
            assert ds[var].size == len(expected)
            np.testing.assert_array_equal(ds[var].values, expected)
            dt = channel.properties["wf_increment"]
            np.testing.assert_allclose(np.diff(ds.time.values), dt, rtol=1e-9)
            seen += 1
        assert ds.time.values[0] == 0.0
        assert ds.attrs["gap_count"] == 0
    assert seen == sum(len(g.channels()) for g in reference.groups()
                       if "Decimated" not in g.name)


def test_daqmx_start_times_keep_the_per_channel_convert_delay(realdata_dir: Path) -> None:
    path = realdata_dir / "nidaqmx-python/data_ai.tdms"
    ds = read_stream(path)
    group = TdmsFile.read(path, raw_timestamps=True)["_unnamedTask<0>"]
    t1, t2 = _start_ns(group["Torque01"]), _start_ns(group["Torque02"])
    assert parse_start_time(ds.attrs["start_time"]) == t1
    offset = ds["Torque02"].attrs["time_offset_s"]
    assert offset == pytest.approx((t2 - t1) / np.timedelta64(1, "s"), abs=1e-9)
    assert offset == pytest.approx(11e-6, abs=0.5e-6)
    assert ds["Torque01"].attrs["time_offset_s"] == 0.0


def test_session_files_report_their_own_start_times(realdata_dir: Path) -> None:
    folder = realdata_dir / "nidaqmx-python"
    starts = {name: parse_start_time(read_stream(folder / name).attrs["start_time"])
              for name in ("data_ai.tdms", "data_ci1.tdms", "data_ci2.tdms")}
    spread = (max(starts.values()) - min(starts.values())) / np.timedelta64(1, "ms")
    assert 6 <= spread <= 50  # the "synchronised" session's tasks start tens of ms apart


def test_sub_microsecond_start_time_is_kept(realdata_dir: Path) -> None:
    path = realdata_dir / "npTDMS/raw_timestamps.tdms"
    ds = read_stream(path)
    expected = _start_ns(TdmsFile.read(path, raw_timestamps=True)["Untitled"]["Untitled"])
    # nptdms truncates the 2**-64 s fraction to ns, rigval rounds it
    assert abs(parse_start_time(ds.attrs["start_time"]) - expected) <= np.timedelta64(1, "ns")
    assert expected.astype("datetime64[ns]").astype(np.int64) % 1000 != 0


def test_signalexpress_decimated_groups_are_skipped_and_missing_offset_noted(
        realdata_dir: Path) -> None:
    path = realdata_dir / "npTDMS/Digital_Input.tdms"
    streams = read(path)
    assert len(streams) == 1
    (name, ds), = streams.items()
    assert name.endswith("All Data")
    assert ds.sizes["time"] == 20000
    assert time_fallbacks(ds.attrs)[0] == TimeFallback("no wf_start_offset", "taken as 0 s")
    everything = read(path, include_decimated=True)
    assert sorted(ds.sizes["time"] for ds in everything.values()) == [8, 400, 20000]


def test_big_endian_relative_time_takes_the_experiment_start(realdata_dir: Path) -> None:
    path = realdata_dir / "npTDMS/big_endian.tdms"
    ds = read_stream(path)
    channel = TdmsFile.read(path, raw_timestamps=True)["Measured Data"]["Amplitude sweep"]
    expected = channel.properties["NI_ExpStartTimeStamp"].as_datetime64("ns")
    assert abs(parse_start_time(ds.attrs["start_time"]) - expected) <= np.timedelta64(1, "ns")
    assert ds.attrs["relative_time"] == 1


def test_coerced_rate_of_a_24_bit_module_and_its_input_delay(realdata_dir: Path) -> None:
    ds = read_stream(realdata_dir / "nidaqmx-python/TestData.tdms", device="WLS-9163")
    assert ds.attrs["fs_nominal"] == pytest.approx(50_000 / 31)
    attrs = ds["Dev2/ai0"].attrs
    assert attrs["rate_divider"] == 31
    assert attrs["input_delay_s"] == pytest.approx((40 + 5 / 512) * 0.00062 + 4.5e-6)
    assert attrs["units"] == "V"


def _independent_lvm(path: Path, columns: list[int], decimal: str) -> np.ndarray:
    rows = []
    lines = path.read_text().splitlines()
    start = max(i for i, line in enumerate(lines) if line.startswith("X_Value")) + 1
    for line in lines[start:]:
        if not line.strip():
            continue
        cells = line.split("\t")
        rows.append([float(cells[c].replace(decimal, ".")) if cells[c].strip() else np.nan
                     for c in columns])
    return np.array(rows)


def test_lvm_decimal_comma_everywhere(realdata_dir: Path) -> None:
    path = realdata_dir / "lvm_read/short.lvm"
    ds = read_stream(path)
    expected = _independent_lvm(path, [1, 2], ",")
    np.testing.assert_array_equal(ds["Excitation (Trigger)"].values, expected[:, 0])
    np.testing.assert_array_equal(ds["Response (Trigger)"].values, expected[:, 1])
    np.testing.assert_allclose(np.diff(ds.time.values), 3.90625e-5, rtol=1e-12)
    assert ds["Response (Trigger)"].attrs["units"] == "m s-2"
    assert parse_start_time(ds.attrs["start_time"]) == np.datetime64(
        "2013-02-19T09:51:40.727189064")


def test_lvm_without_decimal_separator_uses_dots_of_the_data(realdata_dir: Path) -> None:
    path = realdata_dir / "lvm_read/no_decimal_separator.lvm"
    ds = read_stream(path, timezone="Europe/Berlin")
    expected = _independent_lvm(path, [1, 3, 5, 0], ".")
    for k, name in enumerate(("ax", "ay", "az")):
        np.testing.assert_array_equal(ds[name].values, expected[:, k])
    np.testing.assert_array_equal(ds.time.values, expected[:, 3])
    # 09:54:07,483999 CET is 08:54:07.483999 UTC
    assert parse_start_time(ds.attrs["start_time"]) == np.datetime64("2016-12-12T08:54:07.483999")


def test_lvm_with_empty_fields_keeps_channels_with_samples_and_warns(realdata_dir: Path) -> None:
    path = realdata_dir / "lvm_read/with_empty_fields.lvm"
    with pytest.warns(DataWarning, match=r"\(7, 100\)"):
        ds = read_stream(path)
    expected = _independent_lvm(path, [1, 2, 7], ".")
    assert [v for v in ds.data_vars if v not in ("valid", "segment")] == [
        "Dev0/Ai0", "Dev0/Ai2", "Dev0/Ai0 1"]
    np.testing.assert_array_equal(ds["Dev0/Ai2"].values, expected[:, 1])
    np.testing.assert_array_equal(ds["Dev0/Ai0 1"].values, expected[:, 2])
    np.testing.assert_allclose(ds.time.values, np.arange(7) * 0.001, atol=1e-12)
