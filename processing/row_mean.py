"""The mean over the rows of a table handed on a block of rows at a time (bounded memory).

:class:`RowMean` equals ``numpy.mean(table, axis=0)`` of the whole C-ordered table bit for bit:
numpy adds the rows of a table of more than one column one after the other onto zeros (the
columns are its inner loop; only a single column is summed pairwise), then divides by their
number, and so does :class:`RowMean`, a row at a time.
"""

from __future__ import annotations

import numpy as np

from rigval.processing.arrays import FloatArray

__all__ = ["RowMean"]


class RowMean:
    """Mean over rows, added a block of rows at a time, as ``numpy.mean(axis=0)`` of them all.

    Parameters
    ----------
    columns : int
        Columns of the rows; at least two (numpy sums a single column pairwise, in another
        order).

    Raises
    ------
    ValueError
        When ``columns`` is less than two.
    """

    def __init__(self, columns: int) -> None:
        if columns < 2:
            raise ValueError(f"rows of at least two columns are averaged here, got {columns}")
        self._total = np.zeros(columns)
        self._rows = 0

    def add(self, rows: FloatArray) -> None:
        """Add a block of rows, (n_rows, columns), after those added before."""
        for row in rows:  # in numpy.mean's order, not a block's sum added to the total
            self._total += row
        self._rows += len(rows)

    def mean(self) -> FloatArray:
        """Return the mean of the rows added (at least one), (columns,)."""
        return np.true_divide(self._total, self._rows)
