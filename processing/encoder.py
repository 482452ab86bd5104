"""Quadrature encoders: counter values or A/B lines to angle, with glitch and missed-count checks.

NI decoding (DAQmx ``CI.Encoder.DecodingType``): X1 counts one edge of A per line period (up when A
leads B), X2 both edges of A, X4 every edge of A and B; counts per revolution ``CPR = lines x {1,
2, 4}``. Counter channels log 32-bit counts sampled on the AI clock; they wrap, so
:func:`unwrap_counts` removes the wrap with modular differences. Offline, keep the cumulative count
(no Z reset) and reference it in software: :func:`revolution_check` compares the counts between
consecutive reference events with CPR and reports glitches (a few counts off) and gross errors;
:func:`counter_revolution_check` does so from a counter's values, making only the counts at the
events' samples (:func:`counts_at`), not the whole record's.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigval.acquisition.errors import ConfigError, DataError
from rigval.acquisition.sample_times import SampleTimes, times_of
from rigval.processing.arrays import BoolArray, FloatArray, IntArray, never_decreasing

#: NI's quadrature decoding types (edges of A and B counted per line period: 1, 2 or 4).
QuadratureDecoding = Literal["x1", "x2", "x4"]

__all__ = [
    "CountAngle",
    "QuadratureDecoding",
    "RevolutionCheck",
    "compact_counts",
    "count_angle",
    "counter_revolution_check",
    "counter_steps",
    "counts_at",
    "counts_to_angle",
    "decode_quadrature",
    "increasing_angle",
    "interp_minus",
    "remove_index_resets",
    "revolution_check",
    "unwrap_counts",
]

logger = logging.getLogger(__name__)


# Gray-code state s = 2 A + B runs 0 -> 1 -> 3 -> 2 -> 0 when B leads A (this table counts that
# direction as negative, i.e. A leading B is positive as in NI's convention).
_FORWARD = {(0, 2): 1, (2, 3): 1, (3, 1): 1, (1, 0): 1}


def _step_table() -> NDArray[np.int8]:
    table = np.zeros((4, 4), dtype=np.int8)
    for (old, new), step in _FORWARD.items():
        table[old, new] = step
        table[new, old] = -step
    return table


_STEP = _step_table()
_ILLEGAL = np.array([[(old ^ new) == 3 for new in range(4)] for old in range(4)])


def compact_counts(raw: ArrayLike) -> np.ndarray:
    """Return counter values as 32-bit integers when that holds every one exactly.

    A counter logged as float64 (DAQmx counter tasks) takes twice the memory its 32-bit
    values need. Values that are all whole numbers within ``[-2**31, 2**31)`` become int32,
    else within ``[0, 2**32)`` uint32; anything else (NaN, fractions, wider ranges) is
    returned unchanged, so no value is ever altered. The checks run a chunk at a time.

    Parameters
    ----------
    raw : array_like
        Counter values as read.

    Returns
    -------
    numpy.ndarray
        The same values, as int32 or uint32 where exact, else ``raw`` itself.
    """
    values = np.asarray(raw)
    if values.dtype.kind != "f" or values.size == 0:
        return values
    chunk = 1 << 20
    parts = [values[lo:lo + chunk] for lo in range(0, values.size, chunk)]
    if not all(np.all(np.isfinite(part)) and np.all(part == np.round(part)) for part in parts):
        return values
    low, high = float(np.min(values)), float(np.max(values))
    for dtype in (np.int32, np.uint32):
        info = np.iinfo(dtype)
        if low >= info.min and high <= info.max:
            return values.astype(dtype)
    return values


def _whole_counts(values: np.ndarray) -> None:
    """Raise unless float counter values are finite whole numbers (checked a chunk at a time)."""
    chunk = 1 << 20
    if values.dtype.kind == "f" and not all(
            np.all(np.isfinite(part)) and np.all(part == np.round(part))
            for part in (values[lo:lo + chunk] for lo in range(0, values.size, chunk))):
        raise DataError("encoder counts must be finite whole numbers",
                            hint="pass the raw counter channel, not a scaled one")


def _wrapped(steps: IntArray, bits: int) -> IntArray:
    """Return counter steps wrapped into ``[-2**(bits-1), 2**(bits-1))``, the counter's range."""
    modulus = np.int64(1) << bits
    half = modulus >> 1
    return (steps + half) % modulus - half


