"""Reader defects of issue 14 (items 1 to 8), each reproduced on a written or a real NI file.

Every test compares rigval with an independent expectation: the values written, or what nptdms
reads from the same bytes, and checks that each lost sample is counted in a DataWarning.
"""

from __future__ import annotations

import re
import struct
import warnings
from pathlib import Path

import numpy as np
import pytest
from nptdms import ChannelObject, GroupObject, TdmsFile, TdmsWriter

from rigval.acquisition import read
from rigval.acquisition.errors import DataFileError, DataWarning


def _read(path: Path, **options: object) -> tuple[dict, list[str]]:
    """Read a file, returning the streams and the DataWarning texts."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        streams = read(path, checksum=False, **options)
    return streams, [str(w.message) for w in caught if issubclass(w.category, DataWarning)]


def _copy(source: Path, target: Path, edit) -> Path:
    """Write ``target`` as a copy of ``source`` with one local edit ``edit(bytearray)``."""
    data = bytearray(source.read_bytes())
    edit(data)
    target.write_bytes(bytes(data))
    return target


def _nptdms_values(path: Path) -> dict[str, np.ndarray]:
    """Return '/group/channel' -> values as nptdms reads them."""
    tdms = TdmsFile.read(path)
    return {f"{g.name}/{c.name}": c[:] for g in tdms.groups() for c in g.channels()}


# --- item 1: an intact TDMS group with channels of different lengths -----------------------

def test_channels_of_different_lengths_become_one_stream_per_length(tmp_path: Path) -> None:
    path = tmp_path / "labview_log.tdms"
    written = {"setting": np.array([1.5]), "list16": np.arange(16.0), "list30": np.arange(30.0),
               **{f"plot{k}": np.sin(np.arange(5000) * 0.01 * (k + 1)) for k in range(4)},
               "graph": np.arange(361.0) ** 2}
    with TdmsWriter(path) as writer:  # several segments, no wf_increment
        writer.write_segment([GroupObject("Log"), ChannelObject("Log", "setting",
                                                                written["setting"])])
        writer.write_segment([ChannelObject("Log", "list16", written["list16"]),
                              ChannelObject("Log", "list30", written["list30"])])
        for k in range(4):
            writer.write_segment([ChannelObject("Log", f"plot{k}", written[f"plot{k}"])])
        writer.write_segment([ChannelObject("Log", "graph", written["graph"])])
    streams, texts = _read(path)
    got = {name: ds[name].values for ds in streams.values() for name in ds.data_vars
           if name not in ("valid", "segment")}
    assert got.keys() == written.keys()
    for name, values in written.items():
        np.testing.assert_array_equal(got[name], values)  # nothing cropped
    lengths = sorted(ds.sizes["time"] for ds in streams.values())
    assert lengths == [1, 16, 30, 361, 5000]  # one stream per length; the 4 plots share one
    assert not any("recovered" in t or "cut short" in t for t in texts)
    assert all("time is the sample index" in t for t in texts)  # the only honest warning


# --- item 6: damage that nptdms reads around must not give a silent {} ------------------------

def test_bad_utf8_byte_in_a_property_string_keeps_all_samples(realdata_dir: Path,
                                                              tmp_path: Path) -> None:
    source = realdata_dir / "npTDMS/Digital_Input.tdms"

    def edit(data: bytearray) -> None:
        data[data.find(b"SingleWaveform") + 6] = 0xFF

    path = _copy(source, tmp_path / "bad_string.tdms", edit)
    expected = _nptdms_values(path)
    streams, texts = _read(path)
    assert len(streams) == 1
    ds = next(iter(streams.values()))
    name = next(n for n in ds.data_vars if n not in ("valid", "segment"))
    key = next(k for k in expected if k.endswith(name) and "All Data" in k)
    assert ds.sizes["time"] == expected[key].size == 20000
    np.testing.assert_array_equal(ds[name].values, expected[key])
    assert any("not UTF-8" in t and "byte 674" in t for t in texts)


def test_tdms_whose_channels_hold_no_samples_is_an_error(tmp_path: Path) -> None:
    path = tmp_path / "no_samples.tdms"
    with TdmsWriter(path) as writer:
        writer.write_segment([GroupObject("Log"), ChannelObject("Log", "empty", np.array([]))])
    assert _nptdms_values(path)["Log/empty"].size == 0
    with pytest.raises(DataFileError, match=r"no numeric channel with samples.*Log/empty \(0"):
        read(path, checksum=False)


def test_lvm_with_a_names_row_and_no_data_rows_is_an_error(tmp_path: Path) -> None:
    path = tmp_path / "names_only.lvm"
    path.write_text("LabVIEW Measurement\t\nX_Columns\tOne\n***End_of_Header***\t\n\n"
                    "X_Value\tVoltage\tComment\n")
    with pytest.raises(DataFileError, match="no data rows"):
        read(path, checksum=False)


# --- item 7: a segment whose ToC raw-data bit is cleared ------------------------------------

def test_segment_with_cleared_raw_data_bit_is_read_as_nptdms_reads_it(realdata_dir: Path,
                                                                      tmp_path: Path) -> None:
    source = realdata_dir / "npTDMS/big_endian.tdms"
    second = source.read_bytes().find(b"TDSm", 4)

    def edit(data: bytearray) -> None:
        data[second + 4] &= ~(1 << 3)  # kTocRawData

    path = _copy(source, tmp_path / "toc_cleared.tdms", edit)
    expected = _nptdms_values(path)
    streams, texts = _read(path)
    ds = next(iter(streams.values()))
    for name in ("Amplitude sweep", "Phase sweep"):
        key = next(k for k in expected if k.endswith("/" + name))
        assert expected[key].size == 3500
        np.testing.assert_array_equal(ds[name].values, expected[key])
    assert any("ToC says it has no raw data" in t and f"byte {second}" in t for t in texts)


# --- item 8: a value count corrupted to a huge number ---------------------------------------

def test_huge_daqmx_value_count_is_refused_before_any_allocation(realdata_dir: Path,
                                                                 tmp_path: Path) -> None:
    source = realdata_dir / "nidaqmx-python/data_ai.tdms"
    data = source.read_bytes()
    header = re.escape(struct.pack("<III", 0x1269, 0xFFFFFFFF, 1))
    at = next(m.start() for m in re.finditer(header, data)
              if struct.unpack_from("<Q", data, m.start() + 12)[0] > 0)

    def edit(buffer: bytearray) -> None:
        struct.pack_into("<Q", buffer, at + 12, 2**50)  # 1e15 values of a 2-byte raw buffer

    path = _copy(source, tmp_path / "huge_count.tdms", edit)
    with pytest.raises(DataFileError, match=r"claims chunks of \d+ bytes .* holds 28000 data"):
        read(path, checksum=False)
