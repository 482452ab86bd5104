"""The numpy array types the processing functions take and return, and what several take of arrays.

Two checks several modules make before working on a whole record in place or in order: whether
an array may be written in place (:func:`writable_float64`) and whether its values never
decrease (:func:`never_decreasing`, a chunk at a time); and the distinct values of an array that
comes in runs, such as a stream's segment numbers (:func:`distinct_in_runs`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from rigval.acquisition.sample_times import SampleTimes

__all__ = ["BoolArray", "FloatArray", "IntArray", "distinct_in_runs", "never_decreasing",
           "writable_float64"]

#: Samples, times (s) and physical values.
FloatArray = NDArray[np.float64]
#: Indices, segment numbers and counts.
IntArray = NDArray[np.int64]
#: Masks (valid samples, matched events).
BoolArray = NDArray[np.bool_]

#: Samples :func:`never_decreasing` compares at once.
_ORDER_CHUNK = 1 << 20


def writable_float64(values: Any) -> bool:
    """Return True when ``values`` is a writeable float64 array of at least one dimension.

    Such an array, handed over by its owner (an ``overwrite`` argument), may take a
    computation's result in its own memory; a scalar, another dtype or a read-only view may not.
    """
    return (isinstance(values, np.ndarray) and values.dtype == np.float64 and values.ndim > 0
            and values.flags.writeable)


def never_decreasing(x: FloatArray | SampleTimes, *, strictly: bool = False) -> bool:
    """Return True when the values of ``x`` never decrease (``strictly``: always increase).

    Compared a chunk at a time (memory: no whole-record differences; a lazy time axis's times
    computed a chunk at a time). True for fewer than two values.
    """
    step_ok = np.greater if strictly else np.greater_equal
    return all(bool(np.all(step_ok(np.diff(x[lo:lo + _ORDER_CHUNK + 1]), 0)))
               for lo in range(0, max(x.size - 1, 1), _ORDER_CHUNK))


def distinct_in_runs(values: np.ndarray) -> np.ndarray:
    """Return the distinct values of a 1-D array that comes in runs of equal values, sorted.

    ``numpy.unique`` of the values at the starts of the runs (a stream's segment numbers come in
    a few runs): the same values, without a sorted copy of the whole record.
    """
    if values.size == 0:
        return np.unique(values)
    starts = np.concatenate(([0], np.flatnonzero(values[1:] != values[:-1]) + 1))
    return np.unique(values[starts])