def _reloads(steps: IntArray, counts_per_rev: float) -> tuple[IntArray, IntArray]:
    """Return the steps of more than half a revolution (index reloads) and their whole turns."""
    at = np.flatnonzero(np.abs(steps) > counts_per_rev / 2)
    return at, np.round(steps[at] / counts_per_rev).astype(np.int64)


def counter_steps(values: ArrayLike, counts_per_rev: float | None = None,
                  bits: int = 32) -> IntArray:
    """Return the steps between consecutive counter values, as the cumulative counts take them.

    ``numpy.diff`` of :func:`unwrap_counts` of the values, with :func:`remove_index_resets`
    when ``counts_per_rev`` is given: each step wrapped into the counter's range, a step of
    more than half a revolution less its whole revolutions. A step needs only its two values,
    so a record's steps can be taken a piece at a time.

    Parameters
    ----------
    values : array_like of int
        Counter values as logged (a piece of a record).
    counts_per_rev : float, optional
        Counts per revolution: index reloads removed.
    bits : int, default 32
        Counter width in bits.

    Returns
    -------
    numpy.ndarray of int64
        ``values.size - 1`` steps, counts.
    """
    steps = _wrapped(np.diff(np.asarray(values).astype(np.int64)), bits)
    if counts_per_rev:
        at, turns = _reloads(steps, counts_per_rev)
        steps[at] -= turns * round(counts_per_rev)
    return steps


def _wraps(values: np.ndarray, bits: int) -> tuple[IntArray, IntArray]:
    """Return where a counter wraps and the cumulative correction (counts) from each wrap on.

    Each step wrapped into ``[-2**(bits-1), 2**(bits-1))``: the correction (a multiple of the
    modulus) is non-zero only at the counter's wraps; the steps are taken a chunk at a time.
    """
    chunk = 1 << 20
    wraps, corrections = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)]
    for lo in range(0, values.size - 1, chunk):
        steps = np.diff(values[lo:lo + chunk + 1].astype(np.int64))
        fix = _wrapped(steps, bits) - steps
        where = np.flatnonzero(fix)
        wraps.append(lo + 1 + where)
        corrections.append(fix[where])
    return np.concatenate(wraps), np.cumsum(np.concatenate(corrections))


def unwrap_counts(raw: ArrayLike, bits: int = 32, *, overwrite: bool = False) -> IntArray:
    """Return cumulative int64 counts from wrapping counter values.

    Parameters
    ----------
    raw : array_like of int
        Counter values as logged (unsigned or signed ``bits``-bit integers, or floats holding them).
    bits : int, default 32
        Counter width in bits.
    overwrite : bool, default False
        An int64 ``raw`` of the caller's own becomes the result (memory: no second whole-record
        array); other dtypes are copied as without it.

    Returns
    -------
    numpy.ndarray of int64
        ``raw[0] + cumsum(d)`` with ``d`` the step wrapped into ``[-2**(bits-1), 2**(bits-1))``.
    """
    values = np.asarray(raw)
    _whole_counts(values)
    counts = values if overwrite and _own_int64(values) else values.astype(np.int64)
    if counts.size < 2:
        return counts
    at, total = _wraps(counts, bits)
    if at.size > 1000:  # a fast-wrapping counter: one cumulative correction array
        correction = np.zeros(counts.size, dtype=np.int64)
        correction[at] = np.diff(total, prepend=0)
        counts += np.cumsum(correction, out=correction)
        return counts
    for k, start in enumerate(at):
        stop = at[k + 1] if k + 1 < at.size else counts.size
        counts[start:stop] += total[k]
    return counts



def _reloads_of(values: np.ndarray, counts_per_rev: float, bits: int
                ) -> tuple[IntArray, IntArray]:
    """Return where a counter reloads at its index and the cumulative correction from each on.

    :func:`remove_index_resets`' reloads and corrections (counts) of ``unwrap_counts(values,
    bits)``, whose steps are the values' steps wrapped into the counter's range: taken from
    the values a chunk at a time, without the unwrapped counts.
    """
    chunk = 1 << 20
    found, turns = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)]
    for lo in range(0, values.size - 1, chunk):
        steps = _wrapped(np.diff(values[lo:lo + chunk + 1].astype(np.int64)), bits)
        at, whole = _reloads(steps, counts_per_rev)
        found.append(lo + 1 + at)
        turns.append(whole)
    return np.concatenate(found), np.cumsum(-np.concatenate(turns) * round(counts_per_rev))


