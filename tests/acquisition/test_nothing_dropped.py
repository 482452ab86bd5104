"""Nothing dropped silently (issue 26, item 3), each defect reproduced on a file written here.

- a complex-valued TDMS channel (an NI RF capture's "Polar Graph") is read as its real and
  imaginary parts (``test_tdms_complex.py``); an intact file gets no warning of unread channels;
- a segment whose data index claims 0 values of a channel while the segment holds data is read
  as nptdms reads it, with a DataWarning giving the counts;
- a CSV of one row of 20,000 values is read as one channel (values as written, see
  ``test_csv_row.py``) or, without a rate, refused at once with the reason, before any cell is
  converted.
"""

from __future__ import annotations

import re
import struct
import warnings
from pathlib import Path

import numpy as np
import pytest
from nptdms import ChannelObject, GroupObject, RootObject, TdmsFile, TdmsWriter

from rigval.acquisition import read
from rigval.acquisition.errors import DataFileError, DataWarning


def _read(path: Path, **options: object) -> tuple[dict, list[str]]:
    """Read a file, returning the streams and the DataWarning texts."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        streams = read(path, checksum=False, **options)
    return streams, [str(w.message) for w in caught if issubclass(w.category, DataWarning)]


# --- complex channels: read as their parts, see test_tdms_complex.py ----------------------

def test_intact_real_file_gets_no_unread_warning(tmp_path: Path) -> None:
    path = tmp_path / "plain.tdms"
    with TdmsWriter(path) as writer:
        writer.write_segment([GroupObject("g"), ChannelObject("g", "a", np.arange(50.0),
                                                               properties={"wf_increment": 0.1})])
    _, texts = _read(path)
    assert not [t for t in texts if "are not read" in t or "announces 0 values" in t]


# --- a value count zeroed in the metadata --------------------------------------------------

def _three_segments(path: Path, n: int) -> dict[str, np.ndarray]:
    """Write two float channels in three segments of ``n`` values each; return the values."""
    written = {"c0": np.arange(3 * n, dtype=float), "c1": 1000.0 + np.arange(3 * n)}
    with TdmsWriter(path) as writer:
        for s in range(3):
            objects = [RootObject(), GroupObject("g")] if s == 0 else []
            objects += [ChannelObject("g", name, values[s * n:(s + 1) * n],
                                      properties={"wf_increment": 0.01} if s == 0 else {})
                        for name, values in written.items()]
            writer.write_segment(objects)
    return written


def _count_fields(data: bytes, n: int) -> list[int]:
    """Byte offsets of the value counts of every float64 raw data index announcing ``n``."""
    pattern = struct.pack("<IIIQ", 20, 10, 1, n)  # index length, tdsTypeDoubleFloat, dim, count
    return [m.start() + 12 for m in re.finditer(re.escape(pattern), data)]


@pytest.mark.parametrize("which", range(6))
def test_zeroed_value_count_is_warned_with_counts(tmp_path: Path, which: int) -> None:
    n = 100
    base = tmp_path / "base.tdms"
    written = _three_segments(base, n)
    data = bytearray(base.read_bytes())
    fields = _count_fields(bytes(data), n)
    assert len(fields) == 6  # two channels in each of three segments
    data[fields[which]:fields[which] + 8] = struct.pack("<Q", 0)
    damaged = tmp_path / "zeroed.tdms"
    damaged.write_bytes(bytes(data))
    segment, zeroed = divmod(which, 2)
    other = f"c{1 - zeroed}"
    nptdms_values = {c.name: c[:] for c in TdmsFile.read(damaged)["g"].channels()}
    # nptdms reads the segment's bytes as two chunks of the other channel
    assert {k: v.size for k, v in nptdms_values.items()} == {f"c{zeroed}": 2 * n, other: 4 * n}
    streams, texts = _read(damaged)
    got = {name: ds[name].values for ds in streams.values() for name in ds.data_vars
           if name not in ("valid", "segment")}
    for name, values in got.items():
        np.testing.assert_array_equal(values, nptdms_values[name])
    kept = np.delete(written[f"c{zeroed}"], np.s_[segment * n:(segment + 1) * n])
    np.testing.assert_array_equal(got[f"c{zeroed}"], kept)  # the other segments as written
    warned = [t for t in texts if "announces 0 values" in t]
    assert len(warned) == 1, texts
    assert f"the data index of g/c{zeroed} announces 0 values" in warned[0]
    assert f"holds {2 * n * 8} data bytes" in warned[0]
    assert f"g/{other}: {2 * n} values" in warned[0]  # what this segment gave the other channel


# --- a CSV of one wide row -----------------------------------------------------------------

def _wide_row(path: Path, values: np.ndarray, delimiter: str = ",") -> None:
    path.write_text(delimiter.join(f"{v:.17g}" for v in values) + "\n", encoding="ascii")


def test_one_wide_row_without_rate_is_refused_before_conversion(tmp_path: Path) -> None:
    path = tmp_path / "spectrum_row.csv"
    _wide_row(path, np.random.default_rng(3).normal(size=20_000))
    with pytest.raises(DataFileError, match="no time column found and no fs given") as info:
        read(path, checksum=False)
    assert "one row of 20000 values" in str(info.value)


def test_one_wide_row_with_rate_reads_every_value(tmp_path: Path) -> None:
    path = tmp_path / "row.csv"
    values = np.random.default_rng(4).normal(size=20_000) * 1e3
    _wide_row(path, values)
    streams, texts = _read(path, fs=10.0)
    (stream,) = streams.values()
    np.testing.assert_array_equal(stream["row 0"].values, values)  # 17 digits: exact round trip
    np.testing.assert_array_equal(stream["time"].values, np.arange(values.size) / 10.0)
    assert any("read as one channel 'row 0' of 20000 samples" in t for t in texts), texts


def test_few_wide_rows_keep_text_and_empty_cells_apart(tmp_path: Path) -> None:
    path = tmp_path / "wide_table.csv"
    rng = np.random.default_rng(5)
    values = np.round(rng.normal(size=(3, 3000)), 6)
    cells = [[f"{v:.6f}".replace(".", ",") for v in row] for row in values]
    cells[1][17] = "overflow"  # text: NaN and a warning naming its line
    cells[2][42] = ""  # empty: NaN, counted as an empty cell
    names = ["Time"] + [f"ch{k}" for k in range(1, 3000)]
    lines = [";".join(names)] + [";".join([str(r), *row[1:]]) for r, row in enumerate(cells)]
    path.write_text("\n".join(lines) + "\n", encoding="ascii")
    streams, texts = _read(path)
    (stream,) = streams.values()
    expected = values.copy()
    expected[1, 17] = expected[2, 42] = np.nan
    for k in (1, 17, 42, 2999):
        np.testing.assert_array_equal(stream[f"ch{k}"].values, expected[:, k])
    assert any("column 'ch17': 1 cell(s) are not numbers (first on line 3: 'overflow')" in t
               for t in texts), texts
    assert stream["ch42"].attrs["empty_cells"] == 1
    np.testing.assert_array_equal(stream["time"].values, [0.0, 1.0, 2.0])
