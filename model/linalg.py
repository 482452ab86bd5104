"""Batched small dense linear algebra for the loop Jacobian ``J_u`` (one matrix per time step).

:class:`BatchLU` factorises a stack of square matrices once and serves solves with ``J`` and with
``J^T``: positions (Newton), velocities, accelerations and multipliers all reuse one factorisation.
The elimination runs across the whole batch at once (batch in the last, contiguous axis). Rows are
first put in a fixed order that suits the mechanism (partial pivoting on a representative matrix);
a step whose pivot in that order is smaller than ``threshold`` times the largest candidate in its
column swaps rows as partial pivoting would (threshold pivoting), so the factorisation is as stable
as LAPACK's while rows move only where they must. The test runs after an elimination without it
(every multiplier within ``1 / threshold`` means no swap was due), and only the matrices that
fail it are factorised again with the tests. :func:`solve_one` solves one small system.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
from scipy.linalg.lapack import dgesv

__all__ = ["BatchLU", "row_max_abs", "solve_one", "static_row_order"]

#: Threshold pivoting: keep the pivot in place unless it is below this fraction of the column max.
_THRESHOLD = 0.1
#: Matrices factorised together (a chunk of 6 x 6 matrices fits in a core's cache).
_CHUNK = 4096


def _pivoting_factor(a: np.ndarray, perm: np.ndarray) -> None:
    """LU with threshold pivoting of a stack (size, size, m) in place; ``perm`` (size, m) rows."""
    for k in range(a.shape[0] - 1):
        column = np.abs(a[k:, k])
        # the column's largest candidate below the pivot (a pivot that is itself the largest
        # never swaps); NaN compares false and stays in place
        largest = np.maximum.reduce(column[1:], axis=0)
        swap = np.flatnonzero(column[0] < _THRESHOLD * largest)
        if swap.size:
            target = k + np.argmax(column[:, swap], axis=0)
            own = a[k][:, swap].copy()
            a[k][:, swap] = a[target, :, swap].T
            a[target, :, swap] = own.T
            own_perm = perm[k, swap].copy()
            perm[k, swap] = perm[target, swap]
            perm[target, swap] = own_perm
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            a[k + 1:, k] /= a[k, k]
            a[k + 1:, k + 1:] -= a[k + 1:, k, None] * a[k, None, k + 1:]


def solve_one(matrix: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Solve one small square system ``matrix x = rhs`` (LAPACK ``dgesv``, partial pivoting).

    The same LAPACK routine as :func:`numpy.linalg.solve` without its per-call overhead (about
    four times less for a 6 x 6 system), for the sequential continuation's many tiny solves.

    Raises
    ------
    numpy.linalg.LinAlgError
        When the matrix is exactly singular (a zero pivot).
    """
    x, info = dgesv(matrix, rhs)[2:]
    if info > 0:
        raise np.linalg.LinAlgError("singular matrix")
    return x


def row_max_abs(values: np.ndarray) -> np.ndarray:
    """Largest absolute value of each row of a (n, m) array with few columns, (n,).

    Column by column: numpy's reduction along a short last axis is about twenty times slower.
    NaN propagates.
    """
    magnitude = np.abs(values)
    out = magnitude[:, 0].copy() if values.shape[1] else np.zeros(values.shape[0])
    for j in range(1, values.shape[1]):
        np.maximum(out, magnitude[:, j], out=out)
    return out


def static_row_order(matrix: np.ndarray) -> np.ndarray:
    """Rows of a representative matrix in the order partial pivoting takes them as pivots.

    Parameters
    ----------
    matrix : numpy.ndarray
        (m, m) square matrix.

    Returns
    -------
    numpy.ndarray
        (m,) row indices.
    """
    perm = scipy.linalg.lu(matrix, p_indices=True)[0]
    return np.argsort(perm)


