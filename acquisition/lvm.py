"""Read LabVIEW Measurement files (``.lvm``), tag-driven as NI's specification advises.

NI "Specification for the LabVIEW Measurement File (.lvm)" (tutorial 4139): a file header of
tag/value rows up to ``***End_of_Header***`` (``Separator``, ``Decimal_Separator``,
``X_Columns`` = No | One | Multi, ``Time_Pref``, ``Date``, ``Time``, ...), then segments, each with
an optional header (``Channels``, ``Samples``, ``Date``, ``Time``, ``Y_Unit_Label``, ``X0``,
``Delta_X``, one value per data column), a ``X_Value ... Comment`` names row and data rows.

What this reader handles (real files in the public lvm_read project's test files): several
segments; decimal comma everywhere including ``X0``/``Delta_X``/``Time``; no
``Decimal_Separator`` tag (writer 0.92: the separator is taken from the data, never from the
header times); ``X_Columns`` No/One/Multi;
unequal ``Samples`` and empty cells (a channel's trailing empty cells are not samples, inner empty
cells are NaN counted in ``empty_cells``); comment columns; ``***Start_Special***`` blocks; and
files without any header (first line ``X_Value``).

Time axis: for ``X_Columns = No`` it is ``X0 + i * Delta_X`` with a ``Delta_X`` rounded to 6
decimals replaced by the exact interval it stands for; otherwise the written X values are used.
Segments of the same channels join one stream; the time between them comes from their header
``Date``/``Time`` (local time of the writing PC: pass ``timezone``), a jump being a gap. Channels
with different ``Delta_X`` or sample counts form separate streams.
"""

from __future__ import annotations

import logging
import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from rigval.acquisition.detect import checked_path, source_checksum
from rigval.acquisition.devices import get_device, module_attrs
from rigval.acquisition.errors import ChannelNotFoundError, ConfigError, DataFileError
from rigval.acquisition.schema import Channel, stream_dataset, string_table_attrs
from rigval.acquisition.text_csv import read_text
from rigval.acquisition.time_fallbacks import LOCAL_TIME_AS_UTC, TimeFallback, time_fallback_attrs
from rigval.acquisition.timebase import exact_increment
from rigval.acquisition.units import udunits
from rigval.acquisition.warn import warn_data

__all__ = ["LvmFile", "LvmSegment", "parse_lvm", "read_lvm"]

logger = logging.getLogger(__name__)

END_OF_HEADER = "***End_of_Header***"
_EPOCH_1904 = np.datetime64("1904-01-01T00:00:00", "ns")
_SEPARATORS = {"tab": "\t", "comma": ",", "semicolon": ";", "space": " "}
_COMMA_NUMBER = re.compile(r"^\s*[-+]?\d*,\d+([eE][-+]?\d+)?\s*$")
#: Tags that start a segment header (NI tutorial 4139, "Segment Header"); any other text in the
#: first cell of a data row is a damaged X cell, not a new segment.
_SEGMENT_TAGS = frozenset({"Channels", "Samples", "Date", "Time", "Y_Unit_Label", "X_Dimension",
                           "X0", "Delta_X", "Notes", "Test_Name", "Test_Numbers", "Test_Series",
                           "UUT_Name", "UUT_M/N", "UUT_S/N", "Operator", "Description"})
#: An ``X0`` beyond this (s, about 115 days) is taken as damage, not as an offset (as for TDMS).
_MAX_X0_S = 1e7


@dataclass
class LvmSegment:
    """One segment of an LVM file.

    Attributes
    ----------
    header : dict
        Tag -> list of cells (aligned with the data columns).
    names : list of str
        The ``X_Value ...`` row.
    rows : list of list of str
        Data rows split at the separator.
    line : int
        1-based line number of the names row (for messages).
    row_lines : list of int
        1-based line number of each data row.
    """

    header: dict[str, list[str]] = field(default_factory=dict)
    names: list[str] = field(default_factory=list)
    rows: list[list[str]] = field(default_factory=list)
    line: int = 0
    row_lines: list[int] = field(default_factory=list)


@dataclass
class LvmFile:
    """A parsed LVM file (cells still text).

    Attributes
    ----------
    tags : dict
        File-header tag -> value.
    separator : str
        Column separator.
    segments : list of LvmSegment
        The segments in file order.
    """

    tags: dict[str, str]
    separator: str
    segments: list[LvmSegment]


