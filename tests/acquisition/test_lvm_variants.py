"""Generated LVM variants (NI spec tutorial 4139) read back exactly."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from rigval.acquisition import read, read_stream
from rigval.acquisition.errors import DataFileError
from rigval.acquisition.schema import parse_start_time
from rigval.acquisition.time_fallbacks import TimeFallback, time_fallbacks

FILE_HEADER = ("LabVIEW Measurement\t\nWriter_Version\t2\nReader_Version\t2\nSeparator\tTab\n"
               "Decimal_Separator\t{dec}\nMulti_Headings\tYes\nX_Columns\t{x}\n"
               "Time_Pref\tAbsolute\nOperator\tlab\nDate\t2026/11/21\nTime\t06:00:00{dec}5\n"
               "***End_of_Header***\t\n\n")


def _segment(names: list[str], units: list[str], time: str, x0: str, dx: str,
             rows: list[str]) -> str:
    """One segment with X_Columns = No: header, names row, data rows (first cell empty)."""
    n = len(names)

    def per_channel(value: str) -> str:
        return "\t".join([value] * n)

    head = [f"Channels\t{n}", f"Samples\t{per_channel(str(len(rows)))}",
            f"Date\t{per_channel('2026/11/21')}", f"Time\t{per_channel(time)}",
            "Y_Unit_Label\t" + "\t".join(units), f"X_Dimension\t{per_channel('Time')}",
            f"X0\t{per_channel(x0)}", f"Delta_X\t{per_channel(dx)}", "***End_of_Header***",
            "X_Value\t" + "\t".join(names) + "\tComment"]
    return "\n".join(head + rows) + "\n\n"


def _comma(value: float) -> str:
    return f"{value:.6f}".replace(".", ",")


def test_segments_decimal_comma_and_rounded_delta_x(tmp_path: Path) -> None:
    rng = np.random.default_rng(5)
    a, b = rng.normal(size=1024), rng.normal(size=1024)
    rows = [f"\t{_comma(u)}\t{_comma(v)}" for u, v in zip(a, b, strict=True)]
    body = "".join(_segment(["acc1", "acc2"], ["m/s^2", "m/s^2"], time, "0,000000", "0,000977",
                            rows)
                   for time in ("06:00:01,000000", "06:00:04,000000"))  # 3 s apart: a gap
    path = tmp_path / "segments.lvm"
    path.write_text(FILE_HEADER.format(dec=",", x="No") + body)
    ds = read_stream(path)
    assert ds.sizes["time"] == 2048
    np.testing.assert_array_equal(ds["acc1"].values[:1024], np.round(a, 6))
    np.testing.assert_array_equal(ds["acc2"].values[1024:], np.round(b, 6))
    np.testing.assert_allclose(ds.time.values[:1024], np.arange(1024) / 1024, atol=1e-12)
    assert ds.time.values[1024] == pytest.approx(3.0, abs=1e-9)
    assert ds.attrs["gap_count"] == 1
    assert ds.attrs["lvm_segments"] == 2
    assert parse_start_time(ds.attrs["start_time"]) == np.datetime64("2026-11-21T06:00:01")
    assert TimeFallback("Delta_X 0.000977 rounded to 6 decimals",
                        f"using {1 / 1024!r} s") in time_fallbacks(ds.attrs)


def test_multi_x_columns_with_two_rates_give_two_streams(tmp_path: Path) -> None:
    fast = [f"{i * 0.001:.6f}\t{i * 1.5:.6f}" for i in range(10)]
    body = "\n".join([
        "Channels\t2\t\t\t", "Samples\t10\t\t5\t", "Date\t2026/11/21\t\t2026/11/21\t",
        "Time\t06:00:00.0\t\t06:00:00.0\t", "Y_Unit_Label\tV\t\tN\t",
        "X0\t0.000000\t\t0.000000\t", "Delta_X\t0.001000\t\t0.002000\t", "***End_of_Header***",
        "X_Value\tfast\tX_Value\tslow\tComment"]
        + [f"{fast[i]}\t" + (f"{i * 0.002:.6f}\t{-i:.6f}" if i < 5 else "\t")
           + ("\tnote" if i == 0 else "") for i in range(10)]) + "\n"
    path = tmp_path / "multi.lvm"
    path.write_text(FILE_HEADER.format(dec=".", x="Multi") + body)
    streams = read(path)
    assert sorted(ds.sizes["time"] for ds in streams.values()) == [5, 10]
    fast_ds = next(ds for ds in streams.values() if "fast" in ds)
    slow_ds = next(ds for ds in streams.values() if "slow" in ds)
    np.testing.assert_array_equal(fast_ds["fast"].values, np.arange(10) * 1.5)
    np.testing.assert_allclose(slow_ds.time.values, np.arange(5) * 0.002)
    np.testing.assert_array_equal(slow_ds["slow"].values, -np.arange(5.0))
    assert slow_ds["slow"].attrs["units"] == "N"


def test_headerless_file_with_special_block_and_comment(tmp_path: Path) -> None:
    path = tmp_path / "bare.lvm"
    path.write_text("X_Value\tu\tComment\n***Start_Special***\nanything\n***End_Special***\n"
                    "0.000000\t1.000000\tfirst\n0.010000\t2.000000\n0.020000\t3.000000\n")
    ds = read_stream(path)
    np.testing.assert_array_equal(ds["u"].values, [1.0, 2.0, 3.0])
    np.testing.assert_allclose(ds.time.values, [0, 0.01, 0.02])
    assert ds.attrs["start_time"].startswith("1904-01-01")


def test_header_only_file_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "empty.lvm"
    path.write_text(FILE_HEADER.format(dec=".", x="One"))
    with pytest.raises(DataFileError, match="no 'X_Value' names row"):
        read(path)


def test_segment_shorter_than_its_header_warns_with_a_fix(tmp_path: Path) -> None:
    from rigval.acquisition.errors import DataWarning

    rows = [f"\t{k / 10:.6f}" for k in range(8)]
    text = _segment(["acc1"], ["m/s^2"], "06:00:01.000000", "0.000000", "0.001000", rows)
    text = text.replace("Samples\t8", "Samples\t10")  # the header announces 10 rows
    path = tmp_path / "short.lvm"
    path.write_text(FILE_HEADER.format(dec=".", x="No") + text)
    with pytest.warns(DataWarning, match="fewer rows than its header") as seen:
        ds = read_stream(path)
    assert ds.sizes["time"] == 8  # the rows present, none invented
    hint = str(seen[0].message)
    assert "copy it again after the acquisition has stopped" in hint
    assert "read the original file" in hint
