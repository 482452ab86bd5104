"""The shared array checks and helpers against their whole-array definitions."""

from __future__ import annotations

import numpy as np
import pytest

from rigval.processing import arrays
from rigval.processing.arrays import distinct_in_runs, never_decreasing, writable_float64


@pytest.mark.parametrize("chunk", [1 << 20, 7])
def test_never_decreasing_is_the_whole_arrays_steps(chunk, monkeypatch):
    monkeypatch.setattr(arrays, "_ORDER_CHUNK", chunk)
    rng = np.random.default_rng(5)
    rising = np.cumsum(rng.integers(0, 3, 50)).astype(float)  # ties: never decreasing only
    cases = [rising, rising + np.arange(50) * 1e-3, rising[::-1], np.zeros(0), np.ones(1)]
    dip = rising + np.arange(50) * 1e-3
    dip[chunk if chunk < 50 else 20] -= 10.0  # a step down at a chunk's first sample
    cases.append(dip)
    for x in cases:
        steps = np.diff(x)
        assert never_decreasing(x) == bool(np.all(steps >= 0))
        assert never_decreasing(x, strictly=True) == bool(np.all(steps > 0))


def test_writable_float64_only_for_arrays_that_may_take_a_result():
    frozen = np.ones(3)
    frozen.flags.writeable = False
    assert writable_float64(np.ones(3))
    assert not writable_float64(frozen)
    assert not writable_float64(np.ones(3, np.float32))
    assert not writable_float64(np.float64(1.0)) and not writable_float64(np.array(1.0))
    assert not writable_float64([1.0, 2.0])


def test_distinct_in_runs_is_numpys_unique():
    rng = np.random.default_rng(8)
    runs = np.repeat(rng.integers(-3, 6, 40), rng.integers(1, 500, 40)).astype(np.int32)
    for values in (runs, np.array([3, 3, 1, 1, 3, 0], np.int32), np.zeros(0, np.int32),
                   np.array([7]), np.arange(10)[::-1]):
        got = distinct_in_runs(values)
        assert np.array_equal(got, np.unique(values)) and got.dtype == values.dtype
