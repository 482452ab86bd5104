"""TDMS files written with nptdms.TdmsWriter read back exactly, with rigval's own time axis."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pytest
from nptdms import ChannelObject, GroupObject, TdmsFile, TdmsWriter

from rigval.acquisition import iter_stream, read, read_stream
from rigval.acquisition.errors import (
    ChannelNotFoundError,
    ConfigError,
    DataFileError,
    DataWarning,
)
from rigval.acquisition.schema import parse_start_time, stream_gaps
from rigval.acquisition.time_fallbacks import TimeFallback, time_fallbacks

T0 = np.datetime64("2026-11-21T05:00:00.123456", "ns")  # TdmsWriter keeps microseconds
FS = 50_000 / 31  # an NI 9237 rate


def _daqmx_props(t0: np.datetime64, dt: float, slope: float, unit: str = "V/V",
                 **extra: object) -> dict[str, object]:
    return {"NI_Scaling_Status": "unscaled", "NI_Number_Of_Scales": 1,
            "NI_Scale[0]_Scale_Type": "Linear", "NI_Scale[0]_Linear_Slope": slope,
            "NI_Scale[0]_Linear_Y_Intercept": 0.5,
            "NI_Scale[0]_Linear_Input_Source": np.uint32(0xFFFFFFFF),  # raw data
            "NI_ChannelName": "WLS1Mod1/ai0", "unit_string": unit, "wf_start_time": t0,
            "wf_increment": dt, "wf_start_offset": 0.0, "wf_samples": 1, **extra}


def _raw(n: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).integers(-30000, 30000, n).astype(np.int16)


def test_daqmx_style_raw_integers_are_scaled_and_timed(write_tdms, tmp_path: Path) -> None:
    raw = _raw(5000, 1)
    props = _daqmx_props(T0, 1 / FS, 2.5e-7)
    path = write_tdms(tmp_path / "wls1.tdms", [[ChannelObject("task", "tor1", raw, props)]])
    ds = read_stream(path, device="WLS-9163")
    np.testing.assert_allclose(ds["tor1"].values, 2.5e-7 * raw + 0.5, rtol=1e-15)
    np.testing.assert_array_equal(ds["tor1"].values, TdmsFile.read(path)["task"]["tor1"][:])
    np.testing.assert_allclose(ds.time.values, np.arange(5000) / FS, rtol=1e-12, atol=1e-15)
    assert parse_start_time(ds.attrs["start_time"]) == T0
    assert ds.attrs["device"] == "WLS-9163"
    assert ds["tor1"].attrs["units"] == "V/V"
    assert ds["tor1"].attrs["input_delay_s"] == pytest.approx((40 + 5 / 512) / FS + 4.5e-6)
    assert "Linear slope 2.5e-07 intercept 0.5" in ds["tor1"].attrs["scaling"]


def test_restart_with_new_start_time_becomes_a_gap(write_tdms, tmp_path: Path) -> None:
    dt = 1 / FS
    a, b = _raw(3000, 2), _raw(2000, 3)
    restart = T0 + np.timedelta64(round((3000 * dt + 1.25) * 1e9), "ns")
    path = write_tdms(tmp_path / "restart.tdms", [
        [ChannelObject("task", "tor1", a, _daqmx_props(T0, dt, 1e-7))],
        [ChannelObject("task", "tor1", b, {"wf_start_time": restart})],
    ])
    ds = read_stream(path)
    assert ds.sizes["time"] == 5000
    np.testing.assert_array_equal(ds["tor1"].values[3000:], 1e-7 * b + 0.5)
    assert ds.attrs["gap_count"] == 1
    gap = stream_gaps(ds)[0]
    assert int(ds.attrs["gap_missing_samples"][0]) == gap["missing_samples"]
    assert gap["duration_s"] == pytest.approx(1.25, abs=1e-6)
    assert ds.attrs["missing_samples"] == round(1.25 / dt)
    assert ds.time.values[3000] == pytest.approx(3000 * dt + 1.25, abs=1e-9)
    assert np.array_equal(np.bincount(ds["segment"].values), [3000, 2000])


def test_rewritten_start_time_without_a_jump_is_no_gap(write_tdms, tmp_path: Path) -> None:
    dt = 1 / FS
    same = T0 + np.timedelta64(round(3000 * dt * 1e9), "ns")
    path = write_tdms(tmp_path / "continuous.tdms", [
        [ChannelObject("task", "tor1", _raw(3000, 4), _daqmx_props(T0, dt, 1e-7))],
        [ChannelObject("task", "tor1", _raw(100, 5), {"wf_start_time": same})],
    ])
    ds = read_stream(path)
    assert ds.attrs["gap_count"] == 0
    np.testing.assert_allclose(np.diff(ds.time.values), dt, rtol=1e-9)


def test_restart_stamped_before_the_previous_end_is_placed_after_it_with_a_warning(
        write_tdms, tmp_path: Path) -> None:
    dt = 1 / FS
    early = T0 + np.timedelta64(1, "s")  # before the end of the 3000 samples (1.86 s)
    path = write_tdms(tmp_path / "overlap.tdms", [
        [ChannelObject("task", "tor1", _raw(3000, 6), _daqmx_props(T0, dt, 1e-7))],
        [ChannelObject("task", "tor1", _raw(100, 7), {"wf_start_time": early})],
    ])
    with pytest.warns(DataWarning, match="before the end of the previous block"):
        ds = read_stream(path)
    assert ds.time.values[3000] == pytest.approx(3000 * dt)
    assert ds.sizes["time"] == 3100


def test_missing_increment_warns_and_fs_option_fixes_it(write_tdms, tmp_path: Path) -> None:
    data = np.linspace(0, 1, 100)
    path = write_tdms(tmp_path / "plain.tdms", [[ChannelObject("task", "x", data, {})]])
    with pytest.warns(DataWarning, match="no usable wf_increment"):
        ds = read_stream(path)
    np.testing.assert_array_equal(ds.time.values, np.arange(100.0))
    ds = read_stream(path, fs=200.0)
    np.testing.assert_allclose(ds.time.values, np.arange(100) / 200.0)
    assert ds.attrs["start_time"].startswith("1904-01-01")


def test_increment_rounded_to_six_digits_is_replaced_by_the_exact_one(write_tdms,
                                                                      tmp_path: Path) -> None:
    props = {"wf_increment": 1.04167e-05, "wf_start_time": T0, "wf_start_offset": 0.0}
    path = write_tdms(tmp_path / "96k.tdms",
                      [[ChannelObject("task", "x", np.zeros(96_001), props)]])
    ds = read_stream(path)
    assert ds.time.values[-1] == pytest.approx(1.0, abs=1e-12)  # not 1.0000032
    assert TimeFallback("wf_increment 1.04167e-05 rounded in the file",
                        f"using {1 / 96_000!r} s (96000 Hz)") in time_fallbacks(ds.attrs)


def test_start_offset_is_part_of_the_start_time(write_tdms, tmp_path: Path) -> None:
    props = {"wf_increment": 1e-3, "wf_start_time": T0, "wf_start_offset": 0.25}
    path = write_tdms(tmp_path / "offset.tdms", [[ChannelObject("task", "x", np.zeros(10), props)]])
    ds = read_stream(path)
    assert parse_start_time(ds.attrs["start_time"]) == T0 + np.timedelta64(250, "ms")
    assert ds.time.values[0] == 0.0


def test_two_rates_in_one_group_give_two_streams(write_tdms, tmp_path: Path) -> None:
    fast = ChannelObject("task", "acc1", np.arange(500.0),
                         {"wf_increment": 2e-4, "wf_start_time": T0, "wf_start_offset": 0.0})
    slow = ChannelObject("task", "temp", np.arange(10.0),
                         {"wf_increment": 1e-2, "wf_start_time": T0, "wf_start_offset": 0.0})
    path = write_tdms(tmp_path / "rates.tdms", [[fast, slow]])
    streams = read(path)
    assert sorted(streams) == ["task@100Hz", "task@5000Hz"]
    with pytest.raises(DataFileError, match="2 streams"):
        read_stream(path)
    assert read_stream(path, channels=["temp"]).sizes["time"] == 10


def test_channel_and_time_range_selection(write_tdms, tmp_path: Path) -> None:
    props = {"wf_increment": 1e-3, "wf_start_time": T0, "wf_start_offset": 0.0}
    segments = [[ChannelObject("task", "a", np.arange(k * 1000, (k + 1) * 1000.0), props),
                 ChannelObject("task", "b", -np.arange(k * 1000, (k + 1) * 1000.0), props)]
                for k in range(5)]
    path = write_tdms(tmp_path / "long.tdms", segments)
    ds = read_stream(path, channels=["b"], time_range=(1.5, 2.25))
    assert list(ds.data_vars) == ["b", "valid", "segment"]
    np.testing.assert_array_equal(ds["b"].values, -np.arange(1500, 2251.0))
    assert ds.time.values[0] == pytest.approx(1.5)
    assert ds.attrs["first_sample"] == 1500
    with pytest.raises(ChannelNotFoundError, match="Available: a, b"):
        read_stream(path, channels=["c"])
    with pytest.raises(ChannelNotFoundError, match="Available: task"):
        read(path, group="other")
    with pytest.raises(ConfigError, match="no option 'delimiter'"):
        read(path, delimiter=";")


def test_streaming_windows_join_to_the_full_read(write_tdms, tmp_path: Path) -> None:
    dt = 1 / FS
    restart = T0 + np.timedelta64(round((2500 * dt + 0.5) * 1e9), "ns")
    path = write_tdms(tmp_path / "stream.tdms", [
        [ChannelObject("task", "tor1", _raw(2500, 8), _daqmx_props(T0, dt, 1e-7)),
         ChannelObject("task", "opt2", _raw(2500, 9), _daqmx_props(T0, dt, 1e-4, "Volts"))],
        [ChannelObject("task", "tor1", _raw(1700, 10), {"wf_start_time": restart}),
         ChannelObject("task", "opt2", _raw(1700, 11), {"wf_start_time": restart})],
    ])
    full = read_stream(path)
    windows = list(iter_stream(path, chunk_samples=1000))
    assert [w.sizes["time"] for w in windows] == [1000, 1000, 1000, 1000, 200]
    assert [w.attrs["first_sample"] for w in windows] == [0, 1000, 2000, 3000, 4000]
    for name in ("tor1", "opt2", "time", "segment"):
        np.testing.assert_array_equal(np.concatenate([w[name].values for w in windows]),
                                      full[name].values)



def test_every_streamed_window_carries_the_files_digest(write_tdms, tmp_path: Path) -> None:
    """The hash runs beside the first window's read; each window still carries the digest."""
    dt = 1 / FS
    path = write_tdms(tmp_path / "digest.tdms", [
        [ChannelObject("task", "tor1", _raw(2500, k), _daqmx_props(T0, dt, 1e-7))]
        for k in range(3)])
    expected = hashlib.sha256(path.read_bytes()).hexdigest()
    off = [w.attrs["source_sha256"] for w in iter_stream(path, chunk_samples=3000,
                                                         checksum=False)]
    assert off == ["not computed"] * 3
    on = [w.attrs["source_sha256"] for w in iter_stream(path, chunk_samples=3000)]
    assert on == [expected] * 3


