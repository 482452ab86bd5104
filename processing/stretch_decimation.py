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

from rigval.acquisition.errors import DataError
from rigval.acquisition.sample_times import SampleTimes, indexed_time_coordinate
from rigval.processing.arrays import FloatArray, IntArray
from rigval.processing.blocked_decimation import EDGE, decimate_stretch
from rigval.processing.filters import contiguous_runs

__all__ = ["EDGE", "UPPER_HZ", "decimated_runs", "diagnosis_signal"]

logger = logging.getLogger(__name__)

#: Upper end of the band the diagnosis analyses by default (Hz): the first modes of a machine
#: of this size (docs/diagnosis.md); the kept signal's rate is at least four times it.
UPPER_HZ = 40.0
#: Samples whose stretch numbers are counted at a time (:func:`_stretch_numbers`).
_COUNT_BLOCK = 1 << 20


def decimated_runs(values: FloatArray, run: np.ndarray, q: int) -> tuple[FloatArray, np.ndarray,
                                                                          np.ndarray]:
    """Decimate a signal by ``q`` stretch by stretch (zero-phase FIR), as one array.

    Returns the decimated values, their stretch index and the index of the original sample
    each decimated sample sits at (stretches too short to filter are dropped). The filter
    (:func:`scipy.signal.decimate`, 20 q + 1 taps) sees each stretch less its straight line
    from end to end, added back after, and the :data:`EDGE` output samples at each end, where
    the filter reaches past the stretch, are dropped: a large signal cut at a gap would
    otherwise ring there (:func:`~rigval.processing.blocked_decimation.decimate_stretch`).
    """
    out, runs, index = [], [], []
    for k in np.unique(run):
        where = np.flatnonzero(run == k)
        if where.size < 64 * q:
            continue
        y, taken = _decimated(values[where], q)
        taken = where[taken]
        out.append(y)
        runs.append(np.full(y.size, k))
        index.append(taken)
    if not out:
        raise DataError("no gap-free stretch is long enough for the residual spectra",
                        hint="record longer or with fewer gaps")
    return np.concatenate(out), np.concatenate(runs), np.concatenate(index)


def _decimated(x: FloatArray, q: int) -> tuple[FloatArray, IntArray]:
    """Return a stretch decimated by ``q`` less its ends and the index of each output sample."""
    if q > 1:
        return decimate_stretch(x, q)
    return x, np.arange(x.size)


def _stretch_numbers(starts: IntArray, usable: np.ndarray, segment: np.ndarray) -> IntArray:
    """Return the stretch number at each of ``starts`` (sample indices, increasing).

    A new stretch begins at every sample after a segment change or next to an unusable sample:
    the number is the count of such beginnings up to the sample, counted a block at a time.
    """
    numbers = np.zeros(starts.size, np.int64)
    count = 0
    for lo in range(1, usable.size, _COUNT_BLOCK):
        hi = min(lo + _COUNT_BLOCK, usable.size)
        step = (segment[lo:hi] != segment[lo - 1:hi - 1]) | ~usable[lo:hi] | ~usable[lo - 1:hi - 1]
        total = np.cumsum(step)
        inside = (starts >= lo) & (starts < hi)
        numbers[inside] = count + total[starts[inside] - lo]
        count += int(total[-1])
    return numbers


def diagnosis_signal(time: FloatArray | SampleTimes, values: FloatArray, segment: np.ndarray,
                     valid: np.ndarray, fs: float, upper_hz: float = UPPER_HZ, *,
                     delay_s: float = 0.0) -> xr.Dataset:
    """Return a measured signal decimated for the diagnosis, its gap-free stretches numbered.

    Parameters
    ----------
    time : numpy.ndarray or SampleTimes
        Reference time of each sample, s (the module delay ``delay_s`` not yet removed); read at
        the kept samples alone.
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
    delay_s : float, default 0
        The module's input delay, s: taken off the kept samples' times.

    Returns
    -------
    xarray.Dataset
        ``measured`` (signal units) and ``stretch`` (int) over ``time`` (s), attribute ``fs``
        (Hz); empty when no stretch is long enough.

    Notes
    -----
    The stretches are the runs of usable samples within one segment, each decimated as
    :func:`decimated_runs` does, without copying the channel (memory).
    """
    usable = valid & np.isfinite(values)
    q = max(int(fs // (4.0 * upper_hz)), 1)
    stretches = [(a, b) for a, b in contiguous_runs(values.size, segment, usable)
                 if b - a >= 64 * q]
    numbers = _stretch_numbers(np.array([a for a, _ in stretches], np.int64), usable, segment)
    out, runs, index = [np.zeros(0)], [np.zeros(0, np.int32)], [np.zeros(0, np.int64)]
    for (a, b), k in zip(stretches, numbers, strict=True):
        y, taken = _decimated(values[a:b], q)
        out.append(y)
        runs.append(np.full(y.size, k, np.int32))
        index.append(taken + a)
    at = np.concatenate(index)
    return xr.Dataset({"measured": ("time", np.concatenate(out)),
                       "stretch": ("time", np.concatenate(runs))},
                      coords=indexed_time_coordinate(time[at] - delay_s, {"units": "s"}),
                      attrs={"fs": fs / q})  # the times indexed as they are (no copy)
