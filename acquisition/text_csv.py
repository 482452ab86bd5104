"""Read delimited text exports (LabVIEW "Write Delimited Spreadsheet", European CSV) into a stream.

Every guess can be overridden by an option:

- ``delimiter``: ``;``, tab, ``,`` or ``|``, whichever splits the last lines into the same number
  (> 1) of fields, in that order of preference;
- ``decimal``: ``,`` when the delimiter is not a comma and the numbers use a comma, else ``.``;
- header: the data block is the longest run of numeric lines at the end of the file; the line
  above it holds the column names (``acc1 [m/s^2]``, ``tor3 (V/V)``), optionally a units row in
  brackets between names and data; lines above are ``key<delimiter>value`` pairs kept in the
  string-array attributes ``text_header_keys``/``text_header_values`` (read them back with
  :func:`rigval.acquisition.schema.string_table`; a start time among them is used, see below);
- ``time_column``: the first column named like ``Time``, ``Zeit``, ``t``, ``X_Value``,
  ``Timestamp`` or ``Date``, else none (then ``fs`` is needed); its cells are relative seconds
  (``ms`` in the header scales), ISO 8601 timestamps, or local date-times (``9/5/2014 11:53:14 AM``,
  ``21.11.2026 06:00:00,125``; ``time_format`` overrides) taken in ``timezone`` (default UTC);
- ``start_time``: from absolute time cells, else a header entry named like ``Start time``,
  ``t0``, ``wf_start_time`` or ``Date`` + ``Time``, else 1904-01-01 (unknown) with a note.

Jumps in the time column (restarts, dropouts) are kept as gaps. Empty cells become NaN, counted per
channel in the attribute ``empty_cells``. A data block of one row without a names row is a waveform
written as a row: one channel of ``fs`` samples per second (:mod:`rigval.acquisition.csv_row`).
"""

from __future__ import annotations

import csv
import io
import logging
import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from rigval.acquisition.csv_blocks import Middle, is_clean_row, parse_middle, split_file
from rigval.acquisition.csv_cells import NUMBER as _NUMBER
from rigval.acquisition.csv_cells import convert_table, split_rows
from rigval.acquisition.csv_row import read_row
from rigval.acquisition.csv_time import header_start, parse_datetimes
from rigval.acquisition.detect import checked_path, source_checksum
from rigval.acquisition.devices import get_device, module_attrs
from rigval.acquisition.errors import ChannelNotFoundError, ConfigError, DataFileError
from rigval.acquisition.schema import Channel, stream_dataset, string_table_attrs
from rigval.acquisition.time_fallbacks import TimeFallback, time_fallback_attrs
from rigval.acquisition.units import split_name_and_unit, udunits
from rigval.acquisition.warn import warn_data

__all__ = ["CsvLayout", "read_csv", "read_text", "read_text_lines", "sniff_csv"]

logger = logging.getLogger(__name__)

_DELIMITERS = (";", "\t", ",", "|")
_COMMA_NUMBER = re.compile(r"^\s*[-+]?\d*,\d+([eE][-+]?\d+)?\s*$")
_TIME_NAMES = re.compile(r"^(time|zeit|t|x_value|timestamp|zeitstempel|datetime|date|datum|"
                         r"relative time|elapsed time)\b", re.IGNORECASE)
_DATE_TIME = re.compile(r"^\s*\d{1,4}[-./]\d{1,2}[-./]\d{1,4}[ T]\d{1,2}:\d{2}")
_EPOCH_1904 = np.datetime64("1904-01-01T00:00:00", "ns")
_SAMPLE_ROWS = 200  # first data rows that decide the decimal separator
_TAIL_WINDOW = 400  # last lines whose data rows decide the data's width


@dataclass(frozen=True)
class CsvLayout:
    """What :func:`sniff_csv` found out about a text file.

    Attributes
    ----------
    delimiter, decimal : str
        Field and decimal separators.
    data_start : int
        Index of the first data line.
    names : list of str
        Column names without units.
    units : list of str or None
        Units as written per column (None where absent).
    header : dict
        ``key -> value`` pairs above the column names.
    skipped : tuple of int
        Indices of lines at or after ``data_start`` that are not data rows (a text line inside
        the data, a footer such as ``Statistics``); the reader drops and reports them.
    names_row : int or None
        Index of the line holding the column names (None: the file has none).
    """

    delimiter: str
    decimal: str
    data_start: int
    names: list[str]
    units: list[str | None]
    header: dict[str, str]
    skipped: tuple[int, ...] = ()
    names_row: int | None = None