def test_truncated_contiguous_segment_is_cut_to_whole_samples(write_tdms, tmp_path: Path) -> None:
    props = {"wf_increment": 1e-3, "wf_start_time": T0, "wf_start_offset": 0.0}
    path = write_tdms(tmp_path / "whole.tdms", [[
        ChannelObject("task", "a", np.arange(1000.0), props),
        ChannelObject("task", "b", np.arange(1000.0) * 2, props)]])
    data = path.read_bytes()
    cut = tmp_path / "cut.tdms"
    cut.write_bytes(data[:-8 * 750])  # a is whole, b lost its last 750 values
    with pytest.warns(DataWarning, match=r"recovered 250 of 1000 samples") as caught:
        ds = read_stream(cut)
    assert "values past the last whole sample not used: {'a': 750}" in str(caught[0].message)
    np.testing.assert_array_equal(ds["a"].values, np.arange(250.0))
    np.testing.assert_array_equal(ds["b"].values, np.arange(250.0) * 2)


def test_per_channel_start_offsets_are_kept_not_applied(write_tdms, tmp_path: Path) -> None:
    later = T0 + np.timedelta64(11_000, "ns")
    path = write_tdms(tmp_path / "skew.tdms", [[
        ChannelObject("task", "a", np.zeros(10), {"wf_increment": 1e-3, "wf_start_time": T0}),
        ChannelObject("task", "b", np.zeros(10), {"wf_increment": 1e-3, "wf_start_time": later}),
    ]])
    ds = read_stream(path)
    assert ds["b"].attrs["time_offset_s"] == pytest.approx(11e-6, abs=1e-12)
    np.testing.assert_allclose(ds.time.values, np.arange(10) * 1e-3)


