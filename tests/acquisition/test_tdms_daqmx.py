"""The direct DAQmx path: values equal nptdms's bit for bit, the digest equals the file's.

Each file is read twice: as rigval reads it (DAQmx rows read directly) and with the direct DAQmx
path switched off (nptdms reads and scales, ``source_checksum`` hashes); values, dtypes, time
axes, attributes and warnings must agree. The helpers come from ``test_tdms_direct.py``.
"""

from __future__ import annotations

import dataclasses
import gc
import importlib.util
import sys
import weakref
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

import rigval.sample_data.tdms_writer as tdms_writer
from rigval.acquisition import read_stream
from rigval.acquisition.errors import DataFileError
from rigval.acquisition.tdms_daqmx import daqmx_selection, read_daqmx
from rigval.acquisition.tdms_layout import scan_tdms
from rigval.sample_data import runs_dir
from rigval.sample_data.tdms_writer import Acquisition, RawChannel, write_daqmx_tdms

T0 = np.datetime64("2026-11-21T05:00:00.123456", "ns")


def _direct_tests() -> ModuleType:
    path = Path(__file__).resolve().with_name("test_tdms_direct.py")
    if "tdms_direct_tests" not in sys.modules:
        spec = importlib.util.spec_from_file_location("tdms_direct_tests", path)
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        sys.modules["tdms_direct_tests"] = module
    return sys.modules["tdms_direct_tests"]


_assert_same = _direct_tests()._assert_same
_sha = _direct_tests()._sha


@pytest.fixture(autouse=True)
def _fresh_digests(monkeypatch: pytest.MonkeyPatch) -> None:
    """Each test starts without digests remembered from other tests."""
    monkeypatch.setattr("rigval.acquisition.detect._DIGESTS", {})


def _read_both(path: Path, monkeypatch: pytest.MonkeyPatch, **options: object) -> tuple:
    """Return (direct result, nptdms result, direct warnings, nptdms warnings, route used)."""
    return _direct_tests()._read_both(path, monkeypatch, route=("read_daqmx", "daqmx_selection"),
                                      **options)


def _messages(caught: list) -> list[str]:
    return sorted(str(w.message) for w in caught)


def _acquisitions(n: int, restart: bool = True) -> list[Acquisition]:
    """A task of int16, int32 and uint32 channels, optionally restarted once."""
    rng = np.random.default_rng(n)

    def channels() -> tuple[RawChannel, ...]:
        return (RawChannel("Dev1/ai0", rng.integers(-32768, 32767, n).astype(np.int16),
                           3.0518509475997192e-4, 0.0, "Volts"),
                RawChannel("Dev1/ai1", rng.integers(-2**31, 2**31 - 1, n).astype(np.int32),
                           2.98e-9, -0.125, "V/V"),
                RawChannel("Dev1/ctr0", rng.integers(0, 2**32 - 1, n).astype(np.uint32),
                           1.0, 0.0, None))

    acqs = [Acquisition("task", T0, 1e-3, channels())]
    if restart:
        acqs.append(Acquisition("task", T0 + np.timedelta64(10, "s"), 1e-3, channels()))
    return acqs


@pytest.mark.parametrize("name", ["run_0p8_cdaq.tdms", "run_0p8_wls1.tdms",
                                  "run_1p2_cdaq.tdms", "run_1p2_wls1.tdms"])