def _separator(lines: list[str]) -> str:
    """Return the column separator named by the ``Separator`` tag (default tab)."""
    for line in lines[:40]:
        if line.startswith("Separator") and len(line) > len("Separator"):
            sep = line[len("Separator")]
            value = line[len("Separator") + 1:].strip().lower()
            return _SEPARATORS.get(value, value[:1] or sep)
        if line.startswith(END_OF_HEADER):
            break
    return "\t"


def parse_lvm(lines: list[str], file: Path | None = None) -> LvmFile:
    """Split an LVM file into its file-header tags and segments (cells still as text).

    Parameters
    ----------
    lines : list of str
        The file's lines.
    file : pathlib.Path, optional
        For error messages.

    Returns
    -------
    LvmFile
        Tags and segments.

    Raises
    ------
    DataFileError
        If the file holds no ``X_Value`` names row.
    """
    sep = _separator(lines)
    tags: dict[str, str] = {}
    k = 0
    if lines and lines[0].startswith("LabVIEW Measurement"):
        k = 1
        while k < len(lines) and not lines[k].startswith(END_OF_HEADER):
            cells = lines[k].split(sep)
            if cells[0].strip():
                tags[cells[0].strip()] = cells[1].strip() if len(cells) > 1 else ""
            k += 1
        k += 1
    segments: list[LvmSegment] = []
    segment = LvmSegment()
    in_special = False
    while k < len(lines):
        line = lines[k]
        k += 1
        cells = [c.rstrip("\r") for c in line.split(sep)]
        first = cells[0].strip()
        if first == "***Start_Special***":
            in_special = True
        if in_special:
            in_special = first != "***End_Special***"
            continue
        if not line.strip() or first == END_OF_HEADER:
            continue
        if first == "X_Value":
            if segment.names:
                segments.append(segment)
                segment = LvmSegment()
            segment.names, segment.line = cells, k
            continue
        if not segment.names:
            segment.header[first] = cells[1:] if first in ("Notes", "Test_Name") else cells
            continue
        if first in _SEGMENT_TAGS:
            segments.append(segment)  # a new segment header starts
            segment = LvmSegment(header={first: cells})
            continue
        segment.rows.append(cells)  # a text X cell stays a data row: see _x_values
        segment.row_lines.append(k)
    if segment.names:
        segments.append(segment)
    if not segments:
        raise DataFileError("LVM file holds no 'X_Value' names row and no data",
                            where={"file": str(file) if file else None},
                            hint="the file may hold only a header")
    return LvmFile(tags, sep, segments)


def _looks_numeric(cell: str) -> bool:
    """Return True for a number written with a dot or a comma."""
    try:
        float(cell.replace(",", "."))
    except ValueError:
        return False
    return True


def _number(cell: str, decimal: str, file: Path, tag: str) -> float:
    """Parse one header number with the file's decimal separator."""
    try:
        return float(cell.strip().replace(decimal, ".") if decimal != "." else cell.strip())
    except ValueError:
        raise DataFileError(f"segment header {tag} holds {cell!r}, not a number",
                            where={"file": str(file), "key": tag},
                            hint="pass decimal=... if the decimal separator was guessed wrong"
                            ) from None


def _clock(date: str, time: str) -> str:
    """Join an LVM ``Date`` (YYYY/MM/DD) and ``Time`` (HH:MM:SS,fff...) into ISO text (ns)."""
    hms, _, fraction = time.strip().replace(",", ".").partition(".")
    return f"{date.strip().replace('/', '-')}T{hms}" + (f".{fraction[:9]}" if fraction else "")


def _to_utc(text: str, timezone: str | None, file: Path) -> np.datetime64:
    """Return a local LVM time stamp as naive UTC datetime64[ns]."""
    try:
        stamp = pd.Timestamp(text)
    except ValueError:
        raise DataFileError(f"cannot read the header Date/Time {text!r}",
                            where={"file": str(file)},
                            hint="Date must be YYYY/MM/DD and Time HH:MM:SS.fff") from None
    if timezone:
        try:
            stamp = stamp.tz_localize(timezone).tz_convert("UTC").tz_localize(None)
        except Exception as error:
            raise ConfigError(f"cannot apply time zone {timezone!r}: {error}",
                              where={"key": "timezone"},
                              hint="use an IANA name like 'Europe/Berlin'") from None
    return stamp.to_datetime64().astype("datetime64[ns]")


