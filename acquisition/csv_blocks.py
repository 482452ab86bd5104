r"""The fast path of the text reader: the middle of a clean data block parsed in pieces.

:func:`rigval.acquisition.text_csv.read_csv` sniffs the layout on the first :data:`HEAD_LINES`
and the last :data:`TAIL_LINES` lines of a file only. The lines between them (the middle) are
read from the file here, :data:`BLOCK_BYTES` bytes at a time, and parsed by pandas' C parser
into one preallocated float array, so that memory is the output and one block instead of the
file's text, a Python string and a list of fields per row. A block is taken only when every line
of it is a clean data row: exactly the data's number of fields (one trailing delimiter allowed),
every cell a plain number in the file's decimal separator (ASCII digits, sign, exponent; no
spaces, no ``nan``/``inf``, no empty cell), line ends ``\n`` or ``\r\n``. Such a row is a data
row to the per-line rules of the reader, so sniffing the head and tail gives the layout the whole
file would give, and an ASCII middle decodes alike in every encoding the reader guesses. When a
block holds another line (text, an empty cell, a ragged row), :func:`parse_middle` returns None
and the reader takes its per-line path for the whole file, with its exact results, warnings and
counts.
"""

from __future__ import annotations

import io
import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

__all__ = ["BLOCK_BYTES", "HEAD_LINES", "TAIL_LINES", "Middle", "Pieces", "is_clean_row",
           "parse_middle", "split_file"]

logger = logging.getLogger(__name__)

#: Bytes of the middle parsed per block (about 20,000 rows of a rig CSV).
BLOCK_BYTES = 1 << 20
#: Lines at the start of a file sniffed per line (names, units, header block, first rows).
HEAD_LINES = 1000
#: Lines at the end of a file sniffed per line (delimiter guess, footer, a cut last line).
TAIL_LINES = 500
_READ = 1 << 20  # bytes read at a time to find the head's and tail's line ends
_ASCII = "0123456789eE+-\r\n;,.\t|"  # what a clean block holds


@dataclass(frozen=True)
class Pieces:
    """A file cut at line ends into head lines, a middle byte span and tail lines.

    Attributes
    ----------
    path : pathlib.Path
        The file.
    head, tail : list of str
        The first and last lines, decoded, without line ends.
    start, stop : int
        Byte span of the middle (whole lines, each ending in a line feed).
    rows : int
        Number of middle lines.
    complete : bool
        False when the file stops inside its last line.
    encoding : str
        The encoding head and tail decoded in.
    """

    path: Path
    head: list[str]
    start: int
    stop: int
    rows: int
    tail: list[str]
    complete: bool
    encoding: str


def split_file(path: Path, encoding: str | None) -> Pieces | None:
    """Cut a file into :data:`HEAD_LINES` head lines, the middle and :data:`TAIL_LINES` lines.

    Parameters
    ----------
    path : pathlib.Path
        The file.
    encoding : str, optional
        Text encoding of head and tail; default UTF-8 (with or without BOM), else cp1252, as
        :func:`rigval.acquisition.text_csv.read_text` guesses for the whole file.

    Returns
    -------
    Pieces or None
        None when the file is too short to have a middle, or head and tail do not decode (the
        per-line path then reads, and reports on, the whole file). ``head + middle lines +
        tail`` equals the whole text's ``splitlines()`` when the middle is ASCII.
    """
    with path.open("rb") as stream:
        size = stream.seek(0, io.SEEK_END)
        stream.seek(0)
        first = b""
        while first.count(b"\n") < HEAD_LINES and len(first) < size:
            first += stream.read(_READ)
        if first.count(b"\n") < HEAD_LINES:
            return None
        start = 0
        for _ in range(HEAD_LINES):
            start = first.index(b"\n", start) + 1
        last, begin = b"", size
        while last.count(b"\n") <= TAIL_LINES + 1 and begin > start:
            begin = max(start, begin - _READ)
            stream.seek(begin)
            last = stream.read(min(_READ, size - begin)) + last
    stop = len(last) - 1 if last.endswith(b"\n") else len(last)  # the last line's end
    for _ in range(TAIL_LINES):
        stop = last.rfind(b"\n", 0, stop)
        if stop < 0:
            return None
    stop += 1
    if begin + stop <= start:
        return None
    head, tail, used = _decode(first[:start], last[stop:], encoding)
    if head is None or tail is None:
        return None
    rows = _count_lines(path, start, begin + stop)
    return Pieces(path, head.splitlines(), start, begin + stop, rows, tail.splitlines(),
                  tail.endswith(("\n", "\r")), used)