def read_text_lines(path: Path, encoding: str | None = None) -> list[str]:
    """Return the lines of a text file (see :func:`read_text`)."""
    return read_text(path, encoding)[0]


def read_text(path: Path, encoding: str | None = None) -> tuple[list[str], bool]:
    """Return the lines of a text file and whether its last line ends with a line end.

    Parameters
    ----------
    path : pathlib.Path
        The file.
    encoding : str, optional
        Text encoding; default UTF-8 (with or without BOM), else cp1252.

    Returns
    -------
    lines : list of str
        Lines without line ends.
    complete : bool
        False when the text stops inside its last line (a file cut mid-line).

    Raises
    ------
    DataFileError
        If the bytes do not decode.
    ConfigError
        For an unknown encoding name.
    """
    text, complete = _decode(path, encoding, stacklevel=4)
    return text.splitlines(), complete


def _decode(path: Path, encoding: str | None, stacklevel: int) -> tuple[str, bool]:
    """Return the text of a file and whether it ends with a line end (see :func:`read_text`)."""
    raw = path.read_bytes()
    candidates = [encoding] if encoding else ["utf-8-sig", "cp1252"]
    if not encoding and raw[:2] in (b"\xff\xfe", b"\xfe\xff"):
        candidates.insert(0, "utf-16")  # a byte-order mark says UTF-16 (Windows "Unicode")
    for candidate in candidates:
        try:
            text = raw.decode(candidate)
            return text, not text or text.endswith(("\n", "\r"))
        except UnicodeDecodeError:
            continue
        except LookupError:
            raise ConfigError(f"unknown text encoding {encoding!r}",
                              where={"file": str(path), "key": "encoding"}) from None
    if not encoding:
        try:
            raw.decode("utf-8")
        except UnicodeDecodeError as error:
            first = error.start
        text = raw.decode("utf-8", errors="replace")
        if text.count("\ufffd") < max(16, len(raw) // 10):  # local damage, not an encoding
            warn_data(f"{text.count(chr(0xFFFD))} character(s) are neither UTF-8 nor cp1252 "
                      f"(first at byte {first}): replaced by U+FFFD", where={"file": str(path)},
                      hint="the file is damaged there, or pass encoding=...", stacklevel=stacklevel)
            return text, text.endswith(("\n", "\r"))
    raise DataFileError(f"text is not {encoding or 'UTF-8 or cp1252'}", where={"file": str(path)},
                        hint="pass encoding=... (e.g. 'latin-1')")


def _split(line: str, delimiter: str) -> list[str]:
    """Split a line, dropping one trailing empty field left by a trailing delimiter."""
    fields = line.split(delimiter)
    if len(fields) > 1 and fields[-1].strip() == "":
        fields.pop()
    return fields


def _is_data(fields: list[str]) -> bool:
    """Return True when a row looks like data: most cells numeric or a date-time first."""
    cells = [f for f in fields if f.strip()]
    if not cells:
        return False
    numeric = sum(bool(_NUMBER.match(c)) for c in cells)
    text = max(1, len(cells) // 100)  # one text cell; 1 % in a row of >= 200 (a waveform row)
    return numeric >= max(1, len(cells) - text) and (numeric >= len(cells) / 2)


def _all_numbers(fields: list[str]) -> bool:
    """Return True when every non-empty cell is a number (the first may be a date-time)."""
    first, *rest = fields
    return (bool(_NUMBER.match(first) or _DATE_TIME.match(first))
            and all(_NUMBER.match(c) for c in rest if c.strip()))


def _guess_delimiter(lines: list[str]) -> str:
    """Return the delimiter that splits the most of the last lines into data rows (> 1 field).

    A decimal comma splits data rows too, but into cells that are not numbers (``"000000;1"``);
    counting data rows, not equal field counts, keeps one ragged or cut row from tipping the
    choice. Ties go to the first of ``;``, tab, ``,``, ``|``. When no delimiter gives a row of
    numbers only (a single data row holding a text cell), rows that are mostly numbers count.
    """
    tail = [ln for ln in lines[-200:] if ln.strip()]
    for is_row in (_all_numbers, _is_data):
        best, best_score = ",", 0
        for delimiter in _DELIMITERS:
            score = sum(1 for ln in tail
                        if len(fields := _split(ln, delimiter)) > 1 and is_row(fields))
            if score > best_score:
                best, best_score = delimiter, score
        if best_score:
            break
    return best


def sniff_csv(lines: list[str], *, delimiter: str | None = None, decimal: str | None = None,
              header_row: int | None = None, units_row: int | None = None,
              file: Path | None = None) -> CsvLayout:
    """Find delimiter, decimal separator, header, units and the data block of a text table.

    Parameters
    ----------
    lines : list of str
        The file's lines.
    delimiter, decimal : str, optional
        Override the guesses (a tab character for tab).
    header_row, units_row : int, optional
        0-based line numbers of the names and units rows (override the guesses; data then start
        on the next line).
    file : pathlib.Path, optional
        For error messages.

    Returns
    -------
    CsvLayout
        The layout.

    Raises
    ------
    DataFileError
        If no numeric data block is found.
    """
    where = {"file": str(file) if file else None}
    delimiter = delimiter or _guess_delimiter(lines)
    rows = [_split(ln, delimiter) for ln in lines]
    skipped: set[int] = set()
    if header_row is not None:
        data_start = max(header_row, units_row if units_row is not None else -1) + 1
        width = len(rows[header_row])
    else:
        end = len(rows)
        while end > 0 and not lines[end - 1].strip():
            end -= 1
        if end == 0:
            raise DataFileError("text file holds no lines", where=where)
        data_start, skipped = _data_block(lines, rows, end)
        counts = [len(r) for k, r in enumerate(rows[data_start:end], data_start)
                  if k not in skipped and lines[k].strip()]
        width = max(set(counts), key=counts.count) if counts else 0  # one ragged row aside
        if data_start >= end or not _is_data(rows[data_start]):
            raise DataFileError("no block of numeric rows found at the end of the text file",
                                where=where, hint="pass header_row=... and delimiter=...")
        above = data_start - 1
        if units_row is None and above >= 1 and len(rows[above]) == width and all(
                (c.strip().startswith(("[", "(")) or not c.strip()) for c in rows[above]) \
                and len(rows[above - 1]) == width:
            units_row, above = above, above - 1
        header_row = above if above >= 0 and len(rows[above]) == width else None
    sample = [c for r in rows[data_start:data_start + _SAMPLE_ROWS] for c in r if c.strip()]
    if decimal is None:
        decimal = "," if delimiter != "," and any(_COMMA_NUMBER.match(c) for c in sample) else "."
    if header_row is not None:
        split = [split_name_and_unit(c) for c in rows[header_row][:width]]
        names = [n or f"column {k}" for k, (n, _) in enumerate(split)]
        units = [u for _, u in split]
    else:
        names = [f"column {k}" for k in range(width)]
        units = [None] * width
    if units_row is not None:
        units = [c.strip().strip("[]()").strip() or None for c in rows[units_row][:width]]
        units += [None] * (width - len(units))
    first_meta = 0
    last_meta = header_row if header_row is not None else data_start
    header: dict[str, str] = {}
    for row in rows[first_meta:last_meta]:
        cells = [c.strip() for c in row]
        if cells and cells[0]:
            key = cells[0].rstrip(":=").strip()
            header[key] = delimiter.join(c for c in cells[1:] if c).strip()
    return CsvLayout(delimiter, decimal, data_start, names, units, header, tuple(sorted(skipped)),
                     header_row)


def _data_block(lines: list[str], rows: list[list[str]], end: int) -> tuple[int, set[int]]:
    """Return the first line of the data block and the non-data lines inside or below it.

    From the last line upwards: non-data lines below the last data row are a footer; a non-data
    line with another field count than the data, with data rows above it, is a damaged row; a
    non-data line with the data's field count (the names row) or a run of non-data lines ends
    the block.
    """
    data = [bool(ln.strip()) and _is_data(r) for ln, r in zip(lines, rows, strict=True)]
    window = slice(max(0, end - _TAIL_WINDOW), end)
    counts = [len(r) for r, d in zip(rows[window], data[window],
                                     strict=True) if d]
    width = max(set(counts), key=counts.count) if counts else 0
    skipped: set[int] = set()
    k = end - 1
    while k >= 0 and not data[k] and len(skipped) < 20 and any(data[:k]):  # footer
        if lines[k].strip():
            skipped.add(k)
        k -= 1
    data_start = k + 1
    while k >= 0:
        if not lines[k].strip():
            k -= 1
            continue
        if data[k]:
            data_start = k
            k -= 1
            continue
        above = next((j for j in range(k - 1, -1, -1) if lines[j].strip()), None)
        if len(rows[k]) == width or above is None or not data[above]:
            break  # the names row, or the lines above the data
        skipped.add(k)
        k -= 1
    if data_start == end:  # no data at all: report nothing as skipped
        return end, set()
    return data_start, {j for j in skipped if j >= data_start}


def _time_column(names: list[str], option: str | int | None,
                 where: Mapping[str, Any]) -> int | None:
    """Return the index of the time column (None: there is none)."""
    if option is None:
        return next((k for k, n in enumerate(names) if _TIME_NAMES.match(n.strip())), None)
    if isinstance(option, int):
        if not 0 <= option < len(names):
            raise ConfigError(f"time_column {option} out of range 0...{len(names) - 1}",
                              where={**where, "key": "time_column"})
        return option
    if option not in names:
        raise ChannelNotFoundError(f"time column {option!r} not found", where=where,
                                   available=names)
    return names.index(option)


def _rate_of(time: np.ndarray) -> float:
    """Return the sampling rate in Hz of a time column over its first gap-free block.

    Averaging over the block (not the median step) removes the rounding of time cells written
    with few decimals.
    """
    step = np.diff(time)
    if not step.size:
        return 1.0
    typical = float(np.median(step))
    jumps = np.flatnonzero(step > 1.5 * typical)
    end = int(jumps[0]) if jumps.size else step.size
    if end == 0 or time[end] <= time[0]:
        return 1.0 / typical if typical > 0 else float("nan")
    return end / float(time[end] - time[0])


def _drop_bad_times(table: pd.DataFrame, line_of: np.ndarray, t_index: int,
                    lost: dict[str, list[int]], parsed: int = 0) -> tuple[pd.DataFrame, np.ndarray]:
    """Drop rows whose time cell is not a finite number (when most cells are numbers).

    ``parsed`` rows outside the table (the fast path's middle) have finite numbers there.
    """
    cells = table[t_index].fillna("").str.strip()
    numeric = cells.str.match(_NUMBER.pattern, case=False) \
        & ~cells.str.contains("nan|inf", case=False, regex=True)
    if numeric.all() or numeric.sum() + parsed <= 0.5 * (len(cells) + parsed):
        return table, line_of  # all good, or absolute time stamps: parsed as such
    keep = numeric.to_numpy()
    lost["time cell not a number"] = [int(n) for n in line_of[~keep]]
    return table[keep].reset_index(drop=True), line_of[keep]


def _fast_path(file: Path, encoding: str | None, sniff: dict[str, Any]
               ) -> tuple[list[str], CsvLayout, np.ndarray, Middle, bool] | None:
    """Read the clean blocks of a file's middle in bounded memory (see ``csv_blocks``).

    Returns ``(lines read one by one, layout, their 0-based line numbers in the file, the
    middle, whether the file ends with a line end)``, or None when the per-line path must read
    the whole file: short text, a layout the whole file might not give (data starting late, an
    override beyond the head, a tail of blank lines), or bytes that do not decode. Every run of
    lines read one by one starts and ends with a clean data row, so each rule of
    :func:`sniff_csv` sees the neighbours it sees in the whole file: it looks at the last lines,
    the first data rows, the names row and the line above a non-data line, and a clean row is a
    data row of the data's width.
    """
    pieces = split_file(file, encoding)
    if pieces is None:
        return None
    head, tail = pieces.head, pieces.tail
    if any(sniff[key] is not None and sniff[key] >= len(head)
           for key in ("header_row", "units_row")):
        return None
    try:
        layout = sniff_csv(head + tail, **sniff)
    except DataFileError:
        return None  # the per-line path gives the error of the whole file
    width = len(layout.names)
    blank_end = next((j for j, ln in enumerate(reversed(tail)) if ln.strip()), len(tail))
    if layout.data_start + _SAMPLE_ROWS > len(head) or width < 2 \
            or len(tail) - blank_end < _TAIL_WINDOW:
        return None
    clean = [is_clean_row(ln, layout.delimiter, layout.decimal, width)
             for ln in (head[-1], tail[0], tail[1])]
    if not all(clean):
        return None
    middle = parse_middle(pieces, layout.delimiter, layout.decimal, width)
    if middle is None:
        return None
    lines, numbers = list(head), [np.arange(len(head))]
    for first, segment in middle.segments:
        lines += segment
        numbers.append(np.arange(first, first + len(segment)))
    n_tail = len(head) + middle.line.size + sum(len(seg) for _, seg in middle.segments)
    lines += tail
    numbers.append(np.arange(n_tail, n_tail + len(tail)))
    if middle.segments:  # lines of the middle read one by one: the layout of them all
        whole = sniff_csv(lines, **sniff)
        if (whole.delimiter, whole.decimal, whole.names, whole.data_start) != (
                layout.delimiter, layout.decimal, layout.names, layout.data_start):
            return None
        layout = whole
    return lines, layout, np.concatenate(numbers), middle, pieces.complete


def _read_columns(lines: list[str], numbers_of: list[int], real: np.ndarray, layout: CsvLayout,
                  middle: Middle, *, t_index: int | None, lost: dict[str, list[int]],
                  start: np.datetime64 | None, fs: float | None, time_units: str | None,
                  time_format: str | None, timezone: str | None, where: Mapping[str, Any],
                  notes: list[TimeFallback]
                  ) -> tuple[dict[int, np.ndarray], dict[int, int], np.ndarray,
                             np.datetime64 | None]:
    """Read the data rows as one channel per column (see :func:`read_csv`).

    Parameters
    ----------
    lines : list of str
        The lines read one by one.
    numbers_of : list of int
        Indices into ``lines`` of the data rows.
    real : numpy.ndarray of int
        0-based line number in the file of each entry of ``lines``.
    layout : CsvLayout
        The file's layout.
    middle : Middle
        The rows parsed in blocks by the fast path (taken over: emptied).
    t_index : int or None
        The time column.
    lost : dict
        Reason -> 1-based numbers of the lines not read; completed here, then warned about.
    start : numpy.datetime64 or None
        The start time given by the caller.
    fs, time_units, time_format, timezone : optional
        As for :func:`read_csv`.
    where : mapping
        The file, for messages.
    notes : list of TimeFallback
        Fallbacks taken, appended to.

    Returns
    -------
    values : dict of int to numpy.ndarray
        The samples of each column read, by column index.
    text_cells : dict of int to int
        Cells holding text, by column index.
    time : numpy.ndarray
        Sample times in s since the first sample.
    start : numpy.datetime64 or None
        The start time (None: not found yet).
    """
    width = len(layout.names)
    n_mid = middle.line.size
    line_of = real[np.array(numbers_of, dtype=np.int64)] + 1  # 1-based line number of each row
    body = "\n".join(lines[k] for k in numbers_of)
    fields = max((lines[k].count(layout.delimiter) + 1 for k in numbers_of), default=width)
    if len(numbers_of) < fields:  # few wide rows: pandas' parser costs per column
        table = split_rows([lines[k] for k in numbers_of], layout.delimiter,
                            max(fields, width))
    else:
        try:
            table = pd.read_csv(io.StringIO(body), sep=layout.delimiter, decimal=layout.decimal,
                                header=None, names=list(range(max(fields, width))),
                                index_col=False, dtype=str, keep_default_na=False,
                                quoting=csv.QUOTE_NONE, skip_blank_lines=False, engine="c")
        except (ValueError, pd.errors.ParserError, pd.errors.EmptyDataError) as error:
            raise DataFileError(f"cannot split the data rows: {error}", where=where,
                                hint="pass delimiter=... and header_row=...") from None
    if len(table) != line_of.size:
        raise DataFileError(f"{len(table)} table rows from {line_of.size} data lines",
                            where=where, hint="pass delimiter=... and header_row=...")
    extra = np.zeros(len(table), dtype=bool)
    for k in range(width, table.shape[1]):
        extra |= (table[k].fillna("").str.strip() != "").to_numpy()
    if extra.sum() > max(1, 0.1 * (len(table) + n_mid)):
        raise DataFileError(f"{int(extra.sum())} data rows hold more than the {width} fields "
                            "the header names", where=where,
                            hint="check delimiter=... and header_row=...")
    if extra.any():
        lost["more fields than the names row"] = [int(n) for n in line_of[extra]]
        table, line_of = table[~extra].reset_index(drop=True), line_of[~extra]
    if t_index is not None:
        table, line_of = _drop_bad_times(table, line_of, t_index, lost, n_mid)
    into = np.searchsorted(middle.line, line_of - 1)  # where table rows go among the middle's
    middle.line = middle.line[:0]  # its line numbers are done with: freed (memory)
    _warn_lost(lost, where)
    values: dict[int, np.ndarray] = {}
    text_cells: dict[int, int] = {}
    columns = [k for k in range(width) if k != t_index]
    all_cells, all_numbers, all_bad = convert_table(table, columns, layout.decimal)
    for j, k in enumerate(columns):
        cells, bad_mask = all_cells[:, j], all_bad[:, j]
        numbers = (_merged(middle.values[k], into, all_numbers[:, j]) if middle.values[k].size
                   else all_numbers[:, j].copy())  # no middle: nothing to insert into
        middle.values[k] = numbers[:0]  # taken over: freed
        bad = int(np.count_nonzero(bad_mask))
        if bad and bad == np.count_nonzero(cells != "") + n_mid:
            warn_data(f"column {layout.names[k]!r} holds no numbers ({bad} text cells such as "
                      f"{cells[bad_mask][0]!r}): not read", where=where,
                      hint=f"check decimal={layout.decimal!r} and delimiter", stacklevel=3)
            continue
        if bad:
            first = int(line_of[np.flatnonzero(bad_mask)[0]])
            warn_data(f"column {layout.names[k]!r}: {bad} cell(s) are not numbers (first on "
                      f"line {first}: {cells[bad_mask][0]!r}); read as NaN",
                      where={**where, "channel": layout.names[k]},
                      hint=f"check decimal={layout.decimal!r} and delimiter", stacklevel=3)
            text_cells[k] = bad
        if numbers.size and not np.isfinite(numbers).any():
            warn_data(f"column {layout.names[k]!r} holds no finite value ({numbers.size} NaN "
                      "or empty cells): kept as NaN", where={**where, "channel": layout.names[k]},
                      hint="check the channel's wiring or export settings", stacklevel=3)
        values[k] = numbers
    n = len(table) + n_mid
    if t_index is not None:
        cells = table[t_index].fillna("").str.strip()
        if cells.str.match(_NUMBER.pattern, case=False).all():
            seconds = pd.to_numeric(cells.str.replace(",", ".", regex=False)).to_numpy(float)
            seconds = _merged(middle.values[t_index], into, seconds)
            middle.values[t_index] = seconds[:0]  # taken over: freed
            unit = (time_units or layout.units[t_index] or "s").strip()
            scale = {"s": 1.0, "sec": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6}.get(unit)
            if scale is None:
                raise ConfigError(f"time column unit {unit!r} is not s, ms or us",
                                  where={**where, "key": "time_units"})
            if scale != 1.0:
                seconds *= scale  # in the column's own memory, as the values are (memory)
            first = float(seconds[0])
            time = seconds
            time -= first
            if start is None:
                start = header_start(layout.header, time_format, timezone, where, notes)
                if start is not None and first != 0.0:
                    start = start + np.timedelta64(round(first * 1e9), "ns")
        else:
            stamps = parse_datetimes(cells.tolist(), time_format, timezone, where, notes)
            start = stamps[0] if start is None else start
            time = (stamps - stamps[0]).astype(np.int64) / 1e9
    else:
        assert fs is not None  # checked before the cells were converted
        time = np.arange(n) / fs
        notes.append(TimeFallback("no time column", f"t = i / {fs} Hz"))
    return values, text_cells, time, start


def _merged(middle: np.ndarray, into: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Return a column: the rows parsed line by line inserted among the middle's (``np.insert``).

    With none to insert, the middle's own array (its owner lets it go), not its copy (memory).
    """
    return np.insert(middle, into, rows) if into.size else middle


def _warn_lost(lost: Mapping[str, list[int]], where: Mapping[str, Any]) -> None:
    """Warn once per reason about the lines not read (1-based line numbers)."""
    for reason, numbers in lost.items():
        if numbers:
            warn_data(f"{len(numbers)} line(s) not read: {reason} (lines "
                      f"{numbers[:10]}{' ...' if len(numbers) > 10 else ''})", where=where,
                      hint="the file was edited, damaged or cut short; the other rows are read",
                      stacklevel=4)


def read_csv(path: str | os.PathLike[str], *, delimiter: str | None = None,
             decimal: str | None = None, header_row: int | None = None,
             units_row: int | None = None, time_column: str | int | None = None,
             time_format: str | None = None, timezone: str | None = None,
             time_units: str | None = None, start_time: str | None = None,
             fs: float | None = None, channels: Sequence[str] | None = None,
             time_range: tuple[float | None, float | None] | None = None,
             device: str | None = None, modules: Mapping[str, str] | None = None,
             encoding: str | None = None, name: str | None = None,
             checksum: bool = True) -> dict[str, xr.Dataset]:
    """Read a delimited text file into one stream.

    Parameters
    ----------
    path : str or path-like
        The text file.
    delimiter, decimal : str, optional
        Field and decimal separators (default: detected).
    header_row, units_row : int, optional
        0-based line numbers of the column names and units (default: detected).
    time_column : str or int, optional
        Name or index of the time column (default: detected; None found -> ``fs`` needed).
    time_format : str, optional
        strftime format of absolute time cells (default: ISO 8601 or common local formats).
    timezone : str, optional
        IANA zone of local (naive) time cells and header times, e.g. ``"Europe/Berlin"``;
        default UTC.
    time_units : str, optional
        Unit of a relative time column (``"s"``, ``"ms"``); default from its header, else s.
    start_time : str, optional
        ISO 8601 start time overriding the file's (UTC unless it has an offset).
    fs : float, optional
        Sampling rate in Hz for files without a time column.
    channels : sequence of str, optional
        Columns to read (default: all but the time column).
    time_range : tuple of float or None, optional
        ``(t_from, t_to)`` in s since the first sample, inclusive.
    device : str, optional
        Device profile name.
    modules : mapping of str to str, optional
        Column name -> module, as in :func:`~rigval.acquisition.tdms.read_tdms`.
    encoding : str, optional
        Text encoding (default UTF-8, else cp1252).
    name : str, optional
        Stream name (default: the file name without suffix).
    checksum : bool
        Compute ``source_sha256``.

    Returns
    -------
    dict of str to xarray.Dataset
        ``{name: stream}``.

    Raises
    ------
    DataFileError
        No numeric block, unparsable times, no time column and no ``fs``.
    ChannelNotFoundError
        Unknown column names (the message lists the columns).
    DataError
        A time column that is not strictly increasing.
    """
    file = checked_path(path)
    where = {"file": str(file)}
    sniff = {"delimiter": delimiter, "decimal": decimal, "header_row": header_row,
             "units_row": units_row, "file": file}
    fast = _fast_path(file, encoding, sniff)
    if fast is None:
        text, complete = _decode(file, encoding, stacklevel=3)
        lines = text.splitlines()
        del text
        layout = sniff_csv(lines, **sniff)
        real = np.arange(len(lines))
        middle = Middle([np.empty(0)] * len(layout.names), np.empty(0, dtype=np.int64), [])
    else:
        lines, layout, real, middle, complete = fast
        del fast  # the middle's columns are let go as the columns take them over (memory)
    n_mid = middle.line.size  # clean rows parsed in blocks, not in lines
    notes: list[TimeFallback] = []
    t_index = _time_column(layout.names, time_column, where)
    width = len(layout.names)
    if t_index is None and fs is None:  # before any cell is converted
        rows = len(lines) - layout.data_start + n_mid
        raise DataFileError(
            "no time column found and no fs given", where=where,
            hint="pass time_column=... or fs=... (Hz)" + (
                f"; the data are one row of {width} values: with fs it is read as one channel "
                "(a names row above it makes it one sample of each named channel)"
                if rows == 1 else ""))
    row_case = t_index is None and layout.names_row is None and n_mid == 0  # see csv_row
    lost: dict[str, list[int]] = {"not a data row (text line, footer)":
                                  [int(real[k]) + 1 for k in layout.skipped]}
    numbers_of = [k for k in range(layout.data_start, len(lines))
                  if lines[k].strip() and k not in set(layout.skipped)]
    if numbers_of:
        last = numbers_of[-1]
        previous = len(_split(lines[numbers_of[-2]], layout.delimiter)) if len(numbers_of) > 1 \
            else width
        if not complete and last == len(lines) - 1 and not (row_case and len(numbers_of) == 1):
            lost["last line without its line end (file cut mid-line)"] = [int(real[last]) + 1]
            numbers_of.pop()
        elif len(_split(lines[last], layout.delimiter)) < min(previous, width):
            lost["last line with fewer fields than the line before it"] = [int(real[last]) + 1]
            numbers_of.pop()
    start = None if start_time is None else np.datetime64(
        pd.Timestamp(start_time).tz_localize(None) if pd.Timestamp(start_time).tzinfo is None
        else pd.Timestamp(start_time).tz_convert("UTC").tz_localize(None), "ns")
    row = None
    if row_case and len(numbers_of) == 1:
        assert fs is not None  # checked before the cells were converted
        _warn_lost(lost, where)
        k = numbers_of[0]
        row = read_row(lines[k], delimiter=layout.delimiter, decimal=layout.decimal,
                       cut=not complete and k == len(lines) - 1, line_number=int(real[k]) + 1,
                       fs=fs, where=where)
        layout = replace(layout, names=[row.name], units=[row.unit])
        values, text_cells = {0: row.values}, {0: row.text_cells}
        time = np.arange(row.values.size) / fs
        notes.append(TimeFallback("no time column", f"t = i / {fs} Hz (one row, one channel)"))
    else:
        values, text_cells, time, start = _read_columns(
            lines, numbers_of, real, layout, middle, t_index=t_index, lost=lost, start=start,
            fs=fs, time_units=time_units, time_format=time_format, timezone=timezone,
            where=where, notes=notes)
    del middle  # every value is in values and time now
    if start is None:
        start = header_start(layout.header, time_format, timezone, where, notes)
    if start is None:
        start = _EPOCH_1904
        notes.append(TimeFallback("no start time in the file", "start_time unknown (1904-01-01)"))
    if time.size < 1:
        raise DataFileError("the data block is empty", where=where)
    fs_nominal = fs if fs is not None else _rate_of(time)
    if not np.isfinite(fs_nominal) or fs_nominal <= 0:
        raise DataFileError("the time column does not increase", where=where,
                            hint="local times around a DST change need timezone=...")
    by_name = {layout.names[k]: k for k in values}
    chosen = list(by_name) if channels is None else list(channels)
    missing = [c for c in chosen if c not in by_name]
    if missing:
        raise ChannelNotFoundError(f"column {missing[0]!r} not in the file", where=where,
                                   available=list(by_name))
    lo, hi = 0, time.size
    if time_range is not None:
        t_from, t_to = time_range
        lo = int(np.searchsorted(time, -np.inf if t_from is None else t_from - 1e-12, "left"))
        hi = int(np.searchsorted(time, np.inf if t_to is None else t_to + 1e-12, "right"))
    profile = get_device(device) if device else None
    result: dict[str, Channel] = {}
    for column in chosen:
        k = by_name[column]
        unit_text = layout.units[k] or ""
        data = values[k][lo:hi]
        attrs: dict[str, Any] = {"units_in_file": unit_text,
                                 "empty_cells": int(np.count_nonzero(np.isnan(data))),
                                 "text_cells": text_cells.get(k, 0)}
        module = (modules or {}).get(column) or (profile.default_module if profile else None)
        if module is not None:
            attrs.update(module_attrs(module, fs_nominal, where={**where, "channel": column}))
        result[column] = Channel(data, udunits(unit_text), column, column, "none", attrs)
    for note in notes:
        logger.info("%s: %s", file, note.text())
    attrs = {"source_format": "csv", "delimiter": layout.delimiter, "decimal": layout.decimal,
             **string_table_attrs("text_header", layout.header), **time_fallback_attrs(notes),
             "first_sample": lo, "samples_in_file": int(time.size)}
    if profile is not None:
        attrs.update(profile.stream_attrs())
    stream = stream_dataset(
        time[lo:hi], result, device=profile.name if profile else "unknown",
        start_time=start, source_file=file, source_sha256=source_checksum(file, checksum),
        fs_nominal=float(fs_nominal), attrs=attrs,
        valid=row.reason[lo:hi] == 0 if row is not None and row.reason[lo:hi].any() else None,
        invalid_counts=None if row is None else row.invalid_counts(lo, hi))
    return {name or file.stem: stream}