def _correction_at(starts: IntArray, cumulative: IntArray, index: IntArray) -> IntArray:
    """Return the cumulative correction (counts) in force at each sample of ``index``.

    ``cumulative[k]`` holds from sample ``starts[k]`` to the next start; none before the first.
    """
    if not starts.size:
        return np.zeros(index.shape, dtype=np.int64)
    applies = np.searchsorted(starts, index, side="right") - 1
    return np.where(applies >= 0, cumulative[np.maximum(applies, 0)], 0)


def counts_at(raw: ArrayLike, index: ArrayLike, *, counts_per_rev: float | None = None,
              bits: int = 32) -> IntArray:
    """Return the unwrapped counts of some samples, without the whole record's counts.

    ``unwrap_counts(raw, bits)[index]``, and with ``counts_per_rev``
    ``remove_index_resets(unwrap_counts(raw, bits), counts_per_rev)[0][index]``, bit for bit:
    the wraps and reloads are found a chunk at a time and their corrections added to the
    samples asked for (memory: no int64 copy of the record).

    Parameters
    ----------
    raw : array_like of int
        Counter values as logged (as :func:`unwrap_counts` takes them).
    index : array_like of int
        Sample indices (non-negative).
    counts_per_rev : float, optional
        Counts per revolution: index reloads removed.
    bits : int, default 32
        Counter width in bits.

    Returns
    -------
    numpy.ndarray of int64
        The counts, shaped like ``index``.

    Raises
    ------
    DataError
        When float counter values are not finite whole numbers.
    """
    values = np.asarray(raw)
    _whole_counts(values)
    index = np.asarray(index, dtype=np.intp)
    counts = values[index].astype(np.int64)
    counts += _correction_at(*_wraps(values, bits), index)
    if counts_per_rev:
        counts += _correction_at(*_reloads_of(values, counts_per_rev, bits), index)
    return counts


@dataclass(frozen=True)
class CountAngle:
    """A counter's unwrapped angle, made for the samples asked for (memory).

    ``angle[a:b]`` (any slice) and ``angle[i]`` equal those of
    ``counts_to_angle(unwrap_counts(raw), counts_per_rev, gear_ratio=..., direction=...)``
    bit for bit, without the whole-record counts or angle: the counter values stay as held
    (int32 on a stream) and each wrap's correction is added to the samples it applies to.
    Build it with :func:`count_angle`.

    Attributes
    ----------
    raw : numpy.ndarray
        The counter values as held.
    wraps, corrections : numpy.ndarray of int64
        First sample of each wrap's correction and the cumulative correction (counts) from it.
    counts_per_rev, gear_ratio, direction : float
        As in :func:`counts_to_angle`.
    """

    raw: np.ndarray = field(repr=False)
    wraps: IntArray
    corrections: IntArray
    counts_per_rev: float
    gear_ratio: float = 1.0
    direction: float = 1.0

    @property
    def size(self) -> int:
        """Number of samples."""
        return int(self.raw.size)

    @property
    def shape(self) -> tuple[int, ...]:
        """Shape of the record (one dimension)."""
        return (self.size,)

    def window(self, start: int, stop: int) -> CountAngle:
        """Return the angle of samples ``start ... stop - 1`` (as lazy as this one)."""
        before = self.corrections[np.searchsorted(self.wraps, start, side="right") - 1] \
            if self.wraps.size and self.wraps[0] <= start else np.int64(0)
        inside = (self.wraps > start) & (self.wraps < stop)
        return CountAngle(self.raw[start:stop],
                          np.concatenate(([0], self.wraps[inside] - start)).astype(np.int64),
                          np.concatenate(([before], self.corrections[inside])).astype(np.int64),
                          self.counts_per_rev, self.gear_ratio, self.direction)

    def __getitem__(self, key: int | slice) -> FloatArray | np.float64:
        """Return the angle (rad) of one sample or of a slice of samples."""
        if not isinstance(key, slice):
            index = range(self.size)[key]  # IndexError, negative indices as for arrays
            return self[index:index + 1][0]
        positions = np.arange(*key.indices(self.size))
        counts = self.raw[key].astype(np.int64)
        if self.wraps.size:
            applies = np.searchsorted(self.wraps, positions, side="right") - 1
            counts += np.where(applies >= 0, self.corrections[np.maximum(applies, 0)], 0)
        return counts_to_angle(counts, self.counts_per_rev, gear_ratio=self.gear_ratio,
                               direction=self.direction, overwrite=True)


