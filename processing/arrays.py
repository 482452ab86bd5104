"""The numpy array types the processing functions take and return (static typing only)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["BoolArray", "FloatArray", "IntArray"]

#: Samples, times (s) and physical values.
FloatArray = NDArray[np.float64]
#: Indices, segment numbers and counts.
IntArray = NDArray[np.int64]
#: Masks (valid samples, matched events).
BoolArray = NDArray[np.bool_]
