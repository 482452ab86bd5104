"""A waveform written as one row of a text file, read as one channel in one vectorised pass.

LabVIEW's "Write Delimited Spreadsheet" writes a 1-D array as one row unless its ``transpose?``
input is set, and a waveform copied from a spreadsheet often lies across a row. A data block of
one row with no names row above it is therefore one channel of as many samples as the row has
cells (``t = i / fs``), not as many channels of one sample each: a rig channel of one sample
cannot be compared with anything. A first cell that is text and not a number is the row's name
(``Torque [N m]``, unit in brackets as in a names row); otherwise the channel is named
``row 0``. The reader says what it did in a :class:`~rigval.acquisition.errors.DataWarning`.

Nothing is left out: every cell is a sample. A cell that is empty or holds text is NaN and
invalid (``valid`` False) with its reason; the last cell of a row whose line was cut mid-line
keeps the value it parses to but is invalid, since its digits may be incomplete. With a names
row above, the row is one sample of each named channel and the column reader reads it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from rigval.acquisition.csv_cells import NUMBER, convert_cells
from rigval.acquisition.units import split_name_and_unit
from rigval.acquisition.warn import warn_data

__all__ = ["ROW_NAME", "ROW_REASONS", "RowWaveform", "read_row"]

#: The channel's name when the row's first cell is a number.
ROW_NAME = "row 0"
#: Why a sample of the row is invalid, by code (code 0: valid).
ROW_REASONS = ("empty cell in the row", "text cell in the row (not a number)",
               "last cell of a line cut mid-line (its digits may be incomplete)")


@dataclass(frozen=True)
class RowWaveform:
    """One row of a text file read as one channel.

    Attributes
    ----------
    name : str
        The channel's name: the row's first cell when that is text, else :data:`ROW_NAME`.
    unit : str or None
        The unit written in brackets after that name, as written.
    values : numpy.ndarray of float
        One sample per cell after the name (NaN where a cell is empty or text).
    reason : numpy.ndarray of int8
        Per sample, 0 when valid, else 1 + the index of its reason in :data:`ROW_REASONS`.
    text_cells, empty_cells : int
        Cells holding text that is not a number, and cells read as NaN (empty, text or ``nan``).
    """

    name: str
    unit: str | None
    values: np.ndarray
    reason: np.ndarray
    text_cells: int
    empty_cells: int

    def invalid_counts(self, lo: int = 0, hi: int | None = None) -> dict[str, int]:
        """Return the invalid samples of ``values[lo:hi]`` counted by reason."""
        counts = np.bincount(self.reason[lo:hi], minlength=len(ROW_REASONS) + 1)[1:]
        return {r: int(c) for r, c in zip(ROW_REASONS, counts, strict=True) if c}


def read_row(line: str, *, delimiter: str, decimal: str, cut: bool, line_number: int,
             fs: float, where: Mapping[str, Any]) -> RowWaveform:
    """Read one data row as one channel and warn that it did.

    Parameters
    ----------
    line : str
        The row's text, without its line end.
    delimiter, decimal : str
        Field and decimal separators.
    cut : bool
        True when the line is the file's last and has no line end (the file was cut there).
    line_number : int
        1-based line number of the row in the file (for the messages).
    fs : float
        Sampling rate in Hz given by the caller (for the message).
    where : mapping
        Where the row is (the file), for the messages.

    Returns
    -------
    RowWaveform
        The channel's samples and the reason of each invalid one.
    """
    cells = line.split(delimiter)
    if len(cells) > 1 and not cells[-1].strip():
        cells.pop()  # a trailing delimiter, as in the column reader
    first = cells[0].strip()
    name, unit = ROW_NAME, None
    if first and not NUMBER.match(first) and len(cells) > 1:
        name, unit = split_name_and_unit(first)
        name = name or ROW_NAME
        cells = cells[1:]
    stripped, values, bad = convert_cells(cells, decimal)
    reason = np.zeros(values.size, dtype=np.int8)
    reason[stripped == ""] = 1
    reason[bad] = 2
    if cut:
        reason[-1] = 3  # its value, if it parses, kept and flagged
    row = RowWaveform(name, unit, values, reason, int(np.count_nonzero(bad)),
                      int(np.count_nonzero(np.isnan(values))))
    invalid = row.invalid_counts()
    told = "; ".join(f"{count} {text}" for text, count in invalid.items())
    warn_data(f"line {line_number} is one row of {values.size} values without a names row: "
              f"read as one channel {name!r} of {values.size} samples at {fs:g} Hz "
              f"(t = i / fs), not as {values.size} channels of one sample"
              + (f"; invalid samples: {told}" if told else ""),
              where=where, hint="if the row is one sample of many channels, add a names row "
              "above it: each column is then a channel", stacklevel=3)
    return row