@dataclass
class _Column:
    """One channel column of one segment."""

    name: str
    unit: str
    values: np.ndarray
    x: np.ndarray | None
    x0: float
    dt: float | None
    start: np.datetime64 | None
    segment: int
    expected: int | None
    text_cells: int = 0


def _columns(lvm: LvmFile, decimal: str, timezone: str | None, file: Path) -> list[_Column]:
    """Extract every channel column of every segment with its time description."""
    x_mode = lvm.tags.get("X_Columns", "One").strip().lower()
    out: list[_Column] = []
    for s_index, seg in enumerate(lvm.segments):
        names = [n.strip() for n in seg.names]
        width = len(names)
        grid = np.full((len(seg.rows), width), "", dtype=object)
        for r, row in enumerate(seg.rows):
            if any(c.strip() for c in row[width:]):
                raise DataFileError(f"a data row holds {len(row)} cells, the names row {width}",
                                    where={"file": str(file), "segment": s_index, "row": r},
                                    hint="the file may be damaged or its Separator wrong")
            cells = row[:width]
            grid[r, :len(cells)] = [c.strip() for c in cells]
        comment = width - 1 if names and names[-1].lower() == "comment" else None
        if x_mode == "multi":
            pairs = [(j - 1, j) for j in range(1, width, 2) if j != comment]
        else:
            pairs = [(0 if x_mode == "one" else None, j) for j in range(1, width) if j != comment]
        for x_col, j in pairs:
            column = grid[:, j]
            filled = np.flatnonzero(column != "")
            count = int(filled.max()) + 1 if filled.size else 0
            if count == 0:
                logger.info("%s: channel %r of segment %d holds no samples", file, names[j],
                            s_index)
                continue
            cells = column[:count]
            values, text_cells = _numbers(cells, decimal, file, names[j], seg.row_lines[:count])
            x = None
            if x_col is not None:
                x = _x_values(grid[:count, x_col], decimal, file, names[j],
                              seg.row_lines[:count])
            date = _header_cell(seg.header, "Date", j) or lvm.tags.get("Date")
            clock = _header_cell(seg.header, "Time", j) or lvm.tags.get("Time")
            start = _to_utc(_clock(date, clock), timezone, file) if date and clock else None
            x0_text = _header_cell(seg.header, "X0", j)
            dt_text = _header_cell(seg.header, "Delta_X", j)
            out.append(_Column(
                name=names[j] or f"column {j}", unit=_header_cell(seg.header, "Y_Unit_Label", j)
                or "", values=values, x=x,
                x0=_number(x0_text, decimal, file, "X0") if x0_text else 0.0,
                dt=_number(dt_text, decimal, file, "Delta_X") if dt_text else None, start=start,
                segment=s_index, expected=_header_int(seg.header, "Samples", j),
                text_cells=text_cells))
    return out


def _x_values(cells: np.ndarray, decimal: str, file: Path, name: str,
              lines: list[int]) -> np.ndarray:
    """Convert X cells to float64; a cell that is not a number becomes NaN, with a warning.

    A NaN X value makes the segment's time come from ``X0 + i * Delta_X`` (see
    :func:`_segment_times`), so no sample is lost to one damaged X cell.
    """
    text = pd.Series(cells, dtype=object).astype(str)
    if decimal != ".":
        text = text.str.replace(decimal, ".", regex=False)
    numbers = pd.to_numeric(text.replace("", np.nan), errors="coerce").to_numpy(float)
    bad = np.flatnonzero(np.isnan(numbers) & (text != "").to_numpy()
                         & ~text.str.fullmatch(r"\s*[-+]?nan\s*", case=False).to_numpy())
    if bad.size:
        warn_data(f"{bad.size} X cell(s) of channel {name!r} are not numbers (first "
                  f"{cells[bad[0]]!r} on line {lines[bad[0]]}): its time comes from X0 and "
                  "Delta_X", where={"file": str(file), "channel": name},
                  hint="the file was edited or damaged there", stacklevel=5)
    return numbers


def _header_cell(header: Mapping[str, list[str]], tag: str, column: int) -> str | None:
    """Return a segment-header value for a data column (None if absent or empty)."""
    cells = header.get(tag)
    if cells is None or column >= len(cells) or not cells[column].strip():
        return None
    return cells[column].strip()


def _header_int(header: Mapping[str, list[str]], tag: str, column: int) -> int | None:
    """Return an integer segment-header value for a data column (None if absent or not int)."""
    cell = _header_cell(header, tag, column)
    return int(cell) if cell is not None and cell.isascii() and cell.isdigit() else None