def count_angle(raw: ArrayLike, counts_per_rev: float, *, gear_ratio: float = 1.0,
                direction: float = 1.0, bits: int = 32) -> CountAngle:
    """Return a counter's unwrapped angle that is computed stretch by stretch when asked.

    Parameters
    ----------
    raw : array_like of int
        Counter values as logged (as :func:`unwrap_counts` takes them).
    counts_per_rev, gear_ratio, direction : float
        As in :func:`counts_to_angle`.
    bits : int, default 32
        Counter width in bits.

    Raises
    ------
    DataError
        When float counter values are not finite whole numbers.
    ConfigError
        When ``counts_per_rev`` is not positive.
    """
    values = np.asarray(raw)
    _whole_counts(values)
    if counts_per_rev <= 0:
        raise ConfigError(f"counts per revolution must be positive, got {counts_per_rev}",
                          where={"key": "counts_per_rev"})
    at, total = _wraps(values, bits)
    return CountAngle(values, at, total, float(counts_per_rev), gear_ratio, direction)


#: Reloads above which :func:`remove_index_resets` corrects through one whole-record array
#: (fewer: range by range, without it).
_MANY_RESETS = 100_000


def _own_int64(values: np.ndarray) -> bool:
    """Return True when ``values`` is a writeable one-dimensional int64 array."""
    return values.dtype == np.int64 and values.ndim == 1 and values.flags.writeable


def remove_index_resets(counts: ArrayLike, counts_per_rev: float, *, overwrite: bool = False
                        ) -> tuple[IntArray, IntArray]:
    """Undo the counter reloads a Z index pulse causes (DAQmx ``CI.Encoder.ZIndexEnable``).

    With index reset enabled the count falls back to its initial value once per revolution, a
    step of about ``-CPR`` (``+CPR`` turning backwards) between two samples. Steps larger than half
    a revolution are taken as reloads and compensated by whole revolutions.

    Parameters
    ----------
    counts : array_like of int
        Unwrapped counts (:func:`unwrap_counts`).
    counts_per_rev : float
        Counts per revolution.
    overwrite : bool, default False
        An int64 ``counts`` of the caller's own becomes the result, corrected in place (memory).

    Returns
    -------
    cumulative : numpy.ndarray of int64
        Counts without the reloads.
    reset_index : numpy.ndarray of int64
        Sample indices right after each reload: the index pulse passed between that sample and
        the one before, at the cumulative count ``cumulative[i] - counts[i] + reload value``.
    """
    c = np.asarray(counts, dtype=np.int64)
    chunk = 1 << 20  # the steps a chunk at a time; reloads are few (memory)
    found, turns = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)]
    for lo in range(0, c.size - 1, chunk):
        at, whole = _reloads(np.diff(c[lo:lo + chunk + 1]), counts_per_rev)
        found.append(lo + 1 + at)
        turns.append(whole)
    resets = np.concatenate(found)
    fix = -np.concatenate(turns) * round(counts_per_rev)
    in_place = overwrite and _own_int64(c)
    if resets.size > _MANY_RESETS:  # a noisy counter: one cumulative correction array
        correction = np.zeros(c.size, dtype=np.int64)
        correction[resets] = fix
        np.cumsum(correction, out=correction)
        if in_place:
            c += correction
            return c, resets
        return c + correction, resets
    total = np.cumsum(fix)
    cumulative = c if in_place else c.copy()
    for k, start in enumerate(resets):  # each reload's correction holds until the next one
        stop = resets[k + 1] if k + 1 < resets.size else c.size
        cumulative[start:stop] += total[k]
    return cumulative, resets


