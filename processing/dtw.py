"""Dynamic time warping (DTW) of many equally long signal pairs at once, for ISO/TS 18571.

The magnitude score of ISO/TS 18571 warps the model signal onto the reference with DTW: local
cost ``(x_i - y_j)^2``, steps (1, 0), (0, 1), (1, 1) of weight 1, a Sakoe-Chiba band
``|i - j| <= radius``, the path from the first to the last sample of both. Where predecessors tie,
the step that advances only ``x`` wins, then the one advancing only ``y``, then the diagonal (the
order of the TU Graz reference implementation, see docs/metrics.md).

All pairs of a batch share the grid and the band, so the dynamic programme runs over a batch
axis: one vectorised numpy step per anti-diagonal of the cost matrix for the whole batch, and the
backtracking follows every pair's path in lock-step. Each cell sees the same floating-point
operations as in a sweep of one pair alone, so the paths are those of separate sweeps.

Storage: the sweep keeps the accumulated costs of the last three anti-diagonals only, and of
every band cell the decision the backtracking takes there (one byte: which predecessors are the
cheapest), laid out one anti-diagonal after the other at a fixed stride, so that the cells of an
anti-diagonal are contiguous rows and each predecessor lies at a fixed offset for the
backtracking. That is about ``2 n (radius + 3) + n`` bytes per pair (an eighth of the float64
costs of every cell, which the backtracking would otherwise compare again); pairs are processed
in batches of at most :data:`BATCH_BYTES` of it.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterator

import numpy as np

from rigval.acquisition.errors import DataError

__all__ = ["BATCH_BYTES", "dtw_path", "dtw_paths", "pairs_per_batch", "workspace_size"]

logger = logging.getLogger(__name__)

BATCH_BYTES = 32 * 2**20
"""Largest decision array of one batch of pairs, bytes (a batch holds at least one).

About 400 pairs of three revolutions of 360 points with the ISO band: the sweep's Python steps
are shared by that many pairs (fewer pairs cost time: 100 pairs per batch take 1.4 x as long).
"""

_CHECK_EVERY = 32
"""Backtracking steps between checks whether every path of the batch has ended."""


def dtw_path(x: np.ndarray, y: np.ndarray, radius: int) -> tuple[np.ndarray, np.ndarray]:
    """Return the DTW warping path of two equally long signals.

    Local cost ``(x_i - y_j)^2``; steps (1, 0), (0, 1), (1, 1) of weight 1; a Sakoe-Chiba band
    ``|i - j| <= radius``; the path runs from (0, 0) to (n-1, n-1). Where predecessors tie, the
    step that advances only ``x`` wins, then the one advancing only ``y``, then the diagonal.

    Parameters
    ----------
    x, y : numpy.ndarray
        Signals of equal length ``n`` (same units).
    radius : int
        Band half-width, samples (``>= 0``).

    Returns
    -------
    ix, iy : numpy.ndarray
        Indices into ``x`` and ``y`` along the path, from the start; ``x[ix]`` and ``y[iy]`` are
        the warped signals.

    Raises
    ------
    DataError
        If the signals differ in length.

    Notes
    -----
    Time is O(n radius); memory is :func:`dtw_paths`'s for one pair.
    """
    return next(dtw_paths(np.asarray(x)[np.newaxis], np.asarray(y)[np.newaxis], radius))


def dtw_paths(x: np.ndarray, y: np.ndarray, radius: int, *, y_from: int = 0,
              workspace: np.ndarray | None = None) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """Yield the DTW path of each pair of a stack of equally long signals, in order.

    The pairs are swept batch by batch: only one batch's costs and paths are held at a time.

    Parameters
    ----------
    x : numpy.ndarray
        Signals, shape ``(m, n)``.
    y : numpy.ndarray
        Signals of the same shape, or shape ``(1, n)``: one signal every row of ``x`` is warped
        against.
    radius : int
        Band half-width, samples (``>= 0``).
    y_from : int
        Return only the end of each path, its cells with ``iy >= y_from`` (the backtracking
        stops there); 0: the whole path.
    workspace : numpy.ndarray, optional
        Work space of at least :func:`workspace_size` bytes (a contiguous array of any type,
        taken as bytes), written over: a caller
        sweeping several stacks in turn hands each the same one, whose pages are then touched
        (faulted in) once. Default: one of its own.

    Yields
    ------
    (ix, iy)
        For each row ``p`` of ``x``, the path of :func:`dtw_path` ``(x[p], y[p] or y[0])``
        (its cells with ``iy >= y_from``).

    Raises
    ------
    DataError
        If the shapes do not fit.

    Notes
    -----
    Time O(m n radius), with one Python-level step per anti-diagonal and per backtracking step
    for each batch of pairs; memory ``2 n (radius + 3) + n + 1`` bytes per pair of a batch,
    batches bounded by :data:`BATCH_BYTES`, and the costs of three anti-diagonals.
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    if x.ndim != 2 or y.ndim != 2 or y.shape[1] != x.shape[1] or y.shape[0] not in (1, x.shape[0]):
        lengths = (x.shape[-1], y.shape[-1]) if x.ndim and y.ndim else (x.size, y.size)
        raise DataError(f"DTW needs equal lengths, got {lengths[0]} and {lengths[1]} samples "
                        f"(shapes {x.shape} and {y.shape})",
                        hint="truncate or resample both signals to one grid")
    radius = _within(radius, x.shape[1])
    size = _batch(x.shape[0], x.shape[1], radius)
    if workspace is not None:
        workspace = workspace.reshape(-1).view(np.uint8)  # its bytes, whatever its type
    if workspace is None or workspace.size < size * _pair_values(x.shape[1], radius):
        workspace = np.empty(size * _pair_values(x.shape[1], radius), dtype=np.uint8)
    return _paths(x, y, radius, y_from, workspace)