def _numbers(cells: np.ndarray, decimal: str, file: Path, name: str,
             lines: list[int]) -> tuple[np.ndarray, int]:
    """Convert cells to float64 and count the text cells among them.

    Empty and ``NaN`` cells are NaN. A few cells that are not numbers become NaN with a
    DataWarning naming the first one's line; a column without any number is a DataFileError
    (most likely a wrong decimal separator).
    """
    text = pd.Series(cells, dtype=object).astype(str)
    if decimal != ".":
        text = text.str.replace(decimal, ".", regex=False)
    numbers = pd.to_numeric(text.replace("", np.nan), errors="coerce").to_numpy(float)
    bad = np.isnan(numbers) & (text != "").to_numpy() \
        & ~text.str.fullmatch(r"\s*[-+]?nan\s*", case=False).to_numpy()
    if not bad.any():
        return numbers, 0
    first = int(np.flatnonzero(bad)[0])
    where = {"file": str(file), "channel": name, "line": lines[first]}
    if 1 < bad.sum() == np.count_nonzero((text != "").to_numpy()):
        raise DataFileError(f"no cell of column {name!r} is a number (first {cells[first]!r})",
                            where=where,
                            hint="pass decimal=... if the decimal separator was guessed wrong")
    warn_data(f"column {name!r}: {int(bad.sum())} cell(s) are not numbers (first "
              f"{cells[first]!r}); read as NaN", where=where,
              hint="the file was edited or damaged there; check decimal=...", stacklevel=5)
    return numbers, int(bad.sum())


def _drop_incomplete_last_row(lvm: LvmFile, complete: bool, n_lines: int, file: Path) -> None:
    """Drop the file's last data row if it is cut (no line end, or fewer cells), with a warning."""
    seg = lvm.segments[-1]
    if not seg.rows or seg.row_lines[-1] != n_lines:
        return
    filled = [len([c for c in row if c.strip()]) for row in seg.rows[-2:]]
    if complete and (len(filled) < 2 or filled[-1] >= filled[0]):
        return
    reason = ("has no line end (file cut mid-line)" if not complete
              else "has fewer cells than the row before it")
    warn_data(f"the last line ({seg.row_lines[-1]}) {reason}: its {filled[-1]} value(s) not "
              "read", where={"file": str(file)},
              hint="the file was cut short; the rows before it are read", stacklevel=3)
    seg.rows.pop()
    seg.row_lines.pop()


def _guess_decimal(lvm: LvmFile) -> str:
    """Return the decimal separator: the tag, else from the data cells (never header times)."""
    tag = lvm.tags.get("Decimal_Separator")
    if tag:
        return tag.strip() or "."
    if lvm.separator == ",":
        return "."
    for seg in lvm.segments:
        for row in seg.rows[:200]:
            if any(_COMMA_NUMBER.match(c) for c in row):
                return ","
    return "."


def _stream_key(col: _Column) -> tuple[Any, ...]:
    """Columns that share a time base: same name set position, interval and length."""
    return (col.dt, col.values.size, col.x0)