def decode_quadrature(a: ArrayLike, b: ArrayLike, decoding: QuadratureDecoding = "x4",
                      ) -> tuple[IntArray, BoolArray]:
    """Decode sampled A/B lines into counts (for encoders logged as digital or analog lines).

    Parameters
    ----------
    a, b : array_like
        Line states per sample (bool, 0/1, or logic levels already thresholded).
    decoding : {"x1", "x2", "x4"}
        NI decoding type: counts per line period 1, 2 or 4.

    Returns
    -------
    counts : numpy.ndarray of int64
        Cumulative count per sample, starting at 0 (A leading B counts up).
    illegal : numpy.ndarray of bool
        True at samples where both lines changed at once (a state was missed: the count is
        ambiguous by +-2 X4 steps; the sample rate is too low for the shaft speed).
    """
    if decoding not in ("x1", "x2", "x4"):
        raise ConfigError(f"decoding must be x1, x2 or x4, got {decoding!r}",
                          where={"key": "decoding"})
    state = 2 * np.asarray(a, dtype=np.int8).astype(bool) + np.asarray(b, dtype=bool)
    state = state.astype(np.intp)
    old, new = state[:-1], state[1:]
    step = _STEP[old, new].astype(np.int64)
    illegal = np.concatenate(([False], _ILLEGAL[old, new]))
    if decoding != "x4":
        a_line = np.asarray(a, dtype=bool)
        a_edge = a_line[1:] != a_line[:-1]
        if decoding == "x2":
            step = np.where(a_edge, step, 0)
        else:
            # X1: one count per A period, on A rising when counting up, A falling when down.
            rising = a_line[1:] & ~a_line[:-1]
            falling = ~a_line[1:] & a_line[:-1]
            step = np.where((step > 0) & rising | (step < 0) & falling, step, 0)
    counts = np.concatenate(([0], np.cumsum(step)))
    return counts, illegal


def increasing_angle(time: ArrayLike | SampleTimes, angle: ArrayLike, *, use: str
                     ) -> tuple[FloatArray | SampleTimes, FloatArray]:
    """Return the finite samples of an angle record, checked to increase strictly.

    Parameters
    ----------
    time : array_like or SampleTimes
        Sample times in s (a lazy axis's are returned as they are when every angle is finite).
    angle : array_like
        Unwrapped angle in rad (e.g. phi_F); NaN samples (invalid, unfilterable) are dropped.
    use : str
        What the angle is needed for, named in the error (``"to locate events"``).

    Returns
    -------
    time, angle : numpy.ndarray
        The finite samples (s, rad).

    Raises
    ------
    DataError
        When fewer than 2 samples are left or the angle does not increase strictly (a standstill
        or a reversal).
    """
    t = times_of(time)
    phi = np.asarray(angle, dtype=np.float64)
    finite = np.isfinite(phi)
    if not finite.all():  # no copies of a record that is finite throughout
        t, phi = t[finite], phi[finite]
    if phi.size < 2 or not never_decreasing(phi, strictly=True):
        raise DataError(f"the angle must increase strictly {use}",
                        hint="use the smoothed drive angle (excitation.drive_angle) and split the "
                             "record at standstills or reversals")
    return t, phi


#: Samples per block of :func:`interp_minus`.
_INTERP_BLOCK = 1 << 16


def interp_minus(x: ArrayLike, xp: FloatArray | SampleTimes, fp: FloatArray | SampleTimes,
                 shift: float = 0.0) -> FloatArray:
    """Return ``np.interp(x, xp, fp - shift)`` without a whole-record copy.

    Neither the shifted copy ``fp - shift`` nor the one ``np.interp`` makes of a read-only
    ``xp`` or ``fp`` (a Dataset's time index is read-only) is made: the samples are taken a
    block at a time, shifted there, with the targets that fall in the block. Every value is the
    one ``np.interp`` gives on the whole shifted copy (it reads the two samples around a target
    alone), so a record's time axis and a channel's input delay stand for the channel's times
    (memory).

    Parameters
    ----------
    x : array_like
        Points to evaluate at, any shape (sorted when not in increasing order).
    xp : numpy.ndarray or SampleTimes
        Increasing sample points (a lazy time axis's computed a block at a time).
    fp : numpy.ndarray or SampleTimes
        Sample values, as many as ``xp`` (a lazy time axis's, as ``xp``).
    shift : float, default 0
        Subtracted from ``fp``.

    Returns
    -------
    numpy.ndarray
        The interpolated values, the shape of ``x``.
    """
    targets = np.asarray(x, dtype=np.float64)
    flat = targets.ravel()
    order = None if bool(np.all(flat[1:] >= flat[:-1])) else np.argsort(flat, kind="stable")
    ordered = flat if order is None else flat[order]
    # targets from one block start (included) to the next: their bracketing samples lie in the
    # block and one sample either side
    cuts = np.searchsorted(ordered, xp[_INTERP_BLOCK::_INTERP_BLOCK], side="left")
    values = np.empty(flat.size)
    for block, (a, b) in enumerate(zip(np.r_[0, cuts], np.r_[cuts, flat.size], strict=True)):
        if b > a:
            lo = max(block * _INTERP_BLOCK - 1, 0)
            hi = min((block + 1) * _INTERP_BLOCK + 1, xp.size)
            samples = fp[lo:hi] - shift if shift else fp[lo:hi]
            values[a:b] = np.interp(ordered[a:b], xp[lo:hi], samples)
    if order is not None:
        values[order] = values.copy()
    return values.reshape(targets.shape)