def test_shipped_daqmx_runs_read_directly_equal_nptdms(
        name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    path = runs_dir() / name
    fast, slow, fw, sw, used = _read_both(path, monkeypatch)
    assert used
    _assert_same(fast, slow)
    assert next(iter(fast.values())).attrs["source_sha256"] == _sha(path)
    assert _messages(fw) == _messages(sw)


@pytest.mark.parametrize("name", ["npTDMS/raw1.tdms", "nidaqmx-python/TestData.tdms",
                                  "nidaqmx-python/data_ai.tdms", "nidaqmx-python/data_ci1.tdms",
                                  "nidaqmx-python/data_ci2.tdms"])
def test_real_daqmx_files_read_directly_equal_nptdms(
        name: str, monkeypatch: pytest.MonkeyPatch, realdata_dir: Path) -> None:
    path = realdata_dir / name
    fast, slow, fw, sw, used = _read_both(path, monkeypatch)
    assert used
    _assert_same(fast, slow)
    assert next(iter(fast.values())).attrs["source_sha256"] == _sha(path)
    assert _messages(fw) == _messages(sw)


def test_selection_time_range_and_restart(tmp_path: Path,
                                          monkeypatch: pytest.MonkeyPatch) -> None:
    path = write_daqmx_tdms(tmp_path / "restart.tdms", _acquisitions(1000), block_samples=97)
    for options in ({}, {"channels": ["Dev1/ai1"], "time_range": (0.2315, 0.9)},
                    {"time_range": (0.5, None)}):
        fast, slow, fw, sw, used = _read_both(path, monkeypatch, **options)
        assert used, options
        _assert_same(fast, slow)
        assert fast["task"].attrs["source_sha256"] == _sha(path)
        assert _messages(fw) == _messages(sw)
    no_hash = read_stream(path, checksum=False)
    assert no_hash.attrs["source_sha256"] == "not computed"
    hashed = read_stream(path)
    for name in hashed.data_vars:
        np.testing.assert_array_equal(no_hash[name].values, hashed[name].values)


def test_segments_larger_than_a_block_are_read_in_runs_of_rows(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr("rigval.acquisition.tdms_daqmx._BLOCK_BYTES", 1000)
    path = write_daqmx_tdms(tmp_path / "long.tdms", _acquisitions(5000), block_samples=3001)
    for checksum in (True, False):
        fast, slow, *_, used = _read_both(path, monkeypatch, checksum=checksum)
        assert used
        _assert_same(fast, slow)


def test_cut_anywhere_and_damaged_tails_both_routes_agree(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    source = write_daqmx_tdms(tmp_path / "whole.tdms", _acquisitions(400), block_samples=61)
    whole = source.read_bytes()
    rng = np.random.default_rng(11)
    first_data = scan_tdms(source).data_segments[0].data_start
    cuts = sorted({int(c) for c in rng.integers(first_data + 1, len(whole), 30)}
                  | {first_data + 1, first_data + 14, len(whole) - 1})
    path = tmp_path / "cut.tdms"
    routes = []
    variants = [whole[:cut] for cut in cuts]
    variants += [whole + b"TDSx" + bytes(range(100)), whole[:len(whole) - 50] + b"\xff" * 9]
    for k, data in enumerate(variants):
        path.write_bytes(data)
        fast, slow, fw, sw, used = _read_both(path, monkeypatch)
        assert used or fast["task"].sizes["time"] == 0, k  # no value: nothing to read directly
        routes.append(used)
        _assert_same(fast, slow)
        assert fast["task"].attrs["source_sha256"] == _sha(path), k
        assert _messages(fw) == _messages(sw), k
    assert sum(routes) >= len(variants) - 2


def test_shipped_run_cut_in_its_last_segments(tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    whole = (runs_dir() / "run_0p8_wls1.tdms").read_bytes()
    path = tmp_path / "cut.tdms"
    for cut in (len(whole) - 1, len(whole) - 5000, len(whole) - 40_000):
        path.write_bytes(whole[:cut])
        fast, slow, fw, sw, used = _read_both(path, monkeypatch)
        assert used, cut
        _assert_same(fast, slow)
        assert _messages(fw) == _messages(sw)


def _with_scale(monkeypatch: pytest.MonkeyPatch, extra: dict[str, object]) -> None:
    """Make the writer add a third scale (reading the linear scale 1) to every channel."""
    original = tdms_writer._channel_properties

    def props(channel: RawChannel, acq: Acquisition) -> dict[str, object]:
        return {**original(channel, acq), "NI_Number_Of_Scales": np.uint32(3), **extra}

    monkeypatch.setattr(tdms_writer, "_channel_properties", props)


def test_polynomial_after_linear_is_read_directly(tmp_path: Path,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    _with_scale(monkeypatch, {
        "NI_Scale[2]_Scale_Type": "Polynomial", "NI_Scale[2]_Polynomial_Input_Source": 1,
        "NI_Scale[2]_Polynomial_Coefficients_Size": 3,
        "NI_Scale[2]_Polynomial_Coefficients[0]": 0.25,
        "NI_Scale[2]_Polynomial_Coefficients[1]": 1.5,
        "NI_Scale[2]_Polynomial_Coefficients[2]": -0.003})
    path = write_daqmx_tdms(tmp_path / "poly.tdms", _acquisitions(700), block_samples=128)
    fast, slow, fw, sw, used = _read_both(path, monkeypatch)
    assert used
    _assert_same(fast, slow)
    assert _messages(fw) == _messages(sw)


@pytest.mark.parametrize("extra", [
    {"NI_Scale[2]_Scale_Type": "Table", "NI_Scale[2]_Table_Input_Source": 1,
     "NI_Scale[2]_Table_Pre_Scaled_Values_Size": 2, "NI_Scale[2]_Table_Scaled_Values_Size": 2,
     "NI_Scale[2]_Table_Pre_Scaled_Values[0]": -100.0,
     "NI_Scale[2]_Table_Pre_Scaled_Values[1]": 100.0,
     "NI_Scale[2]_Table_Scaled_Values[0]": 0.0, "NI_Scale[2]_Table_Scaled_Values[1]": 10.0},
    {"NI_Scale[2]_Scale_Type": "Linear", "NI_Scale[2]_Linear_Input_Source": 2,
     "NI_Scale[2]_Linear_Slope": 1.0, "NI_Scale[2]_Linear_Y_Intercept": 0.0},
], ids=["table", "loop"])
def test_scales_not_reproduced_here_go_to_nptdms(
        extra: dict[str, object], tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _with_scale(monkeypatch, extra)
    path = write_daqmx_tdms(tmp_path / "other.tdms", _acquisitions(300, restart=False),
                            block_samples=64)
    layout = scan_tdms(path)
    assert daqmx_selection(layout, {p: (0, c.length) for p, c in layout.channels.items()
                                    if c.data_type is not None}) is None
    if extra["NI_Scale[2]_Scale_Type"] == "Table":
        fast, slow, *_, used = _read_both(path, monkeypatch)
        assert not used
        _assert_same(fast, slow)


def test_digital_line_scalers_and_several_raw_buffers_go_to_nptdms(tmp_path: Path) -> None:
    path = write_daqmx_tdms(tmp_path / "plain.tdms", _acquisitions(200, restart=False))
    data = path.read_bytes()
    layout = scan_tdms(path)
    ranges = {p: (0, c.length) for p, c in layout.channels.items() if c.data_type is not None}
    assert daqmx_selection(layout, ranges) is not None

    def changed(**fields):  # the layout with every raw-data index changed (they are frozen)
        def index(i):
            return None if i is None else dataclasses.replace(
                i, **{k: f(i) for k, f in fields.items()})
        segments = [dataclasses.replace(s, objects=tuple((p, index(i)) for p, i in s.objects))
                    for s in layout.data_segments]
        return dataclasses.replace(layout, data_segments=segments)

    # as a 0x126A index would say; one raw buffer per card
    assert daqmx_selection(changed(digital=lambda i: True), ranges) is None
    assert daqmx_selection(changed(widths=lambda i: i.widths * 2), ranges) is None
    assert path.read_bytes() == data


def test_file_cut_after_the_scan_is_a_data_file_error(tmp_path: Path) -> None:
    path = write_daqmx_tdms(tmp_path / "shrinks.tdms", _acquisitions(3000), block_samples=500)
    layout = scan_tdms(path)
    selection = daqmx_selection(layout, {p: (0, c.length) for p, c in layout.channels.items()
                                         if c.data_type is not None})
    assert selection is not None
    path.write_bytes(path.read_bytes()[:layout.file_size // 2])
    for checksum in (True, False):
        with pytest.raises(DataFileError, match=r"ends at byte \d+, before data"):
            read_daqmx(path, layout, selection, checksum)


def test_read_values_are_freed_with_their_dataset_without_the_garbage_collector(
        tmp_path: Path) -> None:
    # a reference cycle in the scaling would keep each channel's array alive after its reader
    # let it go, until the collector runs (an hour's channel: 137 MiB beside the next steps)
    path = write_daqmx_tdms(tmp_path / "freed.tdms", _acquisitions(5000, restart=False),
                            block_samples=500)
    gc.collect()
    gc.disable()
    try:
        stream = read_stream(path, checksum=False)
        arrays = [weakref.ref(stream[name].to_numpy()) for name in stream.data_vars
                  if stream[name].dtype == np.float64]
        assert arrays
        del stream
        assert [ref() for ref in arrays] == [None] * len(arrays)
    finally:
        gc.enable()
