"""A stream's sample times, computed only for the samples asked for.

A stream read from a file keeps its ``time`` coordinate lazy (:class:`~rigval.acquisition.
time_index.BlockTimeIndex`): a 1-hour record at 5 kS/s would otherwise carry 137 MiB of float64
time stamps. The checks that look up a few times (an edge's neighbours, a finding's first and
last sample) take :class:`SampleTimes` instead of the materialised axis: indexing and
:meth:`SampleTimes.searchsorted` (also through :func:`numpy.searchsorted`) give the values and
positions the materialised axis would, bit for bit, without making it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr
from xarray.indexes import PandasIndex

from rigval.acquisition.time_index import BlockTimeIndex, BlockTimeTransform, lazy_time_coords

__all__ = ["SampleTimes", "clocked_time_coordinate", "indexed_time_coordinate", "sample_times",
           "time_coordinate", "times_of", "times_window"]


class SampleTimes:
    """The times (s) of a lazy time axis, made for the positions asked for.

    Parameters
    ----------
    transform : BlockTimeTransform
        The stream's blocks and the window of them this axis covers.
    """

    def __init__(self, transform: BlockTimeTransform) -> None:
        self._transform = transform

    @property
    def size(self) -> int:
        """Number of samples."""
        return self._transform.size

    @property
    def shape(self) -> tuple[int]:
        """``(size,)``, as the materialised axis's."""
        return (self.size,)

    def __len__(self) -> int:
        return self.size

    def _at(self, positions: Any) -> np.ndarray:
        """Return the times of integer positions (any shape; negative ones from the end)."""
        index = np.asarray(positions, dtype=np.int64)
        if index.size and (index.min() < -self.size or index.max() >= self.size):
            raise IndexError(f"sample index out of range for {self.size} samples")
        index = np.where(index < 0, index + self.size, index)
        return self._transform.forward({self._transform.dim: index})[self._transform.dim]

    def __getitem__(self, key: Any) -> Any:
        """Return the times of an integer, an integer array, a boolean mask or a slice.

        A slice of step 1 is computed block by block as the whole axis is (a chunked reader's
        slices cost what they hold, not an index of the whole axis).
        """
        if isinstance(key, slice):
            start, stop, step = key.indices(self.size)
            if step == 1:
                offset = self._transform.offset
                return self._transform.timebase.times(offset + start,
                                                      offset + max(start, stop))
            return self._at(np.arange(start, stop, step))
        index = np.asarray(key)
        if index.dtype == bool:
            return self._at(np.flatnonzero(index))
        values = self._at(index)
        return float(values) if index.ndim == 0 else values

    def window(self, start: int, stop: int) -> SampleTimes:
        """Return the times of samples ``start ... stop - 1`` (as lazy as these)."""
        start, stop, _ = slice(start, stop).indices(self.size)
        return SampleTimes(self._transform.window(start, stop))

    def searchsorted(self, values: Any, side: str = "left", sorter: Any = None) -> Any:
        """Return where ``values`` would go among the times, as :func:`numpy.searchsorted`.

        :meth:`BlockTimeTransform.searchsorted <rigval.acquisition.time_index.
        BlockTimeTransform.searchsorted>`: a bisection evaluating the times at its midpoints.
        """
        if sorter is not None:
            raise TypeError("SampleTimes.searchsorted takes no sorter (the times increase)")
        return self._transform.searchsorted(values, side)


def sample_times(stream: xr.Dataset | xr.DataArray) -> SampleTimes | np.ndarray:
    """Return a stream's sample times: lazy where its axis is, else the axis's values (s).

    ``stream`` may be a stream or a variable of it (its ``time`` coordinate).
    """
    index = stream.xindexes.get("time")
    if isinstance(index, BlockTimeIndex):
        return SampleTimes(index.transform)
    return stream["time"].to_numpy()


def times_of(time: Any) -> SampleTimes | np.ndarray:
    """Return ``time`` as the checks take it: a :class:`SampleTimes` as it is, else float64."""
    return time if isinstance(time, SampleTimes) else np.asarray(time, dtype=np.float64)


def times_window(time: SampleTimes | np.ndarray, start: int, stop: int
                 ) -> SampleTimes | np.ndarray:
    """Return the times of samples ``start ... stop - 1``: lazy where ``time`` is, else a view."""
    return time.window(start, stop) if isinstance(time, SampleTimes) else time[start:stop]


def time_coordinate(stream: xr.Dataset, attrs: Mapping[str, Any] | None = None
                    ) -> xr.Coordinates:
    """Return a stream's ``time`` coordinate with its index as it is (a lazy axis stays lazy).

    Building a Dataset on ``stream["time"]`` instead makes a pandas index of the times (memory:
    the whole axis, twice). ``attrs``: the coordinate's attributes instead of its own.
    """
    variable = stream.variables["time"]
    if attrs is not None:
        variable = variable.copy(deep=False)
        variable.attrs = dict(attrs)
    return xr.Coordinates({"time": variable}, indexes={"time": stream.xindexes["time"]})


def indexed_time_coordinate(time: np.ndarray, attrs: Mapping[str, Any]) -> xr.Coordinates:
    """Return times (s) as the indexed ``time`` coordinate, its index on the same array.

    xarray would build the index with :class:`pandas.Index`, which copies the array (pandas 3):
    137 MiB more for an hour at 5 kS/s.
    """
    index = PandasIndex(pd.Index(time, copy=False, name="time"), "time")
    return xr.Coordinates({"time": xr.Variable("time", time, dict(attrs))},
                          indexes={"time": index})


def clocked_time_coordinate(stream: xr.Dataset, scale: float, shifts: Mapping[int, float],
                            attrs: Mapping[str, Any]) -> xr.Coordinates | None:
    """Return a stream's times on another clock as a lazy ``time`` coordinate, where it can.

    Sample ``i`` of segment ``s`` gets ``scale * t_i + shifts[s]`` (s), the values of that
    expression on the materialised axis bit for bit (:meth:`TimeBase.on_clock
    <rigval.acquisition.timebase.TimeBase.on_clock>`), computed only where asked for: a
    1-hour wireless stream's aligned times are not held (44 MiB at 1.6 kS/s).

    Parameters
    ----------
    stream : xarray.Dataset
        A stream whose ``time`` is a lazy axis and whose ``segment`` numbers its blocks (as
        read from a file).
    scale : float
        Factor of every time.
    shifts : mapping of int to float
        Segment -> shift added, s.
    attrs : mapping
        The coordinate's attributes.

    Returns
    -------
    xarray.Coordinates or None
        None when the axis is not lazy, a segment is not one of its blocks, or a segment of
        the stream has no shift: the caller maps the materialised times instead.
    """
    index = stream.xindexes.get("time")
    if not isinstance(index, BlockTimeIndex):
        return None
    transform = index.transform
    timebase, start = transform.timebase, transform.offset
    stop = start + transform.size
    blocks = timebase.overlaps(start, stop)
    segment = np.asarray(stream["segment"])
    runs = np.flatnonzero(segment[1:] != segment[:-1]) + 1 + start
    if (runs.tolist() != [lo for _, _, lo, _ in blocks[1:]]
            or any(int(segment[lo - start]) != k or k not in shifts for k, _, lo, _ in blocks)):
        return None
    on_clock = [shifts.get(k, math.nan) for k in range(len(timebase.blocks))]
    return lazy_time_coords(timebase.on_clock(scale, on_clock), start, stop, attrs)
