"""Text cells of a delimited file to numbers, in one vectorised pass over all of them.

The number pattern the text reader recognises (plain decimals with ``.`` or ``,``, exponents,
``nan``, ``inf``) and the conversion of many cells at once, shared by the column reader
(:mod:`rigval.acquisition.text_csv`) and the one-row reader (:mod:`rigval.acquisition.csv_row`).
"""

from __future__ import annotations

import re

import numpy as np
import pandas as pd

__all__ = ["NUMBER", "convert_cells", "convert_table", "split_rows"]

#: A cell holding one number (``.`` or ``,`` as decimal separator, ``nan``, ``inf``).
NUMBER = re.compile(r"^\s*([-+]?(\d+([.,]\d*)?|[.,]\d+)([eE][-+]?\d+)?|[-+]?(nan|inf|infinity))"
                    r"\s*$", re.IGNORECASE)


def convert_cells(cells: np.ndarray | list[str], decimal: str
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Convert text cells to numbers in one pass.

    Parameters
    ----------
    cells : numpy.ndarray of object or list of str
        The cells, flat; None stands for a missing cell.
    decimal : str
        The decimal separator, ``.`` or ``,``.

    Returns
    -------
    stripped : numpy.ndarray of object
        The cells without surrounding blanks (empty string for a missing cell).
    numbers : numpy.ndarray of float
        Their values; NaN for empty cells and text.
    bad : numpy.ndarray of bool
        True for cells holding text that is not a number (``nan`` and ``inf`` are numbers).
    """
    stripped = pd.Series(cells, dtype=object).fillna("").astype(str).str.strip()
    if decimal == ",":
        stripped = stripped.str.replace(",", ".", regex=False)
    numbers = pd.to_numeric(stripped.replace("", np.nan), errors="coerce").to_numpy(float)
    bad = np.isnan(numbers) & (stripped != "").to_numpy()  # text, or a nan cell: look closer
    bad[bad] = ~stripped[bad].str.match(NUMBER.pattern, case=False).to_numpy(bool)
    return stripped.to_numpy(dtype=object), numbers, bad


def convert_table(table: pd.DataFrame, columns: list[int], decimal: str
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Convert the text cells of ``columns`` of a table to numbers in one pass over all of them.

    One pass, not one per column: a table of one row and 20,000 columns costs what a table of
    20,000 rows and one column costs.

    Returns
    -------
    cells : numpy.ndarray of object, shape (rows, len(columns))
        The stripped cells (empty string for a missing cell).
    numbers : numpy.ndarray of float, shape (rows, len(columns))
        Their values; NaN for empty cells and text.
    bad : numpy.ndarray of bool, shape (rows, len(columns))
        True for cells holding text that is not a number (``nan`` and ``inf`` are numbers).
    """
    shape = (len(table), len(columns))
    cells, numbers, bad = convert_cells(table[columns].to_numpy(dtype=object).ravel(), decimal)
    return cells.reshape(shape), numbers.reshape(shape), bad.reshape(shape)


def split_rows(lines: list[str], delimiter: str, width: int) -> pd.DataFrame:
    """Split a few wide data lines into a table of text cells, as ``pandas.read_csv`` would.

    The cells are split on the delimiter only (no quoting, as the per-line path reads), missing
    cells of a short row are empty strings.
    """
    cells = np.full((len(lines), width), "", dtype=object)
    for row, line in enumerate(lines):
        parts = line.split(delimiter)
        cells[row, :len(parts)] = parts
    return pd.DataFrame(cells, dtype=object, copy=False)