def test_rate_impossible_for_the_module_is_flagged(write_tdms, tmp_path: Path) -> None:
    props = {"wf_increment": 1e-3, "wf_start_time": T0, "wf_start_offset": 0.0}
    path = write_tdms(tmp_path / "1k.tdms", [[ChannelObject("task", "x", np.zeros(10), props)]])
    with pytest.warns(DataWarning, match="not a rate the NI 9237 can run at"):
        read_stream(path, device="WLS-9163")


def test_files_that_are_not_tdms_are_refused_with_their_path(tmp_path: Path) -> None:
    lfs = tmp_path / "run.tdms"
    lfs.write_text("version https://git-lfs.github.com/spec/v1\noid sha256:abc\nsize 12\n")
    with pytest.raises(DataFileError, match="Git-LFS pointer") as error:
        read(lfs)
    assert str(lfs) in str(error.value)
    binary = tmp_path / "image.tdms"
    binary.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(100))
    with pytest.raises(DataFileError, match="not a TDMS, LVM or CSV file"):
        read(binary)
    garbage = tmp_path / "bad.tdms"
    garbage.write_bytes(b"TDSm" + bytes(10))
    with pytest.raises(DataFileError, match="not a readable TDMS file"):
        read(garbage)
    with pytest.raises(DataFileError, match="file not found"):
        read(tmp_path / "missing.tdms")


def test_a_stale_index_file_next_to_the_data_is_not_trusted(tmp_path: Path) -> None:
    props = {"wf_increment": 1e-3, "wf_start_time": T0, "wf_start_offset": 0.0}
    short, long = tmp_path / "short.tdms", tmp_path / "long.tdms"
    with TdmsWriter(str(short), index_file=True) as writer:
        writer.write_segment([GroupObject("task"), ChannelObject("task", "x", np.zeros(10), props)])
    with TdmsWriter(long) as writer:
        for k in range(3):
            writer.write_segment([ChannelObject("task", "x", np.full(10, float(k)), props)])
    short.write_bytes(long.read_bytes())  # data copied over, the old .tdms_index left behind
    assert Path(f"{short}_index").exists()
    assert len(TdmsFile.read(short)["task"]["x"]) == 10  # nptdms trusts the stale index
    ds = read_stream(short)
    np.testing.assert_array_equal(ds["x"].values, np.repeat([0.0, 1.0, 2.0], 10))
