"""Batched small dense linear algebra for the loop Jacobian ``J_u`` (one matrix per time step).

:class:`BatchLU` factorises a stack of square matrices once and serves solves with ``J`` and with
``J^T`` (positions, velocities, accelerations and multipliers all reuse it). The elimination runs
across the whole batch at once, with the pivot order of each matrix chosen by partial pivoting on
a reference matrix (its anchor configuration, a few hundredths of a radian away); a matrix whose
pivots come out small in that order is refactorised by LAPACK with its own pivoting. A tall stack
(redundant constraints) is solved in the least-squares sense.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

__all__ = ["BatchLU", "equilibrated_condition", "pivot_order"]

#: Pivots smaller than this fraction of their column's size send a matrix to LAPACK.
_PIVOT_FLOOR = 1e-3


def pivot_order(matrices: np.ndarray) -> np.ndarray:
    """Row order of partial pivoting for each matrix of a stack, (n, m) int.

    Parameters
    ----------
    matrices : numpy.ndarray
        (n, m, m) square matrices.
    """
    orders = np.empty(matrices.shape[:2], dtype=np.intp)
    for i, matrix in enumerate(matrices):
        perm = scipy.linalg.lu(matrix, p_indices=True)[0]
        orders[i] = perm
    return orders


def equilibrated_condition(matrices: np.ndarray) -> np.ndarray:
    """2-norm condition number of each matrix after scaling its columns to unit length.

    Parameters
    ----------
    matrices : numpy.ndarray
        (n, rows, cols) with rows >= cols.

    Returns
    -------
    numpy.ndarray
        (n,) condition numbers (inf for a rank-deficient matrix).
    """
    if matrices.shape[-1] == 0:
        return np.ones(matrices.shape[0])
    norms = np.linalg.norm(matrices, axis=-2, keepdims=True)
    scaled = matrices / np.where(norms > 0, norms, 1.0)
    sv = np.linalg.svd(scaled, compute_uv=False)
    with np.errstate(divide="ignore"):
        return np.where(sv[:, -1] > 0, sv[:, 0] / sv[:, -1], np.inf)


class BatchLU:
    """LU factors of a stack of square matrices, or a least-squares solver for a tall stack.

    Parameters
    ----------
    matrices : numpy.ndarray
        (n, rows, cols), rows >= cols.
    order : numpy.ndarray, optional
        (n, rows) row order to eliminate in (from :func:`pivot_order` on nearby matrices); by
        default LAPACK's partial pivoting is used for every matrix.
    """

    def __init__(self, matrices: np.ndarray, order: np.ndarray | None = None) -> None:
        self.shape = matrices.shape
        self.square = matrices.shape[-1] == matrices.shape[-2]
        if not self.square:
            self.normal = np.swapaxes(matrices, -1, -2) @ matrices
            self.matrices = matrices
            return
        self.matrices = matrices
        self.order = order
        self.lu: np.ndarray | None = None
        self.fallback = np.zeros(matrices.shape[0], dtype=bool)
        if order is not None and matrices.shape[-1] > 0:
            self._factor(order)

    def _factor(self, order: np.ndarray) -> None:
        """In-place LU without pivoting of the row-permuted stack, batch in the last axis."""
        size = self.shape[-1]
        a = np.take_along_axis(self.matrices, order[:, :, None], axis=1)
        col_scale = np.max(np.abs(a), axis=1)
        a = np.ascontiguousarray(np.moveaxis(a, 0, -1))
        for k in range(size - 1):
            a[k + 1:, k] /= a[k, k]
            a[k + 1:, k + 1:] -= a[k + 1:, k, None] * a[k, None, k + 1:]
        pivots = np.abs(a[np.arange(size), np.arange(size)]).T
        self.fallback = np.any(pivots < _PIVOT_FLOOR * col_scale, axis=1)
        self.lu = a

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """Solve ``J x = rhs`` for each matrix (least squares for a tall stack).

        Parameters
        ----------
        rhs : numpy.ndarray
            (n, rows).

        Returns
        -------
        numpy.ndarray
            (n, cols).
        """
        if not self.square:
            return np.linalg.solve(self.normal, (np.swapaxes(self.matrices, -1, -2)
                                                 @ rhs[..., None]))[..., 0]
        if self.lu is None:
            return np.linalg.solve(self.matrices, rhs[..., None])[..., 0]
        size = self.shape[-1]
        y = np.take_along_axis(rhs, self.order, axis=1).T.copy()
        for k in range(1, size):
            y[k] -= np.einsum("kn,kn->n", self.lu[k, :k], y[:k])
        for k in range(size - 1, -1, -1):
            y[k] -= np.einsum("kn,kn->n", self.lu[k, k + 1:], y[k + 1:])
            y[k] /= self.lu[k, k]
        x = y.T
        return self._patch(x, rhs, transpose=False)

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
        if self.lu is None:
            return np.linalg.solve(np.swapaxes(self.matrices, -1, -2), rhs[..., None])[..., 0]
        size = self.shape[-1]
        # P J = L U, so J^T = U^T L^T P and J^T x = b gives U^T w = b, L^T v = w, x = P^T v.
        w = rhs.T.copy()
        for k in range(size):
            w[k] -= np.einsum("kn,kn->n", self.lu[:k, k], w[:k])
            w[k] /= self.lu[k, k]
        for k in range(size - 2, -1, -1):
            w[k] -= np.einsum("kn,kn->n", self.lu[k + 1:, k], w[k + 1:])
        x = np.empty_like(rhs)
        np.put_along_axis(x, self.order, w.T, axis=1)
        return self._patch(x, rhs, transpose=True)

    def _patch(self, x: np.ndarray, rhs: np.ndarray, *, transpose: bool) -> np.ndarray:
        """Redo the matrices whose pivots were small with LAPACK's own pivoting."""
        if not np.any(self.fallback):
            return x
        bad = self.fallback
        mats = self.matrices[bad]
        if transpose:
            mats = np.swapaxes(mats, -1, -2)
        x[bad] = np.linalg.solve(mats, rhs[bad][..., None])[..., 0]
        return x
