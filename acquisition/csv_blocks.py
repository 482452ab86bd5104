"""The fast path of the text reader: the middle of a clean data block parsed in pieces.

:func:`rigval.acquisition.text_csv.read_csv` sniffs the layout on the first :data:`HEAD_LINES`
and the last :data:`TAIL_LINES` lines of a file only. The lines between them (the middle) are
parsed here, :data:`BLOCK_CHARS` characters at a time, by pandas' C parser into one
preallocated float array, so that memory is the file's text, the output and one block instead
of a Python string and a list of fields per row. A piece is taken only when every line of it is
a clean data row: exactly the data's number of fields (one trailing delimiter allowed), every
cell a plain number in the file's decimal separator (digits, sign, exponent; no spaces, no
``nan``/``inf``, no empty cell). Such a row is a data row to the per-line rules of the reader,
so sniffing the head and tail gives the layout the whole file would give. When any piece holds
another line (text, an empty cell, a ragged row), :func:`parse_middle` returns None and the
reader takes its per-line path for the whole file, with its exact results, warnings and counts.
"""

from __future__ import annotations

import io
import logging
import re
from dataclasses import dataclass

import numpy as np
import pandas as pd

__all__ = ["BLOCK_CHARS", "HEAD_LINES", "TAIL_LINES", "Pieces", "is_clean_row", "parse_middle",
           "split_text"]

logger = logging.getLogger(__name__)

#: Characters of the middle parsed per piece (about 80,000 rows of a rig CSV).
BLOCK_CHARS = 1 << 22
#: Lines at the start of a file sniffed per line (names, units, header block, first rows).
HEAD_LINES = 1000
#: Lines at the end of a file sniffed per line (delimiter guess, footer, a cut last line).
TAIL_LINES = 500

_LINE_ENDS = re.compile("[\r\v\f\x1c\x1d\x1e\x85\u2028\u2029]")  # str.splitlines' others


@dataclass(frozen=True)
class Pieces:
    r"""A text cut at line ends into head lines, a middle span and tail lines.

    Attributes
    ----------
    text : str
        The whole text (line ends ``\n``).
    head, tail : list of str
        The first and last lines, without line ends.
    start, stop : int
        Character span of the middle in ``text`` (whole lines, each ending in ``\n``).
    rows : int
        Number of middle lines.
    """

    text: str
    head: list[str]
    start: int
    stop: int
    rows: int
    tail: list[str]


def split_text(text: str) -> Pieces | None:
    r"""Cut a text into :data:`HEAD_LINES` head lines, the middle and :data:`TAIL_LINES` lines.

    Returns None when the text is too short to have a middle, or uses line ends other than
    ``\n`` and ``\r\n`` (the per-line path handles those). ``head + middle lines + tail``
    equals ``text.splitlines()``.
    """
    if "\r" in text:
        if text.count("\r") != text.count("\r\n"):
            return None
        text = text.replace("\r\n", "\n")
    if _LINE_ENDS.search(text):
        return None
    start = 0
    for _ in range(HEAD_LINES):
        start = text.find("\n", start) + 1
        if start == 0:
            return None
    stop = len(text) - 1 if text.endswith("\n") else len(text)  # the last line's end
    for _ in range(TAIL_LINES):
        stop = text.rfind("\n", 0, stop)
        if stop < start:
            return None
    stop += 1
    if stop <= start:
        return None
    rows = text.count("\n", start, stop)
    return Pieces(text, text[:start].splitlines(), start, stop, rows, text[stop:].splitlines())


def parse_middle(pieces: Pieces, delimiter: str, decimal: str, width: int) -> np.ndarray | None:
    """Parse the middle lines into a ``(rows, width)`` float array, or None if one is not clean.

    Parameters
    ----------
    pieces : Pieces
        The cut text.
    delimiter, decimal : str
        Field and decimal separators of the layout.
    width : int
        Number of fields of a data row.

    Returns
    -------
    numpy.ndarray or None
        Values, row by row; None when a line is not a clean data row (see the module).
    """
    if width < 1 or delimiter == decimal or "\n" in (delimiter, decimal):
        return None
    allowed = np.zeros(256, dtype=bool)
    allowed[np.frombuffer(f"0123456789eE+-\n{delimiter}{decimal}".encode(), np.uint8)] = True
    out = np.empty((pieces.rows, width))
    text, row, begin = pieces.text, 0, pieces.start
    while begin < pieces.stop:
        end = text.rfind("\n", begin, min(begin + BLOCK_CHARS, pieces.stop)) + 1
        if end <= begin:  # a line longer than a block: up to its end
            end = text.find("\n", begin, pieces.stop) + 1
        block = text[begin:end]
        values = _clean_block(block, delimiter, decimal, width, allowed)
        if values is None:
            logger.debug("rows %d... of the middle not all clean data rows: per-line path", row)
            return None
        out[row:row + len(values)] = values
        row, begin = row + len(values), end
    return out if row == pieces.rows else None


def is_clean_row(line: str, delimiter: str, decimal: str, width: int) -> bool:
    """Return True when one line (without its line end) is a clean data row (see the module)."""
    return parse_middle(Pieces(line + "\n", [], 0, len(line) + 1, 1, []), delimiter, decimal,
                        width) is not None


def _clean_block(block: str, delimiter: str, decimal: str, width: int,
                 allowed: np.ndarray) -> np.ndarray | None:
    """Return the values of a block of whole lines, or None if one is not a clean data row."""
    raw = block.encode("utf-8")
    if len(raw) != len(block) or not allowed[np.frombuffer(raw, np.uint8)].all():
        return None  # a character no plain number holds (letters, spaces, non-ASCII)
    lines = block.count("\n")
    try:
        table = pd.read_csv(io.BytesIO(raw), sep=delimiter, decimal=decimal, header=None,
                            names=list(range(width + 1)), index_col=False, dtype=np.float64,
                            skip_blank_lines=False, engine="c")
    except (ValueError, pd.errors.ParserError, pd.errors.EmptyDataError):
        return None  # a cell that is not a number ("1-2", "1e"), or too many fields
    values = table.to_numpy()
    if values.shape[0] != lines or np.isnan(values[:, :width]).any() \
            or not np.isnan(values[:, width]).all():
        return None  # an empty cell, a short row, a blank line or one field too many
    return values[:, :width]
