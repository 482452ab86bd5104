"""The truth grid of a long record, computed front to back in pieces and kept in temporary files.

A record of hours holds about 14 million 1 kHz truth points: every quantity the channels are
sampled from is 115 MB as float64 at 4 h, 13 of them 1.5 GB. :func:`store_truth` computes the
grid :data:`~rigval.sample_data.simulate.TRUTH_POINTS` points at a time (the model, the rod's
bending stress, the frame mode and the charge amplifiers' high-pass, the filters' states carried
from piece to piece: :mod:`~rigval.sample_data.carried_filters`) and appends each quantity to a
raw float64 file; :meth:`TruthStore.window` reads back the points a sampling window needs, the
very points :meth:`~rigval.sample_data.truth.TruthGrid.window` of the whole grid would give.
The files are read with ``numpy.fromfile`` (page cache, not the process's memory), never mapped.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rigval.processing.arrays import FloatArray
from rigval.sample_data.carried_filters import CarriedHighPass
from rigval.sample_data.rig import RigDraw
from rigval.sample_data.streams import SAMPLED_QUANTITIES, SampledTruth
from rigval.sample_data.truth import WINDOW_MARGIN, TruthGrid, frame_filter

__all__ = ["TruthStore", "UniformGrid", "store_truth"]

logger = logging.getLogger(__name__)

#: The truth of one piece of the grid: uniform true times (s) -> the grid's quantities there
#: (the model with the departures that act point by point).
PieceTruth = Callable[[FloatArray], TruthGrid]
#: The accelerometers and the model quantity each one sees before its filters.
_ACCELEROMETERS = {"acc1": "acc_P1_x", "acc2": "acc_P2_x", "acc3": "frame_force_P3_x"}


@dataclass(frozen=True)
class UniformGrid:
    """A uniform grid of true time, ``t[k] = t0 + k / fs`` for ``k < n``.

    Parameters
    ----------
    t0 : float
        First time in s.
    fs : float
        Rate in Hz.
    n : int
        Number of points.
    """

    t0: float
    fs: float
    n: int

    def times(self, i0: int, i1: int) -> FloatArray:
        """Return ``t[i0:i1]`` in s, bit for bit the whole grid's ``t0 + arange(n) / fs``."""
        return self.t0 + np.arange(i0, i1) / self.fs

    def index(self, t: float) -> int:
        """Return the first index whose time is >= ``t`` (``numpy.searchsorted`` on the grid)."""
        guess = int(np.clip(np.ceil((t - self.t0) * self.fs) - 2, 0, self.n))
        local = self.times(guess, min(guess + 5, self.n))
        return guess + int(np.searchsorted(local, t))

    @property
    def rate(self) -> float:
        """The rate :attr:`TruthGrid.fs` gives for the whole grid (Hz)."""
        span = self.times(self.n - 1, self.n)[0] - self.t0
        return float((self.n - 1) / span)


class TruthStore:
    """Sampled truth of a long record in raw float64 files, one per quantity.

    Parameters
    ----------
    grid : UniformGrid
        The truth grid.
    files : dict of (str, str) to Path
        ``(group, name)`` -> file; group ``"grid"``, ``"physical"`` or ``"volts"`` as in
        :class:`~rigval.sample_data.streams.SampledTruth`.
    """

    def __init__(self, grid: UniformGrid, files: dict[tuple[str, str], Path]) -> None:
        self.grid, self.files = grid, files

    def window(self, t_from: float, t_to: float) -> SampledTruth:
        """Return the truth from ``t_from`` to ``t_to`` (s), read from the files.

        :data:`~rigval.sample_data.truth.WINDOW_MARGIN` points more either side, as
        :meth:`~rigval.sample_data.truth.TruthGrid.window` keeps.
        """
        i0 = max(self.grid.index(t_from) - WINDOW_MARGIN, 0)
        i1 = min(self.grid.index(t_to) + WINDOW_MARGIN, self.grid.n)
        t = self.grid.times(i0, i1)
        groups: dict[str, dict[str, FloatArray]] = {"grid": {}, "physical": {}, "volts": {}}
        for (group, name), path in self.files.items():
            groups[group][name] = np.fromfile(path, dtype=np.float64, count=i1 - i0,
                                              offset=8 * i0)
        return SampledTruth(*(TruthGrid(t, groups[g]) for g in ("grid", "physical", "volts")))


def store_truth(piece_truth: PieceTruth, draw: RigDraw, grid: UniformGrid, points: int,
                scratch: Path) -> TruthStore:
    """Compute the sampled truth ``points`` grid points at a time into files in ``scratch``.

    Parameters
    ----------
    piece_truth : callable
        Times (s) -> the grid's quantities there; called on consecutive pieces of the grid.
    draw : RigDraw
        The run's draws (the frame mode and the accelerometers).
    grid : UniformGrid
        The whole truth grid.
    points : int
        Grid points per piece.
    scratch : Path
        Folder for the files (removed by the caller).

    Returns
    -------
    TruthStore
        The truth, a window at a time. Each filter runs over the whole grid as one call would
        (the frame mode with the whole grid's time step, the high-pass with its rate).
    """
    dt = float(grid.times(1, 2)[0] - grid.t0)
    frame = frame_filter(dt, **draw.frame)
    highpass = {name: CarriedHighPass(grid.rate, draw.accelerometers[name].highpass_hz)
                for name in _ACCELEROMETERS}
    files: dict[tuple[str, str], Path] = {}
    for i in range(0, grid.n, points):
        part = piece_truth(grid.times(i, min(i + points, grid.n)))
        values = {name: v for name, v in part.values.items() if name in SAMPLED_QUANTITIES}
        physical = {name: values[quantity] for name, quantity in _ACCELEROMETERS.items()}
        physical["acc3"] = frame.step(physical["acc3"])
        volts = {name: highpass[name].step(draw.accelerometers[name].voltage_unfiltered(v))
                 for name, v in physical.items()}
        for group, arrays in (("grid", values), ("physical", physical), ("volts", volts)):
            for name, array in arrays.items():
                path = files.setdefault((group, name), scratch / f"{group}.{name}.f64")
                with path.open("ab") as file:
                    array.astype(np.float64, copy=False).tofile(file)
    logger.debug("truth grid of %d points stored in %d files", grid.n, len(files))
    return TruthStore(grid, files)