def _as_float_in_place(counts: np.ndarray) -> FloatArray:
    """Return int64 counts converted to float64 in their own memory, a chunk at a time.

    The values are those of ``counts.astype(np.float64)``; each chunk is cast through a
    buffer of its own (NumPy copies an overlapping source), so nothing whole-record is added.
    """
    values = counts.view(np.float64)
    chunk = 1 << 20
    for lo in range(0, counts.size, chunk):
        values[lo:lo + chunk] = counts[lo:lo + chunk]
    return values


def counts_to_angle(counts: ArrayLike, counts_per_rev: float, *, reference_count: float = 0.0,
                    gear_ratio: float = 1.0, direction: float = 1.0, overwrite: bool = False
                    ) -> FloatArray:
    """Return the shaft angle ``2 pi direction (counts - reference) / (CPR gear_ratio)`` in rad.

    Parameters
    ----------
    counts : array_like
        Cumulative (unwrapped) counts.
    counts_per_rev : float
        Counts per encoder revolution (lines x decoding factor; 8192 for 2048 lines X4).
    reference_count : float, default 0
        Count at which the angle is zero (e.g. interpolated at the optical reference).
    gear_ratio : float, default 1
        Encoder revolutions per shaft revolution.
    direction : float, default 1
        +1 or -1 to make the model's positive sense positive.
    overwrite : bool, default False
        Int64 ``counts`` of the caller's own become the angle in their own memory (memory: no
        second whole-record array; ``counts`` must not be used afterwards); else a new array.
    """
    if counts_per_rev <= 0:
        raise ConfigError(f"counts per revolution must be positive, got {counts_per_rev}",
                          where={"key": "counts_per_rev"})
    given = np.asarray(counts)
    # a new array, or the counts' own memory: worked on in place (memory)
    c = _as_float_in_place(given) if overwrite and _own_int64(given) and \
        given.flags.c_contiguous else given.astype(np.float64)
    c -= reference_count
    c *= direction * 2.0 * np.pi
    c /= counts_per_rev * gear_ratio
    return c if c.ndim else c[()]


@dataclass(frozen=True)
class RevolutionCheck:
    """Counts between consecutive reference events compared with the counts per revolution.

    Attributes
    ----------
    event_times : numpy.ndarray
        Times of the reference events in s.
    residual : numpy.ndarray
        ``counts between event k and k+1`` minus the expected count (len n_events - 1).
    glitch : numpy.ndarray of bool
        ``1 < |residual| <= tolerance``: electrical glitches or missed counts (a residual of
        +-1 is quantisation: the counts at the events are interpolated between samples).
    gross : numpy.ndarray of bool
        ``|residual| > tolerance``: wrong or missing reference event, gap or reversal.
    """

    event_times: FloatArray
    residual: FloatArray
    glitch: BoolArray
    gross: BoolArray


def _bracketing_samples(time: FloatArray | SampleTimes, event_times: FloatArray
                        ) -> tuple[IntArray, IntArray, FloatArray]:
    """Return the samples ``i``, ``j`` around each event and the event's fraction of the way.

    The count at an event is interpolated linearly between its samples ``i`` and ``j``
    (``numpy.interp`` of the counts at the events, clamped at the record's ends), so only
    those samples' counts are needed.
    """
    i = np.clip(np.searchsorted(time, event_times, side="right") - 1, 0,
                max(time.size - 2, 0))
    j = np.minimum(i + 1, time.size - 1)
    span = np.where(j > i, time[j] - time[i], 1.0)
    fraction = np.clip((event_times - time[i]) / span, 0.0, 1.0)
    return i, j, fraction


