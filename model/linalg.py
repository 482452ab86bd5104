"""Batched small dense linear algebra for the loop Jacobian ``J_u`` (one matrix per time step).

:class:`BatchLU` factorises a stack of square matrices once and serves solves with ``J`` and with
``J^T``: positions (Newton), velocities, accelerations and multipliers all reuse one factorisation.
The elimination runs across the whole batch at once (batch in the last, contiguous axis). Rows are
first put in a fixed order that suits the mechanism (partial pivoting on a representative matrix);
a step whose pivot in that order is smaller than ``threshold`` times the largest candidate in its
column swaps rows as partial pivoting would (threshold pivoting), so the factorisation is as stable
as LAPACK's while rows move only where they must.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

__all__ = ["BatchLU", "static_row_order"]

#: Threshold pivoting: keep the pivot in place unless it is below this fraction of the column max.
_THRESHOLD = 0.1


def static_row_order(matrix: np.ndarray) -> np.ndarray:
    """Rows of ``matrix`` in the order partial pivoting takes them as pivots, (m,) int."""
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
        self.n = n
        self.size = cols
        self.square = rows == cols
        if not self.square:
            stack = np.moveaxis(matrices, -1, 0)
            self.stack = stack
            self.normal = np.swapaxes(stack, -1, -2) @ stack
            return
        order = np.arange(rows) if row_order is None else np.asarray(row_order)
        self.column_norms = np.sum(np.abs(matrices), axis=0)
        a = matrices[order]
        perm: np.ndarray | None = None
        for k in range(cols - 1):
            column = np.abs(a[k:, k])
            swap = np.flatnonzero(column[0] < _THRESHOLD * np.max(column, axis=0))
            if swap.size:
                if perm is None:
                    perm = np.repeat(order[:, None], n, axis=1)
                target = k + np.argmax(column[:, swap], axis=0)
                own = a[k][:, swap].copy()
                a[k][:, swap] = a[target, :, swap].T
                a[target, :, swap] = own.T
                own_perm = perm[k, swap].copy()
                perm[k, swap] = perm[target, swap]
                perm[target, swap] = own_perm
            a[k + 1:, k] /= a[k, k]
            a[k + 1:, k + 1:] -= a[k + 1:, k, None] * a[k, None, k + 1:]
        self.lu = a
        self.order = order
        self.perm = perm

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
        y = self._rows_first(rhs)
        if self.perm is None:
            y = y[self.order]
        else:
            y = np.take_along_axis(y, self.perm.reshape(self.perm.shape[0],
                                                        *([1] * (y.ndim - 2)), -1), axis=0)
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

    def condition(self) -> np.ndarray:
        """Condition number of each matrix with its columns scaled to unit length, (n,).

        The 1-norm condition of the column-equilibrated square matrix, exact (from the explicit
        inverse); for a tall stack the 2-norm condition from singular values.
        """
        if not self.square:
            scaled = self.stack / np.linalg.norm(self.stack, axis=-2, keepdims=True)
            sv = np.linalg.svd(scaled, compute_uv=False)
            with np.errstate(divide="ignore"):
                return np.where(sv[:, -1] > 0, sv[:, 0] / sv[:, -1], np.inf)
        n = self.lu.shape[-1]
        identity = np.ascontiguousarray(np.broadcast_to(np.eye(self.size), (n, self.size,
                                                                          self.size)))
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            inverse = self.solve(identity)
            scaled = np.abs(inverse) * self.column_norms.T[:, :, None]
            cond = np.max(np.sum(scaled, axis=1), axis=1)
        return np.where(np.isfinite(cond), cond, np.inf)

    @staticmethod
    def _rows_first(rhs: np.ndarray) -> np.ndarray:
        return np.ascontiguousarray(np.moveaxis(rhs, 0, -1))

    @staticmethod
    def _rows_last(values: np.ndarray) -> np.ndarray:
        return np.moveaxis(values, -1, 0)
