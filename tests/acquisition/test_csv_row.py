"""A CSV of one row without a names row: one channel, every cell a sample or an invalid one.

The files are written here with numpy's own formatting (17 significant digits, so every float64
survives the text exactly), and the expectation is what was written: the values, their times
``i / fs``, and for each damaged cell its position and reason. The damage is placed at seeded
random positions, so the tests do not depend on where the reader looks.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from rigval.acquisition import read
from rigval.acquisition.csv_row import ROW_REASONS
from rigval.acquisition.errors import ChannelNotFoundError, DataWarning
from rigval.acquisition.schema import check_stream, invalid_counts

EMPTY, TEXT, CUT = ROW_REASONS


def _read(path: Path, **options: object) -> tuple[object, list[str]]:
    """Read a one-stream file; return the stream and the DataWarning texts."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        (stream,) = read(path, checksum=False, **options).values()
    check_stream(stream)
    return stream, [str(w.message) for w in caught if issubclass(w.category, DataWarning)]


def _cells(values: np.ndarray, decimal: str = ".") -> list[str]:
    """Return the values as text cells of 17 significant digits."""
    return [f"{v:.17g}".replace(".", decimal) for v in values]


@pytest.mark.parametrize("delimiter, decimal, line_end", [(",", ".", "\n"),
                                                         (";", ",", "\r\n"),
                                                         ("\t", ".", "\n")])