def _decode(head: bytes, tail: bytes, encoding: str | None
            ) -> tuple[str | None, str | None, str]:
    """Decode head and tail in the encoding the whole file would be read in (None: unsure)."""
    if encoding is None and head[:2] in (b"\xff\xfe", b"\xfe\xff"):
        return None, None, ""  # UTF-16: never an ASCII middle
    try:
        if encoding and _ASCII.encode(encoding) != _ASCII.encode():
            return None, None, ""  # the middle's bytes would mean other characters
    except (LookupError, UnicodeError):
        return None, None, ""  # the per-line path reports an unknown encoding
    for candidate in [encoding] if encoding else ["utf-8", "cp1252"]:
        try:
            return (head.decode("utf-8-sig" if candidate == "utf-8" else candidate),
                    tail.decode(candidate), candidate)
        except (UnicodeDecodeError, LookupError):
            continue
    return None, None, ""


def _count_lines(path: Path, start: int, stop: int) -> int:
    """Return the number of line feeds in a byte span of a file."""
    count = 0
    with path.open("rb") as stream:
        stream.seek(start)
        for offset in range(start, stop, BLOCK_BYTES):
            count += stream.read(min(BLOCK_BYTES, stop - offset)).count(b"\n")
    return count


@dataclass
class Middle:
    """The middle of a file: clean rows parsed, the other lines left to the per-line rules.

    Attributes
    ----------
    values : list of numpy.ndarray
        Per column, the values of the clean rows in file order (a list, so that a reader can
        drop each column once it has taken it over).
    line : numpy.ndarray
        0-based line number of each of those rows (int64); a reader drops it once it has placed
        the other rows among them (mutable for that: memory).
    segments : list of tuple of (int, list of str)
        The first line number and the lines of each run of lines not parsed here: every block
        holding a line that is not a clean data row, widened to start and end with a clean row
        (so that the per-line rules see the same neighbours as in the whole file).
    """

    values: list[np.ndarray]
    line: np.ndarray
    segments: list[tuple[int, list[str]]]