class BatchLU:
    """LU factors of a stack of square matrices, or a least-squares solver for a tall stack.

    Parameters
    ----------
    matrices : numpy.ndarray
        (rows, cols, n): the stack with the batch in the last axis; rows >= cols.
    row_order : numpy.ndarray, optional
        (rows,) initial row order (default: as given).
    """

    def __init__(self, matrices: np.ndarray, row_order: np.ndarray | None = None) -> None:
        rows, cols, n = matrices.shape
        self.size = cols
        self.square = rows == cols
        self.matrices = matrices
        if not self.square:
            stack = np.moveaxis(matrices, -1, 0)
            self.stack = stack
            self.normal = np.swapaxes(stack, -1, -2) @ stack
            return
        order = np.arange(rows) if row_order is None else np.asarray(row_order)
        # One new array for the factors, filled in row order (no intermediate copy: every
        # large temporary costs fresh pages on a loaded machine, docs/performance.md).
        self.lu = np.take(matrices, order, axis=0)
        self.order = order
        self.perm: np.ndarray | None = None
        for start in range(0, n, _CHUNK):
            self._factor(slice(start, min(start + _CHUNK, n)))

    def _factor(self, part: slice) -> None:
        """Factorise one chunk of the stack in place (chunks stay in the processor's cache).

        Most matrices keep the static row order, so the elimination first runs without pivot
        tests; threshold pivoting is then checked after the fact (a matrix needed no row swap
        exactly when every multiplier ``|l_ik| = |a_ik / a_kk|`` is at most ``1 / _THRESHOLD``)
        and the few matrices that needed one (or met a zero or non-finite pivot) are factorised
        again from their original rows with the pivot tests, as partial pivoting would.
        """
        a = self.lu[:, :, part]
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            for k in range(self.size - 1):
                a[k + 1:, k] /= a[k, k]
                a[k + 1:, k + 1:] -= a[k + 1:, k, None] * a[k, None, k + 1:]
            below = np.tril_indices(self.size, -1)
            growth = np.maximum.reduce(np.abs(a[below]), axis=0, initial=0.0)
        redo = np.flatnonzero(~(growth <= 1.0 / _THRESHOLD)) + (part.start or 0)
        if redo.size == 0:
            return
        if self.perm is None:
            self.perm = np.repeat(self.order[:, None], self.lu.shape[-1], axis=1)
        again = np.take(self.matrices[:, :, redo], self.order, axis=0)
        perm = self.perm[:, redo]
        _pivoting_factor(again, perm)
        self.lu[:, :, redo] = again
        self.perm[:, redo] = perm

    def assign(self, steps: np.ndarray, other: BatchLU) -> None:
        """Replace the matrices ``steps`` and their factors by those of ``other``, in place.

        Parameters
        ----------
        steps : numpy.ndarray
            (k,) indices of the matrices replaced.
        other : BatchLU
            Factors of the k new matrices (the same shape of matrix).
        """
        self.matrices[:, :, steps] = other.matrices  # the tall stack is a view of it
        if not self.square:
            self.normal[steps] = other.normal
            return
        self.lu[:, :, steps] = other.lu
        if self.perm is None and other.perm is None and np.array_equal(self.order, other.order):
            return
        if self.perm is None:
            self.perm = np.repeat(self.order[:, None], self.lu.shape[-1], axis=1)
        self.perm[:, steps] = other.order[:, None] if other.perm is None else other.perm

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """Solve ``J x = rhs`` for each matrix (least squares for a tall stack).

        Parameters
        ----------
        rhs : numpy.ndarray
            (n, rows) or (n, rows, k).

        Returns
        -------
        numpy.ndarray
            (n, cols) or (n, cols, k).
        """
        if not self.square:
            b = rhs[..., None] if rhs.ndim == 2 else rhs
            x = np.linalg.solve(self.normal, np.swapaxes(self.stack, -1, -2) @ b)
            return x[..., 0] if rhs.ndim == 2 else x
        if self.perm is None:  # rows first and in the factors' order, one copy
            y = np.moveaxis(rhs, 0, -1)[self.order]
        else:
            y = np.take_along_axis(self._rows_first(rhs),
                                   self.perm.reshape(self.perm.shape[0], *([1] * (rhs.ndim - 2)),
                                                     -1), axis=0)
        lu = self.lu
        for k in range(1, self.size):
            y[k] -= np.einsum("jn,j...n->...n", lu[k, :k], y[:k])
        for k in range(self.size - 1, -1, -1):
            if k + 1 < self.size:
                y[k] -= np.einsum("jn,j...n->...n", lu[k, k + 1:], y[k + 1:])
            y[k] /= lu[k, k]
        return self._rows_last(y)

    def solve_transposed(self, rhs: np.ndarray) -> np.ndarray:
        """Solve ``J^T x = rhs`` for each square matrix.

        Parameters
        ----------
        rhs : numpy.ndarray
            (n, cols).

        Returns
        -------
        numpy.ndarray
            (n, rows).
        """
        # P J = L U, so J^T x = b gives U^T w = b, L^T v = w, x = P^T v.
        w = self._rows_first(rhs)
        lu = self.lu
        for k in range(self.size):
            if k:
                w[k] -= np.einsum("jn,jn->n", lu[:k, k], w[:k])
            w[k] /= lu[k, k]
        for k in range(self.size - 2, -1, -1):
            w[k] -= np.einsum("jn,jn->n", lu[k + 1:, k], w[k + 1:])
        x = np.empty_like(w)
        if self.perm is None:
            x[self.order] = w
        else:
            np.put_along_axis(x, self.perm, w, axis=0)
        return self._rows_last(x)

    def condition(self, steps: np.ndarray | None = None) -> np.ndarray:
        """Condition number of matrices with their columns scaled to unit length.

        The 1-norm condition of the column-equilibrated square matrix, exact (from the explicit
        inverse); for a tall stack the 2-norm condition from singular values.

        Parameters
        ----------
        steps : numpy.ndarray, optional
            Indices of the matrices to evaluate (default: all).

        Returns
        -------
        numpy.ndarray
            One condition number per matrix evaluated (inf when singular).
        """
        stack = np.moveaxis(self.matrices, -1, 0)
        if steps is not None:
            stack = stack[steps]
        if not self.square:
            scaled = stack / np.linalg.norm(stack, axis=-2, keepdims=True)
            sv = np.linalg.svd(scaled, compute_uv=False)
            with np.errstate(divide="ignore"):
                return np.where(sv[:, -1] > 0, sv[:, 0] / sv[:, -1], np.inf)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            scaled = stack / np.sum(np.abs(stack), axis=1, keepdims=True)
            try:
                cond = np.linalg.cond(scaled, 1)
            except np.linalg.LinAlgError:
                cond = np.array([np.linalg.cond(m, 1) if np.all(np.isfinite(m)) else np.inf
                                 for m in scaled])
        return np.where(np.isfinite(cond), cond, np.inf)

    def condition_estimate(self) -> np.ndarray:
        """Cheap lower estimate of :meth:`condition` for every matrix, from the pivots, (n,).

        Column scaling does not change the pivot order, so the pivots of the equilibrated matrix
        are ``u_kk / |column k|_1``; one over the smallest is the estimate.
        """
        if not self.square:
            return self.condition()
        pivots = np.abs(self.lu[np.arange(self.size), np.arange(self.size)])
        column_norms = np.sum(np.abs(self.matrices), axis=0)
        with np.errstate(divide="ignore"):
            return 1.0 / np.min(pivots / column_norms, axis=0)

    @staticmethod
    def _rows_first(rhs: np.ndarray) -> np.ndarray:
        return np.ascontiguousarray(np.moveaxis(rhs, 0, -1))

    @staticmethod
    def _rows_last(values: np.ndarray) -> np.ndarray:
        return np.moveaxis(values, -1, 0)
