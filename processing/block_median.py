"""The exact median of a record given a block at a time (no whole-record copy).

:func:`exact_median` counts each block's distinct values and merges the counts, then picks the
middle order statistics, so its result equals :func:`numpy.median` of the blocks joined, bit
for bit, while memory holds one block and the table of distinct values (small for counts,
count steps and their departures from a running rate, which take few distinct values).
"""

from __future__ import annotations

import logging
from collections.abc import Iterable

import numpy as np

__all__ = ["exact_median"]

logger = logging.getLogger(__name__)


def exact_median(parts: Iterable[np.ndarray]) -> float:
    """Return the median of the values of all ``parts``, as :func:`numpy.median` of them joined.

    Parameters
    ----------
    parts : iterable of numpy.ndarray
        The record's values a block at a time (any real dtype, any unit; NaN-free).

    Returns
    -------
    float
        The middle value (odd count) or the mean of the two middle values (even count), in the
        values' unit; NaN when there are no values.
    """
    values, counts = np.zeros(0), np.zeros(0, np.int64)
    for part in parts:
        distinct, number = np.unique(part, return_counts=True)
        values, inverse = np.unique(np.concatenate((values, distinct)), return_inverse=True)
        merged = np.zeros(values.size, np.int64)
        np.add.at(merged, inverse, np.concatenate((counts, number)))
        counts = merged
    total = int(counts.sum())
    if total == 0:
        return float("nan")
    below = np.cumsum(counts)
    low = values[np.searchsorted(below, (total - 1) // 2, side="right")]
    high = values[np.searchsorted(below, total // 2, side="right")]
    if total % 2:
        return float(np.float64(low))
    return float((np.float64(low) + np.float64(high)) / 2)