def test_wide_row_round_trip(tmp_path: Path, delimiter: str, decimal: str,
                             line_end: str) -> None:
    values = np.random.default_rng(11).normal(size=20_000) * 10.0 ** np.arange(-3, 3).repeat(
        20_000 // 6 + 1)[:20_000]
    path = tmp_path / "waveform_row.csv"
    path.write_text(delimiter.join(_cells(values, decimal)) + delimiter + line_end,
                    encoding="ascii")  # a trailing delimiter, as LabVIEW writes one
    stream, texts = _read(path, fs=2000.0)
    assert list(stream.data_vars) == ["row 0", "valid", "segment"]
    np.testing.assert_array_equal(stream["row 0"].values, values)  # exact: 17 digits
    np.testing.assert_array_equal(stream["time"].values, np.arange(values.size) / 2000.0)
    assert bool(stream["valid"].all()) and invalid_counts(stream) == {}
    assert stream.attrs["samples_in_file"] == values.size
    (told,) = [t for t in texts if "one row" in t]
    assert "line 1 is one row of 20000 values without a names row" in told
    assert "read as one channel 'row 0' of 20000 samples at 2000 Hz" in told


def test_named_row_is_one_sample_per_channel(tmp_path: Path) -> None:
    values = np.random.default_rng(12).normal(size=300)
    path = tmp_path / "snapshot.csv"
    names = [f"ch{k} [mV]" for k in range(values.size)]
    path.write_text(",".join(names) + "\n" + ",".join(_cells(values)) + "\n", encoding="ascii")
    stream, texts = _read(path, fs=1.0)
    assert stream.sizes["time"] == 1
    got = np.array([stream[f"ch{k}"].values[0] for k in range(values.size)])
    np.testing.assert_array_equal(got, values)
    assert stream["ch7"].attrs["units"] == "mV"
    assert not [t for t in texts if "one row" in t], texts


def test_row_named_by_its_first_cell(tmp_path: Path) -> None:
    values = np.linspace(-2.0, 3.0, 501)
    path = tmp_path / "torque_row.csv"
    path.write_text("Torque [N m]," + ",".join(_cells(values)) + "\n", encoding="ascii")
    stream, texts = _read(path, fs=500.0)
    np.testing.assert_array_equal(stream["Torque"].values, values)
    assert stream["Torque"].attrs["units"] == "N m"
    assert any("read as one channel 'Torque' of 501 samples" in t for t in texts), texts
    with pytest.raises(ChannelNotFoundError, match="row 0"), pytest.warns(DataWarning):
        read(path, fs=500.0, channels=["row 0"], checksum=False)


@pytest.mark.parametrize("delimiter, decimal", [(",", "."), (";", ",")])
def test_text_and_empty_cells_are_invalid_with_their_reason(tmp_path: Path, delimiter: str,
                                                            decimal: str) -> None:
    rng = np.random.default_rng(13)
    values = rng.normal(size=5000)
    cells = _cells(values, decimal)
    where = rng.choice(values.size, size=40, replace=False)
    text_at, empty_at = np.sort(where[:25]), np.sort(where[25:])
    for k in text_at:
        cells[k] = rng.choice(["overflow", "1.2.3", "#VALUE!", "--"])
    for k in empty_at:
        cells[k] = ""
    path = tmp_path / "damaged_row.csv"
    path.write_text(delimiter.join(cells) + "\n", encoding="ascii")
    stream, texts = _read(path, fs=100.0)
    expected = values.copy()
    expected[where] = np.nan
    np.testing.assert_array_equal(stream["row 0"].values, expected)  # every other value kept
    valid = np.ones(values.size, dtype=bool)
    valid[where] = False
    np.testing.assert_array_equal(stream["valid"].values, valid)
    assert invalid_counts(stream) == {TEXT: 25, EMPTY: 15}
    assert stream["row 0"].attrs["text_cells"] == 25
    assert stream["row 0"].attrs["empty_cells"] == 40
    assert any(f"invalid samples: 15 {EMPTY}; 25 {TEXT}" in t for t in texts), texts


def test_row_cut_mid_line_keeps_its_last_cell_flagged(tmp_path: Path) -> None:
    values = np.random.default_rng(14).uniform(1.0, 2.0, size=1000)
    cells = _cells(values)
    cells[-1] = cells[-1][:6]  # "1.2345": the file ends inside the last number
    path = tmp_path / "cut_row.csv"
    path.write_text(",".join(cells), encoding="ascii")  # no line end
    stream, _ = _read(path, fs=10.0)
    got = stream["row 0"].values
    np.testing.assert_array_equal(got[:-1], values[:-1])
    assert got[-1] == float(cells[-1])
    assert invalid_counts(stream) == {CUT: 1}
    assert not bool(stream["valid"].values[-1]) and bool(stream["valid"].values[:-1].all())


def test_ragged_second_row_is_reported_and_the_first_read(tmp_path: Path) -> None:
    values = np.random.default_rng(15).normal(size=(2, 3000))
    path = tmp_path / "ragged.csv"
    path.write_text(",".join(_cells(values[0])) + "\n" + ",".join(_cells(values[1][:1200]))
                    + "\n", encoding="ascii")
    stream, texts = _read(path, fs=10.0)
    np.testing.assert_array_equal(stream["row 0"].values, values[0])
    assert any("1 line(s) not read: last line with fewer fields than the line before it "
               "(lines [2])" in t for t in texts), texts


def test_time_range_counts_only_the_window(tmp_path: Path) -> None:
    values = np.arange(1000.0)
    cells = _cells(values)
    cells[100] = cells[900] = "x"
    path = tmp_path / "window_row.csv"
    path.write_text(",".join(cells) + "\n", encoding="ascii")
    stream, _ = _read(path, fs=100.0, time_range=(0.5, 5.0))  # samples 50 ... 500
    np.testing.assert_array_equal(stream["time"].values, np.arange(50, 501) / 100.0)
    assert invalid_counts(stream) == {TEXT: 1}
    assert int((~stream["valid"]).sum()) == 1 and np.isnan(stream["row 0"].values[50])


def test_labelled_row_under_header_lines_in_european_format(tmp_path: Path) -> None:
    cells = [f"{v:.6f}" for v in np.random.default_rng(16).normal(size=3000)]
    path = tmp_path / "drehmoment.csv"
    path.write_text("Datum;21.11.2026\nZeit;06:00:00\nDrehmoment [N m];"
                    + ";".join(c.replace(".", ",") for c in cells) + "\r\n", encoding="ascii")
    stream, _ = _read(path, fs=100.0)
    expected = np.array([float(c) for c in cells])  # the decimals as written
    np.testing.assert_array_equal(stream["Drehmoment"].values, expected)
    assert stream["Drehmoment"].attrs["units"] == "N m"
    assert stream.attrs["start_time"] == "2026-11-21T06:00:00.000000000Z"
