"""Delimited text files: guesses for delimiter, decimal, header, time column; every override."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rigval.acquisition import read, read_csv, read_stream
from rigval.acquisition.errors import (
    ChannelNotFoundError,
    ConfigError,
    DataError,
    DataFileError,
    DataWarning,
)
from rigval.acquisition.schema import parse_start_time, string_table
from rigval.acquisition.time_fallbacks import TimeFallback, taken_as_utc, time_fallbacks

FS = 50_000 / 31


def _european(path: Path, time: np.ndarray, columns: dict[str, tuple[str, np.ndarray]],
              head: str = "") -> Path:
    header = ";".join(["Time [s]"] + [f"{n} [{u}]" for n, (u, _) in columns.items()])
    rows = [";".join([f"{t:.6f}"] + [f"{v[i]:.6E}" for _, v in columns.values()])
            for i, t in enumerate(time)]
    text = head + header + "\r\n" + "\r\n".join(rows).replace(".", ",") + "\r\n"
    path.write_bytes(text.encode("ascii"))
    return path


def test_rig_style_european_csv_reads_back_exactly(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    time = np.arange(2000) / FS
    tor3, opt3 = rng.normal(0, 1e-4, 2000), rng.uniform(0, 5, 2000)
    path = _european(tmp_path / "wls2.csv", time, {"tor3": ("V/V", tor3), "opt3": ("V", opt3)})
    ds = read_stream(path, device="WLS-9163")
    np.testing.assert_array_equal(ds["tor3"].values, [float(f"{v:.6E}") for v in tor3])
    np.testing.assert_array_equal(ds["opt3"].values, [float(f"{v:.6E}") for v in opt3])
    np.testing.assert_array_equal(ds.time.values, [float(f"{t:.6f}") for t in time])
    assert ds.attrs["fs_nominal"] == pytest.approx(FS, rel=1e-9)
    assert (ds.attrs["delimiter"], ds.attrs["decimal"]) == (";", ",")
    assert ds["tor3"].attrs["units"] == "V/V"
    assert ds["tor3"].attrs["rate_divider"] == 31
    assert ds.attrs["start_time"].startswith("1904-01-01")
    assert TimeFallback("no start time in the file",
                        "start_time unknown (1904-01-01)") in time_fallbacks(ds.attrs)


def test_jump_in_the_time_column_is_a_gap_never_filled(tmp_path: Path) -> None:
    time = np.r_[np.arange(1000), np.arange(4000, 5000)] / FS
    path = _european(tmp_path / "gap.csv", time, {"tor4": ("V/V", np.zeros(2000))})
    ds = read_stream(path)
    assert ds.sizes["time"] == 2000
    assert ds.attrs["gap_count"] == 1
    assert ds.attrs["missing_samples"] == 3000
    assert float(ds.attrs["gap_start_s"][0]) == pytest.approx(999 / FS, abs=1e-6)


def test_header_block_start_time_and_relative_seconds(tmp_path: Path) -> None:
    head = "WLS-9163 #2 log\r\nStart time;2026-11-21T06:00:00,250+01:00\r\nOperator;jk\r\n\r\n"
    path = _european(tmp_path / "head.csv", np.arange(5) / 100, {"x": ("V", np.ones(5))},
                     head=head)
    ds = read_stream(path)
    assert parse_start_time(ds.attrs["start_time"]) == np.datetime64("2026-11-21T05:00:00.250")
    assert string_table(ds.attrs, "text_header")["Operator"] == "jk"


def test_local_date_and_time_header_in_a_time_zone(tmp_path: Path) -> None:
    head = "Date;2026/07/01\r\nTime;12:00:00,5\r\n"
    path = _european(tmp_path / "dt.csv", np.arange(5) / 100, {"x": ("V", np.ones(5))},
                     head=head)
    ds = read_stream(path, timezone="Europe/Berlin")  # CEST = UTC+2
    assert parse_start_time(ds.attrs["start_time"]) == np.datetime64("2026-07-01T10:00:00.5")


def test_tab_and_comma_delimited_with_dot_decimal(tmp_path: Path) -> None:
    tab = tmp_path / "tab.txt"
    tab.write_text("Time\tacc1 [m/s^2]\n0.0\t1.5\n0.001\t-2.25\n0.002\t3e-3\n")
    ds = read_stream(tab)
    assert ds.attrs["delimiter"] == "\t"
    np.testing.assert_array_equal(ds["acc1"].values, [1.5, -2.25, 3e-3])
    assert ds["acc1"].attrs["units"] == "m s-2"
    comma = tmp_path / "comma.csv"
    comma.write_text("time,a,b,\n0,1,2,\n0.5,3,4,\n1.0,5,6,\n")  # trailing separators
    ds = read_stream(comma)
    assert ds.attrs["decimal"] == "."
    np.testing.assert_array_equal(ds["b"].values, [2, 4, 6])
    np.testing.assert_array_equal(ds.time.values, [0, 0.5, 1.0])


def test_iso_timestamp_column(tmp_path: Path) -> None:
    path = tmp_path / "iso.csv"
    path.write_text("Timestamp;v\n2026-11-21T05:00:00.000Z;1,0\n2026-11-21T05:00:00.010Z;2,0\n"
                    "2026-11-21T05:00:00.020Z;3,0\n")
    ds = read_stream(path)
    np.testing.assert_allclose(ds.time.values, [0, 0.01, 0.02], atol=1e-12)
    assert parse_start_time(ds.attrs["start_time"]) == np.datetime64("2026-11-21T05:00:00")
    assert ds.attrs["fs_nominal"] == pytest.approx(100.0)


def test_locale_dates_with_a_configured_time_zone(tmp_path: Path) -> None:
    german = tmp_path / "de.csv"
    german.write_text("Zeit;v\n21.11.2026 06:00:00,000;1\n21.11.2026 06:00:00,125;2\n"
                      "21.11.2026 06:00:00,250;3\n")
    ds = read_stream(german, timezone="Europe/Berlin")
    assert parse_start_time(ds.attrs["start_time"]) == np.datetime64("2026-11-21T05:00:00")
    np.testing.assert_allclose(ds.time.values, [0, 0.125, 0.25])
    us = tmp_path / "us.csv"
    us.write_text("Date,v\n9/5/2014 11:53:14 AM,1.176E00\n9/5/2014 11:53:15 AM,1.2E00\n"
                  "9/5/2014 11:53:16 AM,1.3E00\n")
    ds = read_stream(us, timezone="America/Chicago")
    assert parse_start_time(ds.attrs["start_time"]) == np.datetime64("2014-09-05T16:53:14")
    with pytest.raises(ConfigError, match="unknown time zone"):
        read_stream(us, timezone="Mars/Olympus")


def test_units_row_millisecond_time_and_empty_cells(tmp_path: Path) -> None:
    path = tmp_path / "units.csv"
    path.write_text("t;F;s\n[ms];[N];[mm]\n0;1;2\n10;;4\n20;5;6\n")
    ds = read_stream(path)
    np.testing.assert_allclose(ds.time.values, [0, 0.01, 0.02])
    assert ds["F"].attrs["units"] == "N"
    assert ds["F"].attrs["empty_cells"] == 1
    assert np.isnan(ds["F"].values[1])


def test_every_guess_can_be_overridden(tmp_path: Path) -> None:
    path = tmp_path / "odd.txt"
    path.write_text("# exported\nsample|a|b\n0|1,5|2\n1|3,5|4\n2|5,5|6\n")
    ds = read_stream(path, delimiter="|", decimal=",", header_row=1, time_column="sample",
                     time_units="ms")
    np.testing.assert_array_equal(ds["a"].values, [1.5, 3.5, 5.5])
    np.testing.assert_allclose(ds.time.values, [0, 1e-3, 2e-3])
    ds = read_stream(path, delimiter="|", decimal=",", header_row=1, time_column=None, fs=10.0,
                     channels=["b"])
    assert next(iter(ds.data_vars)) == "b"
    ds = read_stream(path, delimiter="|", decimal=",", header_row=1, time_column=0,
                     start_time="2026-01-01T00:00:00Z")
    assert parse_start_time(ds.attrs["start_time"]) == np.datetime64("2026-01-01")


def test_bad_text_files_give_clear_errors(tmp_path: Path) -> None:
    bad_cell = tmp_path / "cell.csv"
    bad_cell.write_text("time;a;b\n0;1;2\n1;x;3\n2;4;5\n3;6;7\n")
    with pytest.warns(DataWarning, match=r"column 'a': 1 cell\(s\) are not numbers \(first on "
                      r"line 3: 'x'\); read as NaN"):
        ds = read_stream(bad_cell)
    np.testing.assert_array_equal(ds["a"].values, [1, np.nan, 4, 6])
    assert ds["a"].attrs["text_cells"] == 1
    no_time = tmp_path / "notime.csv"
    no_time.write_text("a;b\n1;2\n3;4\n")
    with pytest.raises(DataFileError, match="no time column"):
        read(no_time)
    backwards = tmp_path / "back.csv"
    backwards.write_text("time;a\n0;1\n2;2\n1;3\n")
    with pytest.raises(DataError, match="not strictly increasing"):
        read(backwards)
    with pytest.raises(ChannelNotFoundError, match="Available: a"):
        read_csv(backwards, channels=["z"])
    prose = tmp_path / "notes.txt"
    prose.write_text("run 3 at 1.0 rev/s\nall fine\n")
    with pytest.raises(DataFileError, match="no block of numeric rows"):
        read(prose)


def test_local_times_across_the_autumn_dst_change(tmp_path: Path) -> None:
    path = tmp_path / "dst.csv"
    path.write_text("Zeit;v\n25.10.2026 02:59:59,500;1\n25.10.2026 02:00:00,000;2\n"
                    "25.10.2026 02:00:00,500;3\n")  # clocks went back at 03:00 CEST
    ds = read_stream(path, timezone="Europe/Berlin")
    np.testing.assert_allclose(ds.time.values, [0, 0.5, 1.0])
    assert parse_start_time(ds.attrs["start_time"]) == np.datetime64("2026-10-25T00:59:59.5")
    with pytest.raises(DataFileError, match="does not increase"):
        read_stream(path)  # without the zone the repeated hour runs backwards
    path.write_text("Zeit;v\n25.10.2026 04:00:00,000;1\n25.10.2026 04:00:00,500;2\n")
    assert taken_as_utc(time_fallbacks(read_stream(path).attrs))


@settings(max_examples=30, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(values=st.lists(st.floats(-1e6, 1e6, allow_nan=False), min_size=2, max_size=40),
       layout=st.sampled_from([(";", ","), ("\t", ","), ("\t", "."), (",", "."), (";", ".")]),
       fs=st.sampled_from([1000.0, 5000.0, FS]))
def test_generated_variants_read_back_exactly(tmp_path: Path, values: list[float],
                                              layout: tuple[str, str], fs: float) -> None:
    delimiter, decimal = layout
    time = np.arange(len(values)) / fs
    rows = [delimiter.join([f"{t:.9f}", repr(v) if v != int(v) else f"{v:.1f}"])
            for t, v in zip(time, values, strict=True)]
    text = f"Time [s]{delimiter}x [N]\n" + "\n".join(rows) + "\n"
    if decimal == ",":
        text = text.replace(".", ",")
    path = tmp_path / "variant.csv"
    path.write_text(text)
    ds = read_stream(path, checksum=False)
    assert (ds.attrs["delimiter"], ds.attrs["decimal"]) == layout
    np.testing.assert_array_equal(ds["x"].values, values)
    np.testing.assert_allclose(ds.time.values, time, atol=1e-9)
    assert ds["x"].attrs["units"] == "N"
