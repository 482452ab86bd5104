"""Damaged files: random truncation and byte corruption of real NI files never crash the readers.

Either the data come back with a DataWarning (or intact), or a rigval error says what is wrong;
never IndexError, struct.error or a traceback from ``rigval info``.
"""

from __future__ import annotations

import re
import tempfile
import warnings
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rigval.acquisition import read
from rigval.acquisition.errors import DataWarning, RigvalError
from rigval.validation.cli import main

REAL_FILES = ["npTDMS/Digital_Input.tdms", "npTDMS/raw1.tdms", "npTDMS/big_endian.tdms",
              "nidaqmx-python/data_ai.tdms", "nidaqmx-python/TestData.tdms",
              "lvm_read/short.lvm", "lvm_read/with_empty_fields.lvm"]


def _read_damaged(data: bytes, suffix: str) -> None:
    """Read damaged bytes; return normally or raise a RigvalError only."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"damaged{suffix}"
        path.write_bytes(data)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # a DataWarning is an allowed outcome
            try:
                streams = read(path, checksum=False)
            except RigvalError:
                return
        for ds in streams.values():
            assert ds.sizes["time"] == ds["valid"].size


@pytest.mark.parametrize("name", REAL_FILES)
@settings(max_examples=25, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(fraction=st.floats(0.0, 1.0, exclude_max=True))
def test_truncated_real_file_reads_or_raises_rigval_error(realdata_dir: Path, name: str,
                                                          fraction: float) -> None:
    data = (realdata_dir / name).read_bytes()
    _read_damaged(data[:max(1, int(len(data) * fraction))], Path(name).suffix)


@pytest.mark.parametrize("name", REAL_FILES)
@settings(max_examples=25, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(fraction=st.floats(0.0, 1.0, exclude_max=True), value=st.integers(0, 255),
       width=st.integers(1, 8))
def test_corrupted_real_file_reads_or_raises_rigval_error(realdata_dir: Path, name: str,
                                                          fraction: float, value: int,
                                                          width: int) -> None:
    data = bytearray((realdata_dir / name).read_bytes())
    at = int(len(data) * fraction)
    data[at:at + width] = bytes([value]) * len(data[at:at + width])
    _read_damaged(bytes(data), Path(name).suffix)


@settings(max_examples=20, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(fraction=st.floats(0.0, 1.0, exclude_max=True), value=st.integers(0, 255))
def test_info_on_damaged_files_never_shows_a_traceback(
        realdata_dir: Path, capsys: pytest.CaptureFixture[str], fraction: float,
        value: int) -> None:
    data = bytearray((realdata_dir / "nidaqmx-python/data_ai.tdms").read_bytes())
    at = int(len(data) * fraction)
    data[at] = value
    with tempfile.TemporaryDirectory() as folder:
        cut = Path(folder) / "cut.tdms"
        cut.write_bytes(bytes(data[:at + 1]))
        flipped = Path(folder) / "flipped.tdms"
        flipped.write_bytes(bytes(data))
        code = main(["info", str(cut), str(flipped)])
    captured = capsys.readouterr()
    assert code in (0, 3)
    assert "Traceback" not in captured.err + captured.out
    if code == 3:
        assert "rigval:" in captured.err


def test_truncated_daqmx_file_keeps_whole_samples_and_counts_them(realdata_dir: Path,
                                                                  tmp_path: Path) -> None:
    data = (realdata_dir / "nidaqmx-python/data_ai.tdms").read_bytes()
    cut = tmp_path / "cut.tdms"
    cut.write_bytes(data[:20_001])
    with pytest.warns(DataWarning) as caught:
        ds = next(iter(read(cut).values()))
    messages = " ".join(str(w.message) for w in caught)
    assert re.search(r"recovered \d+ of 7000 samples", messages)
    # NI-DAQmx writes wf_* after the data: a cut file lost them, and rigval says so
    assert "no usable wf_increment" in messages
    full = next(iter(read(realdata_dir / "nidaqmx-python/data_ai.tdms").values()))
    n = ds.sizes["time"]
    assert 0 < n < 7000
    assert (ds["Torque01"].values == full["Torque01"].values[:n]).all()
    assert (ds["Torque02"].values == full["Torque02"].values[:n]).all()
