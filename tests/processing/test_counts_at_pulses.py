"""The encoder's revolution check from the counts at the pulses alone (phi_F's memory).

:func:`counts_at` equals the whole record's unwrapped counts at the samples asked for, and
:func:`counter_revolution_check` equals :func:`revolution_check` of those whole counts bit for
bit, flagging the same faults: a missed count, extra counts, a reversal.
"""

from __future__ import annotations

import numpy as np
import pytest

from rigval.acquisition.errors import DataError
from rigval.processing.encoder import (
    counter_revolution_check,
    counts_at,
    remove_index_resets,
    revolution_check,
    unwrap_counts,
)

FS = 1000.0
CPR = 4096


def _counter(cumulative: np.ndarray, bits: int = 32) -> np.ndarray:
    """The values a ``bits``-bit counter logs for cumulative counts (uint32 for 32 bits)."""
    wrapped = cumulative % (1 << bits)
    return wrapped.astype(np.uint32) if bits == 32 else wrapped


@pytest.mark.parametrize("bits", [32, 12])  # 12 bits: thousands of wraps (a fast counter)
def test_counts_at_equal_the_whole_unwrapped_counts(bits) -> None:
    # ~2.2 million samples: the wraps are found over more than one chunk of 2**20
    rng = np.random.default_rng(5)
    steps = rng.integers(-3, 40, 2_200_000)
    cumulative = np.cumsum(steps) + (1 << 32) - 5_000_000            # wraps at 2**32 too
    raw = _counter(cumulative, bits)
    index = np.concatenate(([0, 1, raw.size - 1, 1 << 20, (1 << 20) + 1],
                            rng.integers(0, raw.size, 5000)))
    expected = unwrap_counts(raw, bits)[index]
    got = counts_at(raw, index, bits=bits)
    assert got.dtype == np.int64
    np.testing.assert_array_equal(got, expected)
    np.testing.assert_array_equal(got - got[0], cumulative[index] - cumulative[0])
    as_float = counts_at(raw.astype(np.float64), index, bits=bits)    # DAQmx float counters
    np.testing.assert_array_equal(as_float, expected)


def test_counts_at_remove_index_reloads_as_the_whole_record() -> None:
    t = np.arange(0.0, 700.0, 1 / FS)                                # 700 000 samples
    cumulative = np.floor(t * 1.7 * CPR).astype(np.int64) + 100
    reloaded = (cumulative - 100) % CPR                              # Z reloads at each index
    index = np.arange(0, t.size, 997)
    expected = remove_index_resets(unwrap_counts(reloaded), CPR)[0][index]
    got = counts_at(reloaded, index, counts_per_rev=CPR)
    np.testing.assert_array_equal(got, expected)
    np.testing.assert_array_equal(got - got[0], cumulative[index] - cumulative[0])


def test_counts_at_refuses_scaled_counts() -> None:
    with pytest.raises(DataError, match="whole numbers"):
        counts_at(np.array([0.0, 1.5, 3.0]), [0, 1])


def _faulty_record() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Ten revolutions at 1 rev/s, with missed counts, extra counts and a reversal.

    Returns the times, the cumulative counts and the pulse times (one a revolution, between
    samples).
    """
    t = np.arange(0.0, 10.5, 1 / FS)
    counts = np.floor(t * CPR).astype(np.int64)
    counts[t > 2.5] -= 2                                    # two missed counts in interval 1
    counts[t > 4.5] += 3                                    # three extra counts in interval 3
    back = np.flatnonzero((t > 6.3) & (t < 6.5))            # a reversal in interval 5
    counts[back] = counts[back[0]] - 20 * np.arange(back.size)
    after = back[-1] + 1
    counts[after:] += counts[back[-1]] - counts[after] + 4
    return t, counts, np.arange(1.0, 10.0) + 0.37 / FS


def _assert_same(got, expected) -> None:
    for name in ("event_times", "residual", "glitch", "gross"):
        a, b = getattr(got, name), getattr(expected, name)
        assert a.dtype == b.dtype and np.array_equal(a.view(np.uint8), b.view(np.uint8)), name


@pytest.mark.parametrize("direction", [1, -1])
def test_counter_check_flags_the_faults_as_the_whole_counts(direction) -> None:
    t, counts, pulses = _faulty_record()
    raw = _counter(direction * counts)                      # an encoder counting down: -1
    expected = revolution_check(t, direction * unwrap_counts(raw), pulses, CPR)
    got = counter_revolution_check(t, raw, pulses, CPR, direction=float(direction))
    _assert_same(got, expected)
    # the faults themselves: the missed and the extra counts are glitches, the reversal gross
    assert np.flatnonzero(got.glitch).tolist() == [1, 3]
    assert np.flatnonzero(got.gross).tolist() == [5]


def test_counter_check_scaled_by_a_direction_factor_equals_the_whole_counts() -> None:
    t, counts, pulses = _faulty_record()
    raw = _counter(counts)
    expected = revolution_check(t, unwrap_counts(raw) * 2.0, pulses, 2.0 * CPR)
    _assert_same(counter_revolution_check(t, raw, pulses, 2.0 * CPR, direction=2.0), expected)


def test_counter_check_with_index_reloads_equals_the_whole_counts() -> None:
    t, counts, pulses = _faulty_record()
    reloaded = (-counts - (-counts).min()) % CPR            # counting down, reloaded at Z
    expected = revolution_check(t, -remove_index_resets(unwrap_counts(reloaded), CPR)[0],
                                pulses, CPR)
    got = counter_revolution_check(t, reloaded, pulses, CPR, direction=-1.0, index_reset=True)
    _assert_same(got, expected)
    assert np.flatnonzero(got.glitch).tolist() == [1, 3]
    assert got.gross[5]
