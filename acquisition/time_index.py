"""A lazy xarray index for piecewise-uniform time axes (blocks of equally spaced samples).

A stream's ``time`` is a function of three numbers per block (first sample, start, interval;
:mod:`rigval.acquisition.timebase`). :class:`BlockTimeIndex` keeps exactly that description and
computes time values only when they are asked for, so a 1 GiB recording does not carry 256 MiB of
float64 time stamps. The values are bit-identical to :meth:`TimeBase.times
<rigval.acquisition.timebase.TimeBase.times>` (``(i - first) * dt + t_start`` per sample).

Label selection follows pandas: ``ds.sel(time=slice(a, b))`` keeps the samples with
``a <= t <= b`` (computed from the blocks, the index stays lazy); scalar and array labels
(``method="nearest"``, ``tolerance``) are answered by a pandas index built for that call.
Positional slices with step 1 keep the index lazy; other selections materialise the selected
times into a :class:`xarray.indexes.PandasIndex`. See ``docs/formats.md``.
"""

from __future__ import annotations

from collections.abc import Hashable, Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr
from xarray.core.indexing import IndexSelResult  # what Index.sel returns (xarray's API)
from xarray.indexes import CoordinateTransform, CoordinateTransformIndex, Index, PandasIndex

from rigval.acquisition.timebase import TimeBase

__all__ = ["BlockTimeIndex", "BlockTimeTransform", "lazy_time_coords"]


class BlockTimeTransform(CoordinateTransform):
    """Sample position -> time in s for positions ``0 ... size - 1`` of a window of a TimeBase.

    Parameters
    ----------
    timebase : TimeBase
        The blocks of the whole stream.
    offset : int
        Position in ``timebase`` of this window's first sample.
    size : int
        Samples in the window.
    dim : str
        Dimension (and coordinate) name.
    """

    def __init__(self, timebase: TimeBase, offset: int, size: int, dim: str = "time") -> None:
        super().__init__([dim], {dim: size}, dtype=np.dtype(np.float64))
        self.timebase = timebase
        self.offset = int(offset)
        blocks = timebase.blocks
        self._first = np.array([b.first for b in blocks], dtype=np.int64)
        self._t_start = np.array([b.t_start for b in blocks], dtype=np.float64)
        self._dt = np.array([b.dt for b in blocks], dtype=np.float64)

    @property
    def dim(self) -> str:
        """The dimension name."""
        return self.dims[0]

    @property
    def size(self) -> int:
        """Number of samples."""
        return self.dim_size[self.dim]

    def forward(self, dim_positions: dict[str, Any]) -> dict[Hashable, Any]:
        """Return the times (s) of integer sample positions."""
        position = np.asarray(dim_positions[self.dim]).astype(np.int64) + self.offset
        k = np.clip(np.searchsorted(self._first, position, side="right") - 1, 0,
                    self._first.size - 1)
        since = (position - self._first[k]).astype(np.float64)
        times = since * self._dt[k] + self._t_start[k]
        if self.timebase.shifts is not None:  # as TimeBase.times: on the other clock
            times = times * self.timebase.scale + self.timebase.shifts[k]
        return {self.dim: times}

    def reverse(self, coord_labels: dict[Hashable, Any]) -> dict[str, Any]:
        """Return the (fractional) sample positions of times in s."""
        label = np.asarray(coord_labels[self.dim], dtype=np.float64)
        starts = self._t_start
        if self.timebase.shifts is not None:  # back onto the device's own clock
            starts = starts * self.timebase.scale + self.timebase.shifts
        # among the blocks whose times are known (a clock maps no block outside its window:
        # their NaN starts would unsort the search)
        known = np.flatnonzero(np.isfinite(starts))
        k = known[np.clip(np.searchsorted(starts[known], label, side="right") - 1, 0,
                          known.size - 1)]
        if self.timebase.shifts is not None:
            label = (label - self.timebase.shifts[k]) / self.timebase.scale
        position = self._first[k] + (label - self._t_start[k]) / self._dt[k] - self.offset
        return {self.dim: position}

    def generate_coords(self, dims: tuple[str, ...] | None = None) -> dict[Hashable, Any]:
        """Return every time of the window (one allocation per block)."""
        return {self.dim: self.timebase.times(self.offset, self.offset + self.size)}

    def equals(self, other: CoordinateTransform, **kwargs: Any) -> bool:
        """Return True for the same blocks and clock, window start and size."""
        return (isinstance(other, BlockTimeTransform) and other.offset == self.offset
                and other.size == self.size and other.timebase == self.timebase)

    def window(self, start: int, stop: int) -> BlockTimeTransform:
        """Return the transform of positions ``start ... stop - 1`` of this window."""
        return BlockTimeTransform(self.timebase, self.offset + start, max(stop - start, 0),
                                  self.dim)

    def searchsorted(self, labels: Any, side: str = "left") -> Any:
        """Return where times ``labels`` (s) go among the window's, as :func:`numpy.searchsorted`.

        A bisection over the positions, evaluating the times at its midpoints only (the times
        increase): ``"left"`` the first position whose time is ``>= label``, ``"right"`` the
        first whose time is ``> label`` (``size`` if none).
        """
        wanted = np.asarray(labels, dtype=np.float64)
        low = np.zeros(wanted.shape, dtype=np.int64)
        high = np.full(wanted.shape, self.size, dtype=np.int64)
        while np.any(low < high):
            open_ = low < high
            middle = (low + high) // 2
            at = self.forward({self.dim: np.where(open_, np.minimum(middle, self.size - 1),
                                                  0)})[self.dim]
            right = (at < wanted) if side == "left" else (at <= wanted)
            low = np.where(open_ & right, middle + 1, low)
            high = np.where(open_ & ~right, middle, high)
        return int(low) if wanted.ndim == 0 else low

    def first_at_or_after(self, label: float) -> int:
        """Return the first position whose time is ``>= label`` (``size`` if none)."""
        return int(self.searchsorted(label, "left"))

    def first_after(self, label: float) -> int:
        """Return the first position whose time is ``> label`` (``size`` if none)."""
        return int(self.searchsorted(label, "right"))