def workspace_size(m: int, n: int, radius: int) -> int:
    """Return the bytes of work space :func:`dtw_paths` uses for ``m`` pairs of ``n`` samples.

    One batch's decisions (:data:`BATCH_BYTES` at most, one pair at least).
    """
    radius = _within(radius, n)
    return _batch(m, n, radius) * _pair_values(n, radius)


def pairs_per_batch(m: int, n: int, radius: int) -> int:
    """Return the pairs of each batch (the last may hold fewer) of :func:`dtw_paths`' ``m`` pairs.

    A caller that hands :func:`dtw_paths` its pairs this many at a time gets the same batches,
    so the same paths, without making every pair's input at once.
    """
    return _batch(m, n, _within(radius, n))


def _within(radius: int, n: int) -> int:
    """Return the band half-width within a grid of ``n`` samples (0 ... n - 1)."""
    return int(min(max(radius, 0), max(n - 1, 0)))


def _pair_values(n: int, radius: int) -> int:
    """Return the decision bytes of one pair (:func:`_decisions`' rows)."""
    return 2 * n * (radius + 3) + n + 1


def _batch(m: int, n: int, radius: int) -> int:
    """Return the pairs of a batch: ``m`` split into equal batches of :data:`BATCH_BYTES`."""
    batches = math.ceil(m / max(1, min(m, BATCH_BYTES // _pair_values(n, radius))))
    return math.ceil(m / batches)


def _paths(x: np.ndarray, y: np.ndarray, radius: int, y_from: int,
           buffer: np.ndarray) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """Sweep and backtrack batch after batch (checked inputs, radius within the grid).

    Every batch's decisions are held in ``buffer`` (one work space for all: its pages are
    touched once).
    """
    m, n = x.shape
    size = _batch(m, n, radius)
    logger.debug("DTW of %d pairs of %d samples, band radius %d: batches of up to %d", m, n,
                 radius, size)
    for start in range(0, m, size):
        rows = slice(start, start + size)
        decisions = _decisions(x[rows], y if y.shape[0] == 1 else y[rows], radius, buffer)
        yield from _backtrack(decisions, n, radius, y_from)


#: Decision bits of a cell: (i-1, j) is a cheapest predecessor; (i, j-1) costs no more than
#: (i-1, j-1).
_FROM_X, _FROM_Y = 1, 2
#: A decision's step in the tie order (i-1, j), (i, j-1), (i-1, j-1): 0, 1, 2 (as argmin).
_STEP = np.array([2, 0, 1, 0], dtype=np.intp)


def _band(n: int, radius: int) -> tuple[np.ndarray, np.ndarray]:
    """Return the first cell ``i`` and the cell count of each anti-diagonal ``k = 0 ... 2 n``.

    Band cells ``i = lo ... lo + count - 1``, ``j = k - i``, 1-based; anti-diagonal 0 holds the
    origin (0, 0) alone, anti-diagonal 1 no cell (both its cells are boundary).
    """
    k = np.arange(2 * n + 1)
    lo = np.maximum(np.maximum(1, k - n), (k - radius + 1) // 2)
    count = np.maximum(np.minimum(np.minimum(n, k - 1), (k + radius) // 2) - lo + 1, 0)
    lo[0], count[0], lo[1] = 0, 1, 1
    return lo, count


def _decisions(x: np.ndarray, y: np.ndarray, radius: int, buffer: np.ndarray) -> np.ndarray:
    """Sweep the accumulated costs; return each band cell's decision, shape ``(rows, m)``.

    The result is a view of ``buffer`` (at least ``rows * m`` bytes). Cell ``(i, j)``
    (1-based samples, 0 the boundary) of anti-diagonal ``k = i + j`` is stored at row
    ``k * skip + i`` with ``skip = radius + 3``, so that its predecessors (i-1, j), (i, j-1),
    (i-1, j-1) lie ``skip + 1``, ``skip`` and ``2 skip + 1`` rows before it, whatever ``k``.
    Its decision: :data:`_FROM_X` when (i-1, j) is a cheapest predecessor, plus :data:`_FROM_Y`
    when (i, j-1) costs no more than (i-1, j-1); the origin's is :data:`_FROM_X` (a finished
    path stays there).

    The costs of anti-diagonal ``k`` are held in slot ``k % 3`` of three, cell ``i`` at row
    ``1 + i - lo``: row 0 and the rows after the cells are infinite, the boundary.
    """
    m, n = x.shape
    skip = radius + 3
    decisions = buffer[:(2 * n * skip + n + 1) * m].reshape(-1, m)
    decisions[0] = _FROM_X
    lo, count = _band(n, radius)
    slots = np.full((3, skip, m), np.inf)
    slots[0, 1] = 0.0  # the origin
    xt = np.ascontiguousarray(x.T)
    # y reversed and spread over the batch: an ascending, contiguous slice per anti-diagonal
    # (numpy's fast path; a broadcast or reversed operand takes about twice as long)
    reverse = np.ascontiguousarray(np.broadcast_to(y[:, ::-1].T, (n, m)))
    best = np.empty((radius + 1, m))
    from_x = np.empty((radius + 1, m), dtype=np.uint8)
    lo_list, count_list = lo.tolist(), count.tolist()
    for k in range(2, 2 * n + 1):
        first, size = lo_list[k], count_list[k]
        costs = slots[k % 3]
        if k < 3 or size < count_list[k - 3]:
            costs[1 + size:] = np.inf  # the longer anti-diagonal k - 3 held these rows
        if size == 0:  # radius 0: odd anti-diagonals hold no cell
            continue
        cells = costs[1:1 + size]
        # local cost (x_i - y_j)^2 for i = first ... first + size - 1, j = k - i
        np.subtract(xt[first - 1:first - 1 + size], reverse[n - k + first:n - k + first + size],
                    out=cells)
        np.multiply(cells, cells, out=cells)
        # predecessors: (i-1, j) and (i, j-1) on anti-diagonal k - 1, (i-1, j-1) on k - 2
        behind = first - lo_list[k - 1]
        left, below = slots[(k - 1) % 3][behind:behind + size], \
            slots[(k - 1) % 3][behind + 1:behind + 1 + size]
        back = first - lo_list[k - 2]
        diagonal = slots[(k - 2) % 3][back:back + size]
        decided = decisions[k * skip + first:k * skip + first + size]
        low, bit = best[:size], from_x[:size]
        np.less_equal(below, diagonal, out=decided)
        np.minimum(below, diagonal, out=low)
        np.less_equal(left, low, out=bit)
        np.minimum(left, low, out=low)
        np.add(decided, decided, out=decided)  # (i, j-1)'s bit is _FROM_Y
        np.add(decided, bit, out=decided)
        np.add(cells, low, out=cells)
    return decisions


def _backtrack(decisions: np.ndarray, n: int, radius: int,
               y_from: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Follow every pair's decisions from (n, n) back to (1, 1), in lock-step.

    Returns 0-based ``(ix, iy)`` per pair, from the start, cells with ``iy >= y_from`` only
    (the walk stops once every path is below). A path that has reached the origin stays there
    (its decision) while the others go on; the steps taken are recorded and turned into
    cells afterwards.
    """
    m = decisions.shape[1]
    skip = radius + 3
    flat = decisions.reshape(-1)
    origin = np.arange(m)
    position = (2 * n * skip + n) * m + origin
    # the offset of each decision's step: (i-1, j-1), (i-1, j), (i, j-1), (i-1, j)
    offsets = np.array([2 * skip + 1, skip + 1, skip, skip + 1]) * m
    taken = np.empty((2 * n, m), dtype=np.uint8)
    steps = 0
    column = np.full(m, n)  # 1-based j of each path, updated at every check
    while steps < 2 * n:
        decision = flat.take(position)
        taken[steps] = decision
        position -= offsets.take(decision)
        np.maximum(position, origin, out=position)
        steps += 1
        if steps % _CHECK_EVERY == 0:
            column -= np.count_nonzero(_STEP.take(taken[steps - _CHECK_EVERY:steps]), axis=0)
            if np.array_equal(position, origin) or column.max() <= y_from:
                break
    step = _STEP.take(taken[:steps])
    i = n - np.concatenate((np.zeros((1, m), np.intp), np.cumsum(step != 1, axis=0)))
    j = n - np.concatenate((np.zeros((1, m), np.intp), np.cumsum(step != 0, axis=0)))
    inside = (i >= 1) & (j >= 1 + y_from)
    return [(i[inside[:, lane], lane][::-1] - 1, j[inside[:, lane], lane][::-1] - 1)
            for lane in range(m)]
