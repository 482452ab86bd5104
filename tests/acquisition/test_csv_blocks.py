"""The CSV reader's block path gives the per-line path's results, whatever the block size."""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from rigval.acquisition import csv_blocks, read_csv, text_csv
from rigval.acquisition.schema import string_table

ROWS = 3000
MIDDLE = ROWS + 2 - 1500  # lines between the 1000 head and 500 tail lines sniffed per line
FS = 50_000 / 31


def _write(path: Path, rows: list[str], head: str = "Device;WLS-9163 #2\n",
           encoding: str = "ascii") -> Path:
    header = "Time [s];tor3 [V/V];opt3 [V]\n"
    path.write_text(head + header + "\n".join(rows).replace(".", ",") + "\n", encoding=encoding)
    return path


def _rows(n: int = ROWS) -> tuple[list[str], np.ndarray]:
    rng = np.random.default_rng(5)
    values = rng.normal(0, 1e-4, (n, 2))
    rows = [f"{k / FS:.6f};{a:.6E};{b:.6E}" for k, (a, b) in enumerate(values)]
    return rows, values


def _read(path: Path) -> tuple[xr.Dataset, list[str]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        stream = next(iter(read_csv(path, checksum=False).values()))
    return stream, [str(w.message) for w in caught]


def _per_line(path: Path, monkeypatch: pytest.MonkeyPatch) -> tuple[xr.Dataset, list[str]]:
    with monkeypatch.context() as patch:
        patch.setattr(csv_blocks, "HEAD_LINES", 10**9)  # no middle: every line one by one
        return _read(path)


def _spy(monkeypatch: pytest.MonkeyPatch) -> list[tuple[int, int] | None]:
    """Record the rows parsed in blocks and the lines left to the per-line rules per read."""
    calls: list[tuple[int, int] | None] = []
    real = text_csv.parse_middle

    def spy(*args: object) -> csv_blocks.Middle | None:
        out = real(*args)  # type: ignore[arg-type]
        calls.append(None if out is None else
                     (out.line.size, sum(len(lines) for _, lines in out.segments)))
        return out

    monkeypatch.setattr(text_csv, "parse_middle", spy)
    return calls


def _same(a: tuple[xr.Dataset, list[str]], b: tuple[xr.Dataset, list[str]]) -> None:
    xr.testing.assert_identical(a[0], b[0])
    assert a[1] == b[1]


@pytest.mark.parametrize("block", [97, 4096, 1 << 22])
def test_clean_file_in_blocks_equals_one_block_and_the_per_line_path(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, block: int) -> None:
    rows, values = _rows()
    path = _write(tmp_path / "clean.csv", rows)
    calls = _spy(monkeypatch)
    whole = _read(path)
    monkeypatch.setattr(csv_blocks, "BLOCK_BYTES", block)
    pieces = _read(path)
    assert calls == [(MIDDLE, 0), (MIDDLE, 0)]
    _same(pieces, whole)
    _same(pieces, _per_line(path, monkeypatch))
    written = [float(f"{v:.6E}") for v in values[:, 0]]
    np.testing.assert_array_equal(pieces[0]["tor3"].values, written)
    np.testing.assert_array_equal(pieces[0].time.values, [float(f"{k / FS:.6f}")
                                                          for k in range(ROWS)])
    assert pieces[1] == [] and pieces[0].attrs["samples_in_file"] == ROWS


@pytest.mark.parametrize("where", ["starts", "ends", "tiny", "small"])
def test_bad_rows_on_block_boundaries_counts_and_reasons_as_per_line(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, where: str) -> None:
    rows, _ = _rows()
    rows[998 + 40] = "sensor reconnected"
    rows[998 + 59] = rows[998 + 59] + ";7,5"  # a field more
    rows[998 + 60] = rows[998 + 60].split(";")[0] + ";;"  # empty cells
    rows[2000] = "Prüfung unterbrochen"  # non-ASCII text in another block
    path = _write(tmp_path / "bad.csv", rows, encoding="utf-8")
    text = path.read_text()
    middle = len("\n".join(text.split("\n")[:1000])) + 1  # after the 1000 head lines
    bad = text.index("sensor") - middle
    block = {"starts": bad + 1, "ends": bad + len("sensor reconnected\n"), "tiny": 7,
             "small": 600}[where]
    if where == "starts":  # the first block ends right above the text row
        assert text[middle:middle + block].endswith("\ns") and text[middle - 1] == "\n"
    if where == "ends":  # the text row is the first block's last line
        assert text[middle:middle + block].endswith("\nsensor reconnected\n")
    calls = _spy(monkeypatch)
    whole = _read(path)
    monkeypatch.setattr(csv_blocks, "BLOCK_BYTES", block)
    pieces = _read(path)
    assert calls[0] == (0, MIDDLE)  # one block holding text: all lines read one by one
    parsed, one_by_one = calls[1]
    assert parsed + one_by_one == MIDDLE and one_by_one < (200 if where != "small" else 800)
    _same(pieces, whole)
    _same(pieces, _per_line(path, monkeypatch))
    assert pieces[0].sizes["time"] == ROWS - 3
    assert np.count_nonzero(np.isnan(pieces[0]["tor3"].values)) == 1
    assert any("not a data row" in w and "[1041, 2003]" in w for w in pieces[1])
    assert any("more fields than the names row" in w and "[1060]" in w for w in pieces[1])


def test_bad_rows_in_head_and_tail_keep_their_line_numbers(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    rows, _ = _rows()
    rows[100] = "pause"                        # a text line in the head's data rows
    rows[150] = rows[150] + ";1,0"             # a field more, in the head
    rows[ROWS - 200] = "resume"                # a text line among the tail's rows
    rows[ROWS - 150] = rows[ROWS - 150] + ";1,0"  # a field more, in the tail
    rows[ROWS - 120] = rows[ROWS - 120].rsplit(";", 1)[0] + ";x"  # a text cell: NaN
    rows[ROWS - 100] = rows[ROWS - 100].split(";")[0] + ";;"  # empty cells: NaN
    rows[-1] = rows[-1][:9]                    # the file cut mid-line
    path = _write(tmp_path / "edges.csv", rows)
    path.write_text(path.read_text().rstrip("\n"), encoding="ascii")
    calls = _spy(monkeypatch)
    monkeypatch.setattr(csv_blocks, "BLOCK_BYTES", 1000)
    pieces = _read(path)
    assert calls == [(MIDDLE, 0)]  # the middle was clean and parsed in blocks
    _same(pieces, _per_line(path, monkeypatch))
    text = "\n".join(pieces[1])
    # 1-based line numbers: two lines above the data
    for line in (103, 153, ROWS - 197, ROWS - 147, ROWS - 117, ROWS + 2):
        assert re.search(rf"\b{line}\b", text), line
    assert pieces[0].sizes["time"] == ROWS - 5
    assert pieces[0]["tor3"].attrs["empty_cells"] == 1


def test_windows_line_ends_and_a_trailing_delimiter_take_the_block_path(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    rows, _ = _rows()
    path = tmp_path / "crlf.csv"
    text = _write(path, [r + ";" for r in rows]).read_text()
    path.write_bytes(text.replace("\n", "\r\n").encode("ascii"))
    calls = _spy(monkeypatch)
    pieces = _read(path)
    assert calls == [(MIDDLE, 0)]
    _same(pieces, _per_line(path, monkeypatch))


@pytest.mark.parametrize("encoding", ["utf-8-sig", "cp1252"])
def test_encoded_head_and_tail_read_as_the_whole_file(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, encoding: str) -> None:
    rows, _ = _rows()
    path = tmp_path / "encoded.csv"
    _write(path, rows, head="Prüfstand;Halle 3 – µ-Messung\n", encoding=encoding)
    with path.open("ab") as stream:
        stream.write("Ende ±\n".encode(encoding))
    calls = _spy(monkeypatch)
    pieces = _read(path)
    assert calls == [(MIDDLE + 1, 0)]  # the footer: one line more in the file
    _same(pieces, _per_line(path, monkeypatch))
    assert string_table(pieces[0].attrs, "text_header")["Prüfstand"] == "Halle 3 – µ-Messung"
    assert any("not a data row" in w and f"[{ROWS + 3}]" in w for w in pieces[1])


def test_text_rows_ending_and_starting_blocks_keep_the_block_path(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    rows = [f"{k / FS:012.6f};{0.5 + (k % 7) / 10:.6E};{2.5:.6E}" for k in range(ROWS)]
    size = len(rows[0]) + 1  # every line this long: blocks of 10 lines exactly
    rows[998 + 9] = "X" * (size - 1)    # the last line of the middle's first block
    rows[998 + 20] = "Y" * (size - 1)   # the first line of its third block
    path = _write(tmp_path / "xy.csv", rows)
    monkeypatch.setattr(csv_blocks, "BLOCK_BYTES", 10 * size)
    taken: list[bool] = []
    real = text_csv._fast_path

    def spy(*args: object) -> object:
        out = real(*args)  # type: ignore[arg-type]
        taken.append(out is not None)
        return out

    monkeypatch.setattr(text_csv, "_fast_path", spy)
    pieces = _read(path)
    # each text row read one by one between clean rows, as in the whole file
    assert taken == [True]
    _same(pieces, _per_line(path, monkeypatch))
    assert any("not a data row" in w and "[1010, 1021]" in w for w in pieces[1])
