"""The fine grid's reference times found a block of revolutions at a time (memory).

:func:`rigval.validation.pipeline._grid` no longer makes the whole fine grid's angles: its
times, chosen grid and angles over one revolution must equal those of the whole grid bit for
bit (``numpy.interp`` of the grid angles on phi_F), with or without the encoder's delay.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from rigval.processing.angle import cycle_grid
from rigval.processing.stream_alignment import MainAngle
from rigval.validation import pipeline
from rigval.validation.model_run import FINE_FACTOR

FS = 500.0


@pytest.mark.parametrize("delay_s", [0.0, 2.5e-4])
def test_fine_grid_times_in_blocks_equal_the_whole_grid(delay_s) -> None:
    # 700 revolutions of uneven speed (more than two blocks of 256)
    axis = 7.0 + np.arange(0.0, 600.0, 1 / FS)
    axis.setflags(write=False)                        # as a Dataset's time index
    phi = 0.4 + 2 * np.pi * (1.1 * (axis - 7.0) + 0.0002 * (axis - 7.0) ** 2) \
        + 0.05 * np.sin(axis)
    main = MainAngle(axis, phi, 0.0, delay_s)
    scene = SimpleNamespace(angle=SimpleNamespace(points_per_revolution=18, min_cycles=10))
    grid, fine_times = pipeline._grid(scene, main, pipeline._revolutions(scene, main))

    turns, fine_grid = cycle_grid(phi[0], phi[-1], 18 * FINE_FACTOR)
    assert turns.size > 600
    expected = np.interp(fine_grid, phi, axis - delay_s)
    assert np.array_equal(grid.turns, turns)
    assert np.array_equal(fine_times.view(np.uint64), expected.view(np.uint64))
    assert np.array_equal(grid.times, expected[:, ::FINE_FACTOR])
    assert np.array_equal(grid.fine_angle, fine_grid[0] - fine_grid[0, 0])
    duration = np.interp(2 * np.pi * (turns[-1] + 1), phi, axis - delay_s) - expected[0, 0]
    assert grid.speed_rev_s == turns.size / duration