def parse_middle(pieces: Pieces, delimiter: str, decimal: str, width: int) -> Middle | None:
    """Parse the clean blocks of the middle; keep the lines of the other blocks as text.

    Parameters
    ----------
    pieces : Pieces
        The cut file.
    delimiter, decimal : str
        Field and decimal separators of the layout.
    width : int
        Number of fields of a data row.

    Returns
    -------
    Middle or None
        None when the layout has no fast path or a block does not decode.
    """
    allowed = _allowed(delimiter, decimal, width)
    if allowed is None:
        return None
    out = [np.empty(pieces.rows) for _ in range(width)]
    line = np.empty(pieces.rows, dtype=np.int64)
    segments: list[tuple[int, list[str]]] = []
    row, current, carry, last, widen = 0, len(pieces.head), b"", "", False
    with pieces.path.open("rb") as stream:
        stream.seek(pieces.start)
        for offset in range(pieces.start, pieces.stop, BLOCK_BYTES):
            data = carry + stream.read(min(BLOCK_BYTES, pieces.stop - offset))
            cut = data.rfind(b"\n") + 1  # a line longer than a block waits for the next
            block, carry = data[:cut], data[cut:]
            if not block:
                continue
            values = _clean_block(block, delimiter, decimal, width, allowed)
            if values is not None and widen:  # its first (clean) row closes the last segment
                first = block.index(b"\n") + 1
                segments[-1][1].append(block[:first].decode("ascii").rstrip("\r\n"))
                block, values, current, widen = block[first:], values[1:], current + 1, False
            if values is not None:
                for column, cells in zip(out, values.T, strict=True):
                    column[row:row + len(values)] = cells
                line[row:row + len(values)] = np.arange(current, current + len(values))
                row, current = row + len(values), current + len(values)
                if len(values):
                    last = block[block.rfind(b"\n", 0, len(block) - 1) + 1:].decode("ascii")
                continue
            try:
                lines = block.decode(pieces.encoding).splitlines()
            except (UnicodeDecodeError, LookupError):
                return None
            if segments and segments[-1][0] + len(segments[-1][1]) == current:
                segments[-1][1].extend(lines)  # right after the last segment: one segment
            elif is_clean_row(lines[0], delimiter, decimal, width) or row == 0 \
                    or line[row - 1] != current - 1:
                segments.append((current, lines))
            else:  # the clean row above joins, so the segment starts with a clean row
                row -= 1
                segments.append((current - 1, [last.rstrip("\r\n"), *lines]))
            current += len(lines)
            widen = not is_clean_row(segments[-1][1][-1], delimiter, decimal, width)
    if carry or row + sum(len(lines) for _, lines in segments) != current - len(pieces.head):
        return None
    logger.debug("%d middle rows in blocks, %d lines per line", row,
                 sum(len(lines) for _, lines in segments))
    return Middle([column[:row] for column in out], line[:row], segments)


def is_clean_row(line: str, delimiter: str, decimal: str, width: int) -> bool:
    """Return True when one line (without its line end) is a clean data row (see the module)."""
    allowed = _allowed(delimiter, decimal, width)
    try:
        raw = (line + "\n").encode("ascii")
    except UnicodeEncodeError:
        return False
    return allowed is not None and _clean_block(raw, delimiter, decimal, width,
                                                allowed) is not None


def _allowed(delimiter: str, decimal: str, width: int) -> np.ndarray | None:
    """Return the bytes a clean block may hold (None: the layout has no fast path)."""
    if width < 1 or delimiter == decimal or not f"{delimiter}{decimal}".isascii() \
            or any(c in "0123456789eE+-\r\n" for c in (delimiter, decimal)):
        return None
    allowed = np.zeros(256, dtype=bool)
    allowed[np.frombuffer(f"0123456789eE+-\r\n{delimiter}{decimal}".encode(), np.uint8)] = True
    return allowed


def _clean_block(block: bytes, delimiter: str, decimal: str, width: int,
                 allowed: np.ndarray) -> np.ndarray | None:
    """Return the values of a block of whole lines, or None if one is not a clean data row."""
    if not allowed[np.frombuffer(block, np.uint8)].all():
        return None  # a character no plain number holds (letters, spaces, non-ASCII)
    if block.count(b"\r") != block.count(b"\r\n"):
        return None  # a lone carriage return: a line end the per-line path splits at
    lines = block.count(b"\n")
    try:
        table = pd.read_csv(io.BytesIO(block), sep=delimiter, decimal=decimal, header=None,
                            names=list(range(width + 1)), index_col=False, dtype=np.float64,
                            skip_blank_lines=False, engine="c")
    except (ValueError, pd.errors.ParserError, pd.errors.EmptyDataError):
        return None  # a cell that is not a number ("1-2", "1e"), or too many fields
    values = table.to_numpy()
    if values.shape[0] != lines or np.isnan(values[:, :width]).any() \
            or not np.isnan(values[:, width]).all():
        return None  # an empty cell, a short row, a blank line or one field too many
    return values[:, :width]