class BlockTimeIndex(CoordinateTransformIndex):
    """Lazy index of a stream's ``time`` coordinate (see the module docstring).

    Parameters
    ----------
    transform : BlockTimeTransform
        The blocks and the window they describe.
    """

    transform: BlockTimeTransform

    def __init__(self, transform: BlockTimeTransform) -> None:
        super().__init__(transform)

    @property
    def dim(self) -> str:
        """The dimension name."""
        return self.transform.dim

    def _pandas(self) -> PandasIndex:
        """Return an equivalent (materialised) pandas index."""
        return PandasIndex(self.to_pandas_index(), self.dim, coord_dtype=np.dtype(np.float64))

    def to_pandas_index(self) -> pd.Index:
        """Return the times as a pandas index (materialises them)."""
        return pd.Index(self.transform.generate_coords()[self.dim], name=self.dim)

    def isel(self, indexers: Mapping[Any, Any]) -> Index | None:
        """Keep the index lazy for step-1 slices; materialise other selections."""
        indexer = indexers[self.dim]
        if isinstance(indexer, slice):
            chosen = range(self.transform.size)[indexer]
            if chosen.step == 1:
                return BlockTimeIndex(self.transform.window(chosen.start, chosen.stop))
            indexer = np.arange(chosen.start, chosen.stop, chosen.step)
        if isinstance(indexer, xr.Variable):
            if indexer.ndim != 1:
                return None
            new_dim, indexer = indexer.dims[0], indexer.values
        else:
            new_dim = self.dim
        if np.ndim(indexer) == 0:
            return None
        indexer = np.asarray(indexer)
        if indexer.dtype == bool:
            indexer = np.flatnonzero(indexer)
        values = self.transform.forward({self.dim: indexer})[self.dim]
        return PandasIndex(pd.Index(values, name=self.dim), new_dim,
                           coord_dtype=np.dtype(np.float64))

    def sel(self, labels: dict[Any, Any], method: Any = None, tolerance: Any = None) -> Any:
        """Select by time in s: slices ``a <= t <= b`` lazily, other labels as pandas does."""
        label = labels[self.dim]
        if isinstance(label, slice) and label.step is None and method is None:
            start = 0 if label.start is None else self.transform.first_at_or_after(
                float(label.start))
            stop = self.transform.size if label.stop is None else self.transform.first_after(
                float(label.stop))
            return IndexSelResult({self.dim: slice(start, max(start, stop))})
        return self._pandas().sel(labels, method=method, tolerance=tolerance)

    def equals(self, other: Index, *, exclude: frozenset[Hashable] | None = None,
               **kwargs: Any) -> bool:
        """Equal to another BlockTimeIndex of the same window, or a pandas index of equal times."""
        if isinstance(other, BlockTimeIndex):
            return self.transform.equals(other.transform)
        if isinstance(other, PandasIndex):
            return bool(self.to_pandas_index().equals(other.index))
        return False

    def join(self, other: Index, how: str = "inner") -> Index:
        """Join as pandas indexes do (materialises the times)."""
        other = other._pandas() if isinstance(other, BlockTimeIndex) else other
        return self._pandas().join(other, how=how)  # type: ignore[arg-type]

    def reindex_like(self, other: Index, method: Any = None,
                     tolerance: Any = None) -> dict[Hashable, Any]:
        """Reindex as pandas indexes do (materialises the times)."""
        other = other._pandas() if isinstance(other, BlockTimeIndex) else other
        return self._pandas().reindex_like(other, method=method,  # type: ignore[arg-type]
                                           tolerance=tolerance)

    @classmethod
    def concat(cls, indexes: Sequence[Any], dim: Hashable,
               positions: Any = None) -> Index:
        """Join consecutive windows of one time base lazily; anything else as pandas indexes."""
        parts = list(indexes)
        if positions is None and all(isinstance(p, BlockTimeIndex) for p in parts):
            first = parts[0].transform
            end = first.offset
            for part in parts:
                if part.transform.timebase != first.timebase or \
                        part.transform.offset != end:
                    break
                end += part.transform.size
            else:
                return BlockTimeIndex(BlockTimeTransform(first.timebase, first.offset,
                                                         end - first.offset, str(dim)))
        pandas = [p._pandas() if isinstance(p, BlockTimeIndex) else p for p in parts]
        return PandasIndex.concat(pandas, dim, positions)

    def _repr_inline_(self, max_width: int) -> str:
        blocks = len(self.transform.timebase.blocks)
        clock = ", on another clock" if self.transform.timebase.clocked else ""
        return (f"BlockTimeIndex ({self.transform.size} samples, {blocks} block"
                f"{'s' if blocks != 1 else ''}, dt={self.transform.timebase.dt:.6g} s{clock})")

    def __repr__(self) -> str:
        return self._repr_inline_(80)


def lazy_time_coords(timebase: TimeBase, start: int, stop: int,
                     attrs: Mapping[str, Any]) -> xr.Coordinates:
    """Return the ``time`` coordinate of samples ``start ... stop - 1`` as lazy coordinates.

    Parameters
    ----------
    timebase : TimeBase
        The stream's blocks.
    start, stop : int
        Sample window.
    attrs : mapping
        Attributes of the ``time`` variable (CF ``units``, ``calendar``, ...).
    """
    index = BlockTimeIndex(BlockTimeTransform(timebase, start, stop - start))
    coords = xr.Coordinates.from_xindex(index)
    coords["time"].attrs.update(attrs)
    return coords
