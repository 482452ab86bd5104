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


# --- item 2: LVM time axes that do not increase ---------------------------------------------

def _lvm_edit(source: Path, target: Path, old: str, new: str, count: int = -1) -> Path:
    """Copy an LVM file replacing ``old`` by ``new`` (``count`` times, default all)."""
    text = source.read_text()
    assert old in text
    target.write_text(text.replace(old, new, count))
    return target


def test_lvm_constant_x_column_is_read_by_delta_x(realdata_dir: Path, tmp_path: Path) -> None:
    source = realdata_dir / "lvm_read/with_empty_fields.lvm"
    text = source.read_text()
    lines = text.splitlines(keepends=True)
    first = next(k for k, ln in enumerate(lines) if ln.startswith("X_Value")) + 1
    for k in range(first, len(lines)):
        lines[k] = "0.000000" + lines[k][lines[k].index("\t"):]
    path = tmp_path / "constant_x.lvm"
    path.write_text("".join(lines))
    original, _ = _read(source)
    streams, texts = _read(path)
    ds = streams["constant_x"]
    np.testing.assert_allclose(ds.time.values, np.arange(7) * 0.001, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(ds["Dev0/Ai2"].values,
                                  original["with_empty_fields"]["Dev0/Ai2"].values)
    assert any("X values do not increase" in t and "Delta_X = 0.001" in t for t in texts)


def test_lvm_delta_x_zero_is_an_error_unless_fs_is_given(realdata_dir: Path,
                                                         tmp_path: Path) -> None:
    path = _lvm_edit(realdata_dir / "lvm_read/short.lvm", tmp_path / "dx0.lvm",
                     "3,906250E-5", "0,000000")
    with pytest.raises(DataFileError, match=r"time axis of channel .* is not increasing"):
        read(path, checksum=False)
    streams, _ = _read(path, fs=25600.0)
    np.testing.assert_allclose(streams["dx0"].time.values, np.arange(10) / 25600.0)


@pytest.mark.parametrize("x0", ["NaN", "1,0E+308"])
def test_lvm_unusable_x0_is_taken_as_zero_with_a_warning(realdata_dir: Path, tmp_path: Path,
                                                         x0: str) -> None:
    path = _lvm_edit(realdata_dir / "lvm_read/short.lvm", tmp_path / "x0.lvm",
                     "0,0000000000000000E+0", x0)
    streams, texts = _read(path)
    np.testing.assert_allclose(streams["x0"].time.values, np.arange(10) * 3.90625e-5,
                               rtol=1e-12)
    assert any("X0 = " in t and "taken as 0 s" in t for t in texts)


# --- item 3: a text X cell in an LVM data row -------------------------------------------------

def test_lvm_text_x_cell_keeps_every_row(realdata_dir: Path, tmp_path: Path) -> None:
    source = realdata_dir / "lvm_read/with_empty_fields.lvm"
    path = _lvm_edit(source, tmp_path / "text_x.lvm", "\n0.003000\t", "\nabc\t", 1)
    original, _ = _read(source)
    streams, texts = _read(path)
    ds, ref = streams["text_x"], original["with_empty_fields"]
    assert ds.sizes["time"] == ref.sizes["time"] == 7
    np.testing.assert_allclose(ds.time.values, ref.time.values, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(ds["Dev0/Ai0"].values, ref["Dev0/Ai0"].values)
    line = source.read_text().splitlines().index(
        next(ln for ln in source.read_text().splitlines() if ln.startswith("0.003000"))) + 1
    assert any("X cell(s)" in t and "'abc'" in t and f"line {line}" in t for t in texts)


# --- item 4: text files cut mid-line ----------------------------------------------------------

def _sample_csv_head(tmp_path: Path, rows: int = 641) -> tuple[Path, list[str]]:
    """The first ``rows`` data rows of a shipped sample-run CSV (3 header lines)."""
    from rigval.sample_data import runs_dir

    lines = (runs_dir() / "run_0p8_wls2.csv").read_text().splitlines(keepends=True)[:3 + rows]
    path = tmp_path / "wls2.csv"
    path.write_text("".join(lines))
    return path, lines


def test_csv_cut_mid_line_drops_and_counts_the_last_row(tmp_path: Path) -> None:
    path, lines = _sample_csv_head(tmp_path)
    intact, _ = _read(path)
    last = lines[-1].rstrip("\n")
    cut = tmp_path / "cut.csv"
    cut.write_text("".join(lines[:-1]) + last[:last.rindex("E")])  # '...E-07' -> '...'
    streams, texts = _read(cut)
    ds, ref = streams["cut"], intact["wls2"]
    assert ds.sizes["time"] == 640
    for name in ("tor3", "tor4", "opt3"):
        np.testing.assert_array_equal(ds[name].values, ref[name].values[:640])
    assert any("1 line(s) not read: last line without its line end" in t
               and f"[{len(lines)}]" in t for t in texts)
    fewer = tmp_path / "fewer.csv"
    fewer.write_text("".join(lines[:-1]) + last[:last.rindex(";")] + "\n")
    streams, texts = _read(fewer)
    assert streams["fewer"].sizes["time"] == 640
    assert any("fewer fields than the line before it" in t for t in texts)


def test_lvm_cut_mid_line_drops_and_counts_the_last_row(realdata_dir: Path,
                                                        tmp_path: Path) -> None:
    source = realdata_dir / "lvm_read/short.lvm"
    text = source.read_text().rstrip("\n")
    path = tmp_path / "cut.lvm"
    path.write_text(text[:-3])  # '1,212775' -> '1,212'
    original, _ = _read(source)
    streams, texts = _read(path)
    assert streams["cut"].sizes["time"] == 9
    np.testing.assert_array_equal(streams["cut"]["Response (Trigger)"].values,
                                  original["short"]["Response (Trigger)"].values[:9])
    assert any("has no line end" in t for t in texts)


# --- item 5: non-data rows in a CSV -----------------------------------------------------------

def test_csv_nan_row_and_footer_lose_only_themselves(tmp_path: Path) -> None:
    path, lines = _sample_csv_head(tmp_path)
    intact, _ = _read(path)
    ref = intact["wls2"]
    nan_row = tmp_path / "nan_row.csv"
    nan_row.write_text("".join(lines[:323]) + "NaN;NaN;NaN;NaN\n" + "".join(lines[323:]))
    streams, texts = _read(nan_row)
    ds = streams["nan_row"]
    assert ds.sizes["time"] == 641
    np.testing.assert_array_equal(ds["tor3"].values, ref["tor3"].values)
    np.testing.assert_array_equal(ds.time.values, ref.time.values)
    assert any("time cell not a number (lines [324])" in t for t in texts)
    footer = tmp_path / "footer.csv"
    footer.write_text("".join(lines) + "Statistics\nMean;1,1E-05;1,1E-05;1,0E-07\n")
    streams, texts = _read(footer)
    ds = streams["footer"]
    assert ds.sizes["time"] == 641
    np.testing.assert_array_equal(ds["opt3"].values, ref["opt3"].values)
    lost = sum(int(re.search(r"(\d+) line\(s\) not read", t).group(1)) for t in texts
               if "not read" in t)
    assert lost == 2


def test_csv_all_nan_column_is_kept_and_counted(tmp_path: Path) -> None:
    path, lines = _sample_csv_head(tmp_path, rows=20)
    edited = [lines[0], lines[1], lines[2].rstrip("\n") + ";spare [V]\n"]
    edited += [ln.rstrip("\n") + ";NaN\n" for ln in lines[3:]]
    path.write_text("".join(edited))
    streams, texts = _read(path)
    ds = streams["wls2"]
    assert np.isnan(ds["spare"].values).all() and ds["spare"].attrs["empty_cells"] == 20
    assert any("'spare' holds no finite value" in t for t in texts)


# --- found by the fuzz suite ------------------------------------------------------------------

@pytest.mark.parametrize("increment", [5e-324, 1e300, -1.0])
def test_implausible_wf_increment_falls_back_to_the_sample_index(
        realdata_dir: Path, tmp_path: Path, increment: float) -> None:
    source = realdata_dir / "npTDMS/big_endian.tdms"
    data = source.read_bytes()
    at = data.index(b"wf_increment") + len(b"wf_increment") + 4  # u32 type code, then the value

    def edit(buffer: bytearray) -> None:
        struct.pack_into(">d", buffer, at, increment)

    path = _copy(source, tmp_path / "odd_increment.tdms", edit)
    expected = _nptdms_values(path)
    streams, texts = _read(path)
    odd = [ds for ds in streams.values() if ds.attrs["fs_nominal"] == 1.0]
    assert len(odd) == 1 and odd[0].sizes["time"] == 3500
    np.testing.assert_array_equal(odd[0].time.values, np.arange(3500.0))
    name = next(n for n in odd[0].data_vars if n not in ("valid", "segment"))
    key = next(k for k in expected if k.endswith("/" + name))
    np.testing.assert_array_equal(odd[0][name].values, expected[key])
    assert any("time is the sample index" in t for t in texts)
