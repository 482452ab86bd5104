"""Decimation of a signal stretch by stretch between its gaps (zero-phase FIR).

The validation pipeline keeps each compared signal, before its comparison's low-pass, at an
analysis rate of about ``4 UPPER_HZ`` (:func:`diagnosis_signal`, a run's
``/diagnosis/<comparison>``), so that the residual spectra of docs/diagnosis.md see the modes
the angle domain's low-pass hides, at a small cost in memory and file size.
"""

from __future__ import annotations

import logging

import numpy as np
import xarray as xr
from scipy.signal import decimate

from rigval.acquisition.errors import DataError
from rigval.processing.arrays import FloatArray

__all__ = ["EDGE", "UPPER_HZ", "decimated_runs", "diagnosis_signal"]

logger = logging.getLogger(__name__)

#: Upper end of the band the diagnosis analyses by default (Hz): the first modes of a machine
#: of this size (docs/diagnosis.md); the kept signal's rate is at least four times it.
UPPER_HZ = 40.0


#: Output samples dropped at each end of a decimated stretch (the FIR's half length).
EDGE = 10


def decimated_runs(values: FloatArray, run: np.ndarray, q: int) -> tuple[FloatArray, np.ndarray,
                                                                          np.ndarray]:
    """Decimate a signal by ``q`` stretch by stretch (zero-phase FIR), as one array.

    Returns the decimated values, their stretch index and the index of the original sample
    each decimated sample sits at (stretches too short to filter are dropped). The filter
    (:func:`scipy.signal.decimate`, 20 q + 1 taps) sees each stretch less its straight line
    from end to end, added back after, and the :data:`EDGE` output samples at each end, where
    the filter reaches past the stretch, are dropped: a large signal cut at a gap would
    otherwise ring there.
    """
    out, runs, index = [], [], []
    for k in np.unique(run):
        where = np.flatnonzero(run == k)
        if where.size < 64 * q:
            continue
        x = values[where]
        if q > 1:
            line = np.linspace(x[0], x[-1], x.size)
            y = (decimate(x - line, q, ftype="fir", zero_phase=True) + line[::q])[EDGE:-EDGE]
            taken = where[::q][EDGE:EDGE + y.size]
        else:
            y, taken = x, where
        out.append(y)
        runs.append(np.full(y.size, k))
        index.append(taken)
    if not out:
        raise DataError("no gap-free stretch is long enough for the residual spectra",
                        hint="record longer or with fewer gaps")
    return np.concatenate(out), np.concatenate(runs), np.concatenate(index)


def diagnosis_signal(time: FloatArray, values: FloatArray, segment: np.ndarray,
                     valid: np.ndarray, fs: float, upper_hz: float = UPPER_HZ) -> xr.Dataset:
    """Return a measured signal decimated for the diagnosis, its gap-free stretches numbered.

    Parameters
    ----------
    time : numpy.ndarray
        Reference time of each sample's input (module delay removed), s.
    values : numpy.ndarray
        Measured values (before any low-pass), signal units.
    segment : numpy.ndarray
        Gap-free segment of each sample.
    valid : numpy.ndarray of bool
        Samples to use.
    fs : float
        Sample rate in Hz.
    upper_hz : float, default :data:`UPPER_HZ`
        Highest frequency kept (Hz): the rate becomes at least ``4 upper_hz``.

    Returns
    -------
    xarray.Dataset
        ``measured`` (signal units) and ``stretch`` (int) over ``time`` (s), attribute ``fs``
        (Hz); empty when no stretch is long enough.
    """
    usable = valid & np.isfinite(values)
    step = np.concatenate([[False], (np.diff(segment) != 0) | ~usable[1:] | ~usable[:-1]])
    stretch = np.cumsum(step)
    where = np.flatnonzero(usable)
    q = max(int(fs // (4.0 * upper_hz)), 1)
    try:
        out, runs, index = decimated_runs(values[where], stretch[where], q)
    except DataError:
        out, runs, index = np.zeros(0), np.zeros(0, int), np.zeros(0, int)
    return xr.Dataset({"measured": ("time", out), "stretch": ("time", runs.astype(np.int32))},
                      coords={"time": ("time", time[where][index], {"units": "s"})},
                      attrs={"fs": fs / q})