def _checked(event_times: FloatArray, before: np.ndarray, after: np.ndarray,
             fraction: FloatArray, counts_per_rev: float, events_per_rev: int,
             tolerance: float) -> RevolutionCheck:
    """Return the revolution check of the counts at the samples before and after each event."""
    # integer counts are converted at these samples only
    at_event = before + fraction * (after.astype(np.float64) - before)
    residual = np.round(np.diff(at_event) - counts_per_rev / events_per_rev)
    magnitude = np.abs(residual)
    return RevolutionCheck(event_times, residual, (magnitude > 1) & (magnitude <= tolerance),
                           magnitude > tolerance)


def revolution_check(time: ArrayLike, counts: ArrayLike, event_times: ArrayLike,
                     counts_per_rev: float, *, events_per_rev: int = 1,
                     tolerance: float = 4.0) -> RevolutionCheck:
    """Compare the counts between consecutive reference events with CPR / events_per_rev.

    The count at each event is interpolated linearly between the samples around it and the
    difference is rounded to whole counts, so quantisation alone leaves residuals of 0 or +-1;
    larger ones are glitches (up to ``tolerance``) or gross errors.

    Parameters
    ----------
    time : array_like
        Sample times in s (same clock as ``event_times``).
    counts : array_like
        Unwrapped counts per sample.
    event_times : array_like
        Reference event times in s (optical pulses or index pulses), increasing.
    counts_per_rev : float
        Expected counts per revolution.
    events_per_rev : int, default 1
        Reference events per revolution of the encoder shaft.
    tolerance : float, default 4
        Largest |residual| in counts still called a glitch rather than a gross error.

    Returns
    -------
    RevolutionCheck
        Residual per interval with glitch and gross flags.
    """
    c = np.asarray(counts)  # integer or float: only the samples around events are converted
    events = np.asarray(event_times, dtype=np.float64)
    i, j, fraction = _bracketing_samples(times_of(time), events)
    return _checked(events, c[i], c[j], fraction, counts_per_rev, events_per_rev, tolerance)


def counter_revolution_check(time: ArrayLike, raw: ArrayLike, event_times: ArrayLike,
                             counts_per_rev: float, *, direction: float = 1.0,
                             index_reset: bool = False, events_per_rev: int = 1,
                             tolerance: float = 4.0, bits: int = 32) -> RevolutionCheck:
    """Revolution check of a counter channel, from its counts at the events' samples alone.

    :func:`revolution_check` of ``unwrap_counts(raw, bits)`` (index reloads removed with
    :func:`remove_index_resets` when ``index_reset``, times ``direction``), bit for bit, but
    only the counts at the two samples around each event are made (:func:`counts_at`), not
    the whole record's int64 counts (memory: 8 bytes a sample).

    Parameters
    ----------
    time : array_like
        Sample times in s (same clock as ``event_times``).
    raw : array_like of int
        Counter values as logged (as :func:`unwrap_counts` takes them).
    event_times : array_like
        Reference event times in s, increasing.
    counts_per_rev : float
        Counts per revolution.
    direction : float, default 1
        Factor on the counts (-1 for an encoder counting down).
    index_reset : bool, default False
        The counter reloads at the Z index.
    events_per_rev, tolerance
        As in :func:`revolution_check`.
    bits : int, default 32
        Counter width in bits.

    Returns
    -------
    RevolutionCheck
        As :func:`revolution_check` returns it.

    Raises
    ------
    DataError
        When float counter values are not finite whole numbers.
    """
    events = np.asarray(event_times, dtype=np.float64)
    i, j, fraction = _bracketing_samples(times_of(time), events)  # a lazy axis's few times
    counts = counts_at(raw, np.concatenate((i, j)), bits=bits,
                       counts_per_rev=counts_per_rev if index_reset else None)
    if direction == -1.0:
        np.negative(counts, out=counts)
    elif direction != 1.0:
        counts = counts * direction
    return _checked(events, counts[:i.size], counts[i.size:], fraction, counts_per_rev,
                    events_per_rev, tolerance)
