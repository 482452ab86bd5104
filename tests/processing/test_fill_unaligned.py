"""Placeholder times of unaligned samples, filled run by run, against the whole-record interp."""

from __future__ import annotations

import numpy as np
import pytest

from rigval.processing.clock_fit import _fill_unaligned


def _whole_record(ref_time: np.ndarray, own_time: np.ndarray, lost: np.ndarray) -> np.ndarray:
    """The placeholder as an interp over every aligned sample of the record (the expectation)."""
    good = np.flatnonzero(~lost)
    offset = (np.interp(np.arange(ref_time.size), good, ref_time[good] - own_time[good])
              if good.size else np.zeros(ref_time.size))
    return np.where(lost, own_time + offset, ref_time)


@pytest.mark.parametrize("runs", [
    [(300, 700)],                       # inside
    [(0, 120)],                         # at the start
    [(880, 1000)],                      # at the end
    [(0, 5), (6, 9), (500, 501), (999, 1000)],  # one aligned sample between runs, single ones
    [(0, 1000)],                        # nothing aligned
    [(10, 400), (401, 990)],
])
def test_fill_equals_whole_record_interp(runs: list[tuple[int, int]]) -> None:
    rng = np.random.default_rng(3)
    own = np.cumsum(rng.uniform(0.9e-3, 1.1e-3, 1000))
    ref = 0.7 + (1 + 40e-6) * own + np.repeat(rng.normal(0, 1e-3, 4), 250)  # offset per segment
    lost = np.zeros(own.size, dtype=bool)
    for a, b in runs:
        lost[a:b] = True
    ref[lost] = np.nan
    expected = _whole_record(ref, own, lost)
    _fill_unaligned(ref, own, lost)
    np.testing.assert_array_equal(ref, expected)