def read_lvm(path: str | os.PathLike[str], *, channels: Sequence[str] | None = None,
             time_range: tuple[float | None, float | None] | None = None,
             device: str | None = None, modules: Mapping[str, str] | None = None,
             decimal: str | None = None, timezone: str | None = None,
             fs: float | None = None, encoding: str | None = None,
             checksum: bool = True) -> dict[str, xr.Dataset]:
    """Read an LVM file into streams (one per time base).

    Parameters
    ----------
    path : str or path-like
        The ``.lvm`` file.
    channels : sequence of str, optional
        Channel names (default: every channel with samples).
    time_range : tuple of float or None, optional
        ``(t_from, t_to)`` in s since each stream's first sample, inclusive.
    device : str, optional
        Device profile name.
    modules : mapping of str to str, optional
        Channel name -> module (``"NI 9237"``).
    decimal : str, optional
        Decimal separator (default: the ``Decimal_Separator`` tag, else from the data).
    timezone : str, optional
        IANA time zone of the header ``Date``/``Time`` (LabVIEW writes local time); default UTC.
    fs : float, optional
        Rate in Hz for header-less files without X values.
    encoding : str, optional
        Text encoding.
    checksum : bool
        Compute ``source_sha256``.

    Returns
    -------
    dict of str to xarray.Dataset
        Stream name -> stream: the file name without suffix, with ``#k`` for further time bases.

    Raises
    ------
    DataFileError
        No names row, non-numeric cells, no way to build a time axis.
    ChannelNotFoundError
        Unknown channel names (the message lists the available ones).
    """
    file = checked_path(path)
    lines, complete = read_text(file, encoding)
    lvm = parse_lvm(lines, file)
    _drop_incomplete_last_row(lvm, complete, len(lines), file)
    decimal = decimal or _guess_decimal(lvm)
    columns = _columns(lvm, decimal, timezone, file)
    if not columns:
        raise DataFileError(
            f"LVM file has {len(lvm.segments)} names row(s) but no data rows with values",
            where={"file": str(file), "line": lvm.segments[0].line},
            hint="the file holds only headers (an aborted or empty acquisition)")
    empty = [s.line for s in lvm.segments if not s.rows]
    if empty:
        warn_data(f"{len(empty)} segment(s) have a names row but no data rows (names rows on "
                  f"lines {empty})", where={"file": str(file)},
                  hint="the acquisition wrote headers without data there", stacklevel=2)
    available = sorted({c.name for c in columns})
    if channels is not None:
        missing = [c for c in channels if c not in available]
        if missing:
            raise ChannelNotFoundError(f"channel {missing[0]!r} not in the file",
                                       where={"file": str(file)}, available=available)
        columns = [c for c in columns if c.name in channels]
    groups: dict[tuple[Any, ...], list[_Column]] = {}
    for col in columns:
        groups.setdefault((col.segment, *_stream_key(col)), []).append(col)
    # join segments holding the same channels with the same interval into one stream
    streams: dict[tuple[Any, ...], list[list[_Column]]] = {}
    for (_, *key), cols in groups.items():
        signature = (tuple(c.name for c in cols), key[0])
        streams.setdefault(signature, []).append(cols)
    sha = source_checksum(file, checksum)
    profile = get_device(device) if device else None
    result: dict[str, xr.Dataset] = {}
    for k, parts in enumerate(streams.values()):
        name = file.stem if k == 0 else f"{file.stem}#{k}"
        result[name] = _stream(parts, lvm, file, fs, time_range, profile, modules, sha, timezone)
    return result


def _segment_times(col: _Column, fs: float | None, notes: list[TimeFallback],
                   file: Path) -> np.ndarray:
    """Return the time axis of one column in s since its segment's X0."""
    n = col.values.size
    where = {"file": str(file), "channel": col.name, "segment": col.segment}
    x0 = col.x0
    if not np.isfinite(x0) or abs(x0) > _MAX_X0_S:
        warn_data(f"X0 = {x0!r} s is not a usable start offset: taken as 0 s", where=where,
                  hint="the segment header was edited or damaged", stacklevel=5)
        x0 = 0.0
    dt = col.dt if col.dt is not None and np.isfinite(col.dt) and col.dt > 0 else None
    dt_ok = dt is not None
    problem = None
    if col.x is not None and not np.isnan(col.x).any():
        if _increasing(col.x):
            return col.x
        problem = "its X values do not increase (e.g. a constant X column)"
        fallback = f"Delta_X = {col.dt!r} s" if dt_ok else f"the fs option ({fs} Hz)"
        if dt_ok or fs is not None:
            warn_data(f"channel {col.name!r}: {problem}: time from {fallback} instead",
                      where=where, hint="check the X column", stacklevel=5)
    if dt is not None:
        exact = exact_increment(dt, decimals=6)
        if exact is not None:
            notes.append(TimeFallback(f"Delta_X {dt!r} rounded to 6 decimals",
                                      f"using {exact!r} s"))
            dt = exact
        time = x0 + np.arange(n) * dt
        if _increasing(time):
            return time
        problem = f"X0 + i * Delta_X (X0 = {x0!r}, Delta_X = {dt!r}) does not increase"
    if fs is not None and fs > 0 and np.isfinite(fs):
        notes.append(TimeFallback("no usable X values or Delta_X", f"t = i / {fs} Hz"))
        return np.arange(n) / fs
    if problem is None and col.dt is not None:
        problem = f"Delta_X = {col.dt!r} is not a positive interval"
    raise DataFileError(
        f"the time axis of channel {col.name!r} is not increasing: "
        f"{problem or 'it has neither X values nor Delta_X'}", where=where,
        hint="pass fs=... (Hz) to read the samples at a known rate")


def _increasing(time: np.ndarray) -> bool:
    """Return True for finite, strictly increasing times (a single sample counts)."""
    return bool(np.isfinite(time).all() and (time.size < 2 or np.all(np.diff(time) > 0)))


