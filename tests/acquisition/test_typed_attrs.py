"""File headers are typed attributes that survive a netCDF round trip (issue 18).

A header is data: ``text_header_keys``/``text_header_values`` (and the LVM ones) are string arrays,
not JSON text, and ``to_netcdf`` followed by ``open_datatree`` gives back the same mapping.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from nptdms import ChannelObject

from rigval.acquisition import read_stream
from rigval.acquisition.channel_map import sensor_attrs
from rigval.acquisition.errors import DataError
from rigval.acquisition.schema import string_table, string_table_attrs
from rigval.acquisition.time_fallbacks import TimeFallback, time_fallback_attrs, time_fallbacks


def _round_trip(ds: xr.Dataset, path: Path) -> xr.Dataset:
    xr.DataTree.from_dict({"/raw/s": ds}).to_netcdf(path, engine="netcdf4")
    with xr.open_datatree(path, engine="netcdf4") as tree:
        return tree["/raw/s"].to_dataset().load()


def test_csv_header_is_a_string_table_after_a_round_trip(tmp_path: Path) -> None:
    head = ("WLS-9163 #2 log\r\nStart time;2026-11-21T06:00:00,250+01:00\r\nOperator;jk\r\n"
            "Note;a;b\r\n\r\n")
    rows = "\r\n".join(f"{t:.3f};{t * 2:.3f}".replace(".", ",") for t in np.arange(5) / 100)
    path = tmp_path / "head.csv"
    path.write_bytes((head + "Time [s];x [V]\r\n" + rows + "\r\n").encode("ascii"))
    ds = read_stream(path)
    expected = {"WLS-9163 #2 log": "", "Start time": "2026-11-21T06:00:00,250+01:00",
                "Operator": "jk", "Note": "a;b"}  # a line without a value keeps its text
    assert string_table(ds.attrs, "text_header") == expected
    assert not any(isinstance(v, str) and v.startswith(("[", "{")) for v in ds.attrs.values())
    back = _round_trip(ds, tmp_path / "csv.nc")
    assert string_table(back.attrs, "text_header") == expected


def test_lvm_header_is_a_string_table_after_a_round_trip(tmp_path: Path) -> None:
    header = ("LabVIEW Measurement\t\nWriter_Version\t2\nReader_Version\t2\nSeparator\tTab\n"
              "Decimal_Separator\t.\nMulti_Headings\tNo\nX_Columns\tOne\nTime_Pref\tAbsolute\n"
              "Operator\tlab\nDate\t2026/11/21\nTime\t06:00:00.5\n***End_of_Header***\t\n\n")
    rows = "".join(f"{t:.3f}\t{t * 3:.3f}\n" for t in np.arange(6) / 100)
    path = tmp_path / "one.lvm"
    path.write_text(header + "X_Value\tacc1\n" + rows)
    ds = read_stream(path)
    table = string_table(ds.attrs, "lvm_header")
    assert table["Operator"] == "lab" and table["X_Columns"] == "One"
    assert table["Date"] == "2026/11/21" and table["Time"] == "06:00:00.5"
    assert string_table(_round_trip(ds, tmp_path / "lvm.nc").attrs, "lvm_header") == table


@pytest.mark.parametrize("table", [{}, {"only": "one"}, {"a": "", "b c": "d=e"}])
def test_string_table_round_trips_empty_single_and_odd_keys(tmp_path: Path,
                                                           table: dict[str, str]) -> None:
    ds = xr.Dataset({"x": ("time", np.zeros(2))}, attrs=string_table_attrs("h", table))
    assert string_table(ds.attrs, "h") == table
    assert string_table(_round_trip(ds, tmp_path / "t.nc").attrs, "h") == table


def test_string_table_with_unequal_lengths_names_the_attribute() -> None:
    with pytest.raises(DataError, match="h_keys has 2 entries, h_values 1"):
        string_table({"h_keys": ["a", "b"], "h_values": ["1"]}, "h")


def test_sensor_parameters_are_typed_channel_attributes_after_a_round_trip(tmp_path: Path
                                                                          ) -> None:
    params = {"counts_per_rev": 2048, "index_reset": True, "edge": "rising", "slope": 2.5e-3}
    ds = xr.Dataset({"enc": ("time", np.zeros(3), sensor_attrs(params))})
    back = _round_trip(ds, tmp_path / "sensor.nc")["enc"].attrs
    assert list(back["sensor_params"]) == list(params)
    assert int(back["sensor_counts_per_rev"]) == 2048 and back["sensor_edge"] == "rising"
    assert back["sensor_index_reset"] == 1 and back["sensor_slope"] == 2.5e-3


def test_time_fallbacks_are_records_per_stream_or_channel_after_a_round_trip(
        write_tdms, tmp_path: Path) -> None:
    start = np.datetime64("2026-11-21T05:00:00.123456", "ns")
    common = {"wf_increment": 1.04167e-05, "wf_start_time": start}
    path = write_tdms(tmp_path / "two.tdms", [[
        ChannelObject("task", "a", np.zeros(960), {**common, "wf_start_offset": 0.0}),
        ChannelObject("task", "b", np.ones(960), common)]])  # only b lacks wf_start_offset
    ds = read_stream(path)
    expected = (TimeFallback("no wf_start_offset", "taken as 0 s", channel="b"),
                TimeFallback("wf_increment 1.04167e-05 rounded in the file",
                             f"using {1 / 96_000!r} s (96000 Hz)"))  # both channels: channel ""
    assert time_fallbacks(ds.attrs) == expected
    assert all(isinstance(v, list) and all(isinstance(s, str) for s in v)
               for k, v in ds.attrs.items() if k.startswith("time_fallback"))
    assert time_fallbacks(_round_trip(ds, tmp_path / "two.nc").attrs) == expected


@pytest.mark.parametrize("count", [0, 1, 3])
def test_time_fallback_attrs_round_trip_none_one_and_several(tmp_path: Path,
                                                             count: int) -> None:
    records = [TimeFallback(f"reason {k}: with a colon", f"used {k}", f"ch {k}" * (k % 2))
               for k in range(count)]
    ds = xr.Dataset({"x": ("time", np.zeros(2))},
                    attrs=time_fallback_attrs([*reversed(records), *records]))  # repeats kept once
    assert time_fallbacks(ds.attrs) == tuple(records)
    assert time_fallbacks(_round_trip(ds, tmp_path / "t.nc").attrs) == tuple(records)


def test_time_fallbacks_of_unequal_length_name_the_attributes() -> None:
    attrs = {"time_fallback_reason": ["a", "b"], "time_fallback_used": ["x", "y"],
             "time_fallback_channel": "c"}
    with pytest.raises(DataError, match=r"differ in length.*'channel': 1"):
        time_fallbacks(attrs)
