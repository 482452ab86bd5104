"""Counter work done in the caller's own int64 array equals the same work on a copy.

``overwrite=True`` of :func:`unwrap_counts`, :func:`remove_index_resets` and
:func:`counts_to_angle` saves a whole-record array; the values must be those of the copying
path bit for bit, over several chunks and through wraps and index reloads.
"""

from __future__ import annotations

import numpy as np
import pytest

from rigval.processing.encoder import counts_to_angle, remove_index_resets, unwrap_counts

N = (1 << 20) * 2 + 12_345  # three chunks, the last one short
CPR = 8192


def _cumulative(seed: int) -> np.ndarray:
    """Counts turning forward, with a backward stretch and counts far from zero."""
    rng = np.random.default_rng(seed)
    steps = rng.integers(3, 6, N).astype(np.int64)
    steps[500_000:510_000] *= -1
    return np.cumsum(steps) - 3_000_000_000


def test_unwrap_in_place_equals_the_copy() -> None:
    raw = (_cumulative(1) % (1 << 32)).astype(np.int64)  # wraps at 2**32 like a u32 counter
    expected = unwrap_counts(raw.copy())
    own = raw.copy()
    found = unwrap_counts(own, overwrite=True)
    assert found is own and np.array_equal(found, expected)
    assert np.array_equal(expected - expected[0], _cumulative(1) - _cumulative(1)[0])


@pytest.mark.parametrize("resets", [10, 150_000])  # range by range, one correction array
def test_index_resets_removed_in_place_equal_the_copy(resets: int) -> None:
    counts = _cumulative(2)
    at = np.sort(np.random.default_rng(3).choice(np.arange(1, N), resets, replace=False))
    reloaded = counts.copy()
    for k, start in enumerate(at):  # each reload takes one turn off from there on
        stop = at[k + 1] if k + 1 < at.size else N
        reloaded[start:stop] -= (k + 1) * CPR
    expected, expected_at = remove_index_resets(reloaded.copy(), CPR)
    own = reloaded.copy()
    found, found_at = remove_index_resets(own, CPR, overwrite=True)
    assert found is own and np.array_equal(found, expected)
    assert np.array_equal(found_at, expected_at) and np.array_equal(found, counts)


@pytest.mark.parametrize("direction", [1.0, -1.0])
def test_angle_in_the_counts_memory_equals_a_new_array(direction: float) -> None:
    counts = _cumulative(4)
    expected = counts_to_angle(counts, CPR, reference_count=12.5, gear_ratio=2.0,
                               direction=direction)
    own = counts.copy()
    found = counts_to_angle(own, CPR, reference_count=12.5, gear_ratio=2.0,
                            direction=direction, overwrite=True)
    assert found.dtype == np.float64 and np.shares_memory(found, own)
    assert np.array_equal(found, expected)
    # counts of another dtype are never overwritten
    small = counts.astype(np.float64)
    assert not np.shares_memory(counts_to_angle(small, CPR, overwrite=True), small)
