"""Piecewise-uniform time axes: blocks of equally spaced samples separated by gaps.

A device that restarts its task (a Wi-Fi dropout on a WLS-9163) continues its file with a new start
time. The samples of one block are ``t = t_start + i * dt``; the blocks follow each other in file
order. A :class:`TimeBase` turns that description into the stream's time axis (seconds since the
first sample), its segment index, and index ranges for a time window, without materialising more
than the samples asked for.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["Block", "TimeBase", "exact_increment"]

#: Rates a rounded ``wf_increment`` is checked against besides integer Hz: NI delta-sigma master
#: rates divided by n (NI 9237: 50 kS/s, NI 9234: 51.2 kS/s, 12.8 MHz / 256 = 50 kS/s).
_MASTER_RATES = (50_000.0, 51_200.0)


@dataclass(frozen=True)
class Block:
    """Equally spaced samples ``t = t_start + i * dt`` for ``i`` in ``0 ... n - 1``.

    Parameters
    ----------
    first : int
        Index of the block's first sample in the channel.
    n : int
        Number of samples.
    t_start : float
        Time of the first sample in s since the stream's first sample.
    dt : float
        Sample interval in s.
    """

    first: int
    n: int
    t_start: float
    dt: float


class TimeBase:
    """The time axis of a stream as a list of :class:`Block` objects.

    Parameters
    ----------
    blocks : list of Block
        In sample order; ``blocks[k + 1].first == blocks[k].first + blocks[k].n``.
    scale : float
        The times of every block are multiplied by ``scale`` ...
    shifts : sequence of float, optional
        ... and block ``k``'s shifted by ``shifts[k]`` (s): a device's samples on another
        clock, ``scale * t + shifts[k]`` (:meth:`on_clock`). Default: the times as they are.
    """

    def __init__(self, blocks: list[Block], scale: float = 1.0,
                 shifts: Sequence[float] | None = None) -> None:
        self.blocks = [b for b in blocks if b.n > 0] or blocks[:1]
        self.length = sum(b.n for b in self.blocks)
        self.scale = float(scale)
        self.shifts = None if shifts is None else np.array(shifts, dtype=np.float64)
        if self.shifts is not None and self.shifts.shape != (len(self.blocks),):
            raise ValueError(f"{self.shifts.size} clock shifts for {len(self.blocks)} blocks")

    def on_clock(self, scale: float, shifts: Sequence[float]) -> TimeBase:
        """Return these samples' times on another clock: ``scale * t + shifts[k]`` in block k.

        The times are those of ``scale * times() + shifts[segment]`` computed whole, bit for
        bit (one multiplication and one addition per sample, in that order). A block's shift
        may be NaN where no clock maps it (its times are then NaN).
        """
        return TimeBase(self.blocks, scale, shifts)

    @property
    def clocked(self) -> bool:
        """Whether the times are mapped onto another clock (:meth:`on_clock`)."""
        return self.shifts is not None

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, TimeBase):
            return NotImplemented
        if self.blocks != other.blocks or self.scale != other.scale:
            return False
        if self.shifts is None or other.shifts is None:
            return self.shifts is None and other.shifts is None
        return bool(np.array_equal(self.shifts, other.shifts, equal_nan=True))

    __hash__ = None  # type: ignore[assignment]  # equal by value, not hashable

    @property
    def dt(self) -> float:
        """Sample interval of the first block, s (on the device's own clock)."""
        return self.blocks[0].dt

    def overlaps(self, start: int, stop: int) -> list[tuple[int, Block, int, int]]:
        """Return ``(k, block, lo, hi)`` for the blocks meeting samples ``start ... stop - 1``.

        ``k`` is the block's index (the samples' ``segment``), ``lo ... hi - 1`` its samples
        in the window.
        """
        return [(k, b, max(start, b.first), min(stop, b.first + b.n))
                for k, b in enumerate(self.blocks)
                if max(start, b.first) < min(stop, b.first + b.n)]

    def times(self, start: int = 0, stop: int | None = None) -> np.ndarray:
        """Return the times in s of samples ``start`` to ``stop - 1`` (float64).

        Several blocks' times are written into one output, a block at a time (memory: the
        window's array and one block's, not the blocks' and their concatenation).
        """
        stop = self.length if stop is None else min(stop, self.length)
        parts = self.overlaps(start, stop)
        if len(parts) == 1:
            return self._block_times(*parts[0])
        out = np.empty(max(stop - start, 0), dtype=np.float64)
        for k, block, lo, hi in parts:
            out[lo - start:hi - start] = self._block_times(k, block, lo, hi)
        return out

    def _block_times(self, k: int, block: Block, lo: int, hi: int) -> np.ndarray:
        """Return the times of samples ``lo ... hi - 1`` of block ``k`` (s)."""
        part = np.arange(lo - block.first, hi - block.first, dtype=np.float64)
        part *= block.dt  # in place: one allocation per block (page faults dominate)
        part += block.t_start
        if self.shifts is not None:
            part *= self.scale
            part += self.shifts[k]
        return part

    def segments(self, start: int = 0, stop: int | None = None) -> np.ndarray:
        """Return the block index (``segment``) of samples ``start`` to ``stop - 1``."""
        stop = self.length if stop is None else min(stop, self.length)
        out = np.empty(max(stop - start, 0), dtype=np.int32)
        for k, _, lo, hi in self.overlaps(start, stop):
            out[lo - start:hi - start] = k
        return out

    def index_range(self, t_from: float | None, t_to: float | None) -> tuple[int, int]:
        """Return ``(start, stop)`` of the samples with ``t_from <= t <= t_to`` (None: open end).

        Times on the device's own clock (a file's read window; not :meth:`on_clock`'s).
        """
        start, stop = self.length, 0
        for block in self.blocks:
            lo, hi = 0, block.n
            if t_from is not None:
                lo = max(lo, math.ceil((t_from - block.t_start) / block.dt - 1e-9))
            if t_to is not None:
                hi = min(hi, math.floor((t_to - block.t_start) / block.dt + 1e-9) + 1)
            if lo < hi:
                start = min(start, block.first + lo)
                stop = max(stop, block.first + hi)
        return (start, stop) if start < stop else (0, 0)


def exact_increment(dt: float, decimals: int | None = None) -> float | None:
    """Return the exact sample interval behind a rounded ``wf_increment`` or ``Delta_X``.

    Some writers store the interval with 6 significant digits (TDMS ``wf_increment`` 1.04167e-05 s
    for 96 kHz; 33 us error after 1e6 samples), LVM files with 6 decimals (``Delta_X`` 0.000977 for
    1/1024 s, -0.045 %). If ``1 / fs`` rounds to ``dt`` for an integer rate ``fs`` in Hz or for
    ``master / n`` of an NI delta-sigma master rate, while ``1 / fs`` itself differs from ``dt``,
    that interval is returned.

    Parameters
    ----------
    dt : float
        Interval as stored, s.
    decimals : int, optional
        The writer rounds to this many decimals (LVM: 6); default: 6 significant digits.

    Returns
    -------
    float or None
        The exact interval, or None when ``dt`` shows no sign of rounding.
    """

    def rounded(value: float) -> float:
        return round(value, decimals) if decimals is not None else float(f"{value:.6g}")

    if not (math.isfinite(dt) and dt > 0) or rounded(dt) != dt:
        return None
    candidates = [round(1.0 / dt)]
    candidates += [master / round(master * dt) for master in _MASTER_RATES
                   if round(master * dt) >= 1]
    for fs in candidates:
        if fs <= 0:
            continue
        exact = 1.0 / fs
        if exact != dt and rounded(exact) == dt:
            return exact
    return None
