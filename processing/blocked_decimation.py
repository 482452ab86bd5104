"""Zero-phase FIR decimation of one long stretch, block by block, less its ends.

:func:`decimate_stretch` gives the samples of
``(scipy.signal.decimate(x - line, q, ftype="fir", zero_phase=True) + line[::q])[EDGE:-EDGE]``
(``line`` the straight line from the stretch's first to its last sample, as
:func:`numpy.linspace` makes it) bit for bit, while holding only a block of the stretch at a
time: every kept output sample's filter (20 q + 1 taps, centred) lies inside the stretch, so each
block is decimated with the :data:`EDGE` output samples of context on either side that its filter
reaches, and its outputs are the whole stretch's, summed in the same order. The line is rebuilt
per block with :func:`numpy.linspace`'s own arithmetic (:func:`line_values`).
"""

from __future__ import annotations

import logging

import numpy as np

from rigval.processing.arrays import FloatArray, IntArray
from rigval.processing.scipy_signal import decimate

__all__ = ["BLOCK", "EDGE", "decimate_stretch", "line_values"]

logger = logging.getLogger(__name__)

#: Output samples dropped at each end of a decimated stretch (the FIR's half length, 10 q input
#: samples).
EDGE = 10
#: Input samples decimated at a time (8 MiB of float64).
BLOCK = 1 << 20


def line_values(first: float, last: float, n: int, index: IntArray) -> FloatArray:
    """Return ``numpy.linspace(first, last, n)[index]`` without making the whole line.

    The same operations as :func:`numpy.linspace` (``i * step + first``, or ``i / (n - 1) *
    delta + first`` when the step underflows to 0; the last sample set to ``last``), so the
    values are bit-identical. ``n`` must be at least 2; values in the signal's unit.
    """
    div = n - 1
    delta = np.subtract(last, first, dtype=np.float64)
    step = delta / div
    y = index.astype(np.float64)
    if step == 0:
        y /= div
        y *= delta
    else:
        y *= step
    y += first
    y[index == n - 1] = last
    return y


def decimate_stretch(x: FloatArray, q: int, block: int = BLOCK) -> tuple[FloatArray, IntArray]:
    """Decimate one gap-free stretch by ``q`` (zero-phase FIR), its straight line kept aside.

    Parameters
    ----------
    x : numpy.ndarray
        The stretch's samples (float64, signal units; a view is enough), at least
        ``(2 EDGE + 1) q`` of them.
    q : int
        Decimation factor (>= 2).
    block : int, default :data:`BLOCK`
        Input samples decimated at a time (memory), at least ``q``.

    Returns
    -------
    y : numpy.ndarray
        The decimated samples but :data:`EDGE` at each end (signal units), equal to the whole
        stretch's :func:`scipy.signal.decimate` less its line, plus the line.
    taken : numpy.ndarray of int
        Index into ``x`` of the sample each output sits at (``q`` apart).
    """
    n = x.size
    n_out = -(-n // q)
    first, last = x[0], x[-1]
    per = max(block // q, 1)
    parts = []
    for m0 in range(EDGE, n_out - EDGE, per):
        m1 = min(m0 + per, n_out - EDGE)
        a, b = (m0 - EDGE) * q, (m1 - 1 + EDGE) * q + 1
        part = x[a:b] - line_values(first, last, n, np.arange(a, b))
        y = decimate(part, q, ftype="fir", zero_phase=True)[EDGE:EDGE + m1 - m0]
        y += line_values(first, last, n, np.arange(m0, m1) * q)
        parts.append(y)
    y = np.concatenate(parts) if parts else np.zeros(0)
    return y, np.arange(EDGE, EDGE + y.size) * q