def _stream(parts: list[list[_Column]], lvm: LvmFile, file: Path, fs: float | None,
            time_range: tuple[float | None, float | None] | None, profile: Any,
            modules: Mapping[str, str] | None, sha: str, timezone: str | None) -> xr.Dataset:
    """Build one stream from the same channels in one or more segments."""
    notes: list[TimeFallback] = []
    if timezone is None:
        notes.append(TimeFallback("LVM Date/Time are the writing PC's local time",
                                  LOCAL_TIME_AS_UTC))
    times: list[np.ndarray] = []
    first = parts[0][0]
    start = first.start if first.start is not None else _EPOCH_1904
    if first.start is None:
        notes.append(TimeFallback("no Date/Time in the header",
                                  "start_time unknown (1904-01-01)"))
    end = -np.inf
    for k, cols in enumerate(parts):
        t = _segment_times(cols[0], fs, notes, file)
        if k and cols[0].start is not None and first.start is not None:
            t = t + (cols[0].start - first.start) / np.timedelta64(1, "s")
        elif k:
            t = t - t[0] + end + (t[1] - t[0] if t.size > 1 else 1.0 / (fs or 1.0))
        if t.size and t[0] <= end:
            warn_data(
                f"segment {cols[0].segment} starts {end - t[0]:.6g} s before the previous one "
                "ends; placed right after it", where={"file": str(file)},
                hint="check the segment header times (time zone, DST)", stacklevel=4)
            step = t[1] - t[0] if t.size > 1 else 0.0
            t = t - t[0] + end + step
        end = float(t[-1]) if t.size else end
        short = {c.name: (c.values.size, c.expected) for c in cols
                 if c.expected is not None and c.values.size < c.expected}
        if short:
            warn_data(
                f"segment {cols[0].segment}: fewer rows than its header's Samples "
                f"(recovered, expected): {short}", where={"file": str(file)},
                hint="the rows present are read; if the file was copied while LabVIEW was "
                     "still writing it, copy it again after the acquisition has stopped, else "
                     "read the original file (this copy lost rows)", stacklevel=4)
        times.append(t)
    time = np.concatenate(times)
    t0 = time[0]
    time = time - t0
    start = start + np.timedelta64(round(t0 * 1e9), "ns")
    lo, hi = 0, time.size
    if time_range is not None:
        lo = int(np.searchsorted(time, -np.inf if time_range[0] is None
                                 else time_range[0] - 1e-12, "left"))
        hi = int(np.searchsorted(time, np.inf if time_range[1] is None
                                 else time_range[1] + 1e-12, "right"))
    dt_first = np.diff(times[0])
    fs_nominal = fs or (1.0 / float(np.mean(dt_first)) if dt_first.size else 1.0)
    if not (np.isfinite(fs_nominal) and fs_nominal > 0):  # a span too short for float64
        raise DataFileError(f"the time axis gives no usable rate ({fs_nominal!r} Hz)",
                            where={"file": str(file)}, hint="pass fs=... (Hz)")
    channels: dict[str, Channel] = {}
    for j, col in enumerate(parts[0]):
        data = np.concatenate([cols[j].values for cols in parts])[lo:hi]
        attrs: dict[str, Any] = {"units_in_file": col.unit,
                                 "empty_cells": int(np.count_nonzero(np.isnan(data))),
                                 "text_cells": sum(cols[j].text_cells for cols in parts)}
        module = (modules or {}).get(col.name) or (profile.default_module if profile else None)
        if module is not None:
            attrs.update(module_attrs(module, fs_nominal,
                                      where={"file": str(file), "channel": col.name}))
        name = col.name if col.name not in channels else f"{col.name} ({j})"
        channels[name] = Channel(data, udunits(col.unit), col.name, col.name, "none", attrs)
    for note in notes:
        logger.info("%s: %s", file, note.text())
    attrs = {"source_format": "lvm", **string_table_attrs("lvm_header", lvm.tags),
             **time_fallback_attrs(notes), "first_sample": lo,
             "samples_in_file": int(time.size), "lvm_segments": len(parts)}
    if profile is not None:
        attrs.update(profile.stream_attrs())
    return stream_dataset(time[lo:hi], channels, device=profile.name if profile else "unknown",
                          start_time=start, source_file=file, source_sha256=sha,
                          fs_nominal=float(fs_nominal), attrs=attrs)
