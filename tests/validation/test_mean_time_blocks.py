"""The mean time since the revolution's start, taken a block of revolutions at a time."""

from __future__ import annotations

import numpy as np

from rigval.validation.model_run import _mean_time_in_revolution


def test_mean_time_in_revolution_equals_the_whole_grid_mean() -> None:
    # 700 revolutions of uneven length (more than two blocks), times far from zero
    rng = np.random.default_rng(8)
    starts = 1e4 + np.cumsum(rng.uniform(0.9, 1.1, 700))
    phase = np.sort(rng.uniform(0.0, 0.9, 1440))
    fine_times = starts[:, None] + phase[None, :] * rng.uniform(0.95, 1.05, (700, 1))
    expected = (fine_times - fine_times[:, :1]).mean(axis=0)
    got = _mean_time_in_revolution(fine_times)
    assert np.array_equal(got.view(np.uint64), expected.view(np.uint64))
