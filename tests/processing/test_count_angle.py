"""A counter's angle made stretch by stretch equals the whole-record angle of its counts.

:class:`~rigval.processing.encoder.CountAngle` adds each wrap's correction to the samples asked
for; any slice, step, window and single sample must equal
``counts_to_angle(unwrap_counts(raw))`` bit for bit, across wraps and chunk edges.
"""

from __future__ import annotations

import numpy as np
import pytest

from rigval.processing.encoder import count_angle, counts_to_angle, unwrap_counts

CPR = 8192.0


def _raw(kind: str) -> np.ndarray:
    """Counts through several wraps of a 32-bit counter, as uint32 or int32 values."""
    rng = np.random.default_rng(7)
    steps = rng.integers(0, 2_000_000, 3_000_000).astype(np.int64)
    steps[1_500_000:1_500_100] *= -1
    cumulative = np.cumsum(steps) + 4_000_000_000
    if kind == "uint32":
        return (cumulative % (1 << 32)).astype(np.uint32)
    return ((cumulative + (1 << 31)) % (1 << 32) - (1 << 31)).astype(np.int32)


@pytest.mark.parametrize("kind", ["uint32", "int32"])
@pytest.mark.parametrize("direction", [1.0, -1.0])
def test_slices_windows_and_samples_equal_the_whole_record(kind: str, direction: float) -> None:
    raw = _raw(kind)
    whole = counts_to_angle(unwrap_counts(raw), CPR, gear_ratio=2.0, direction=direction)
    angle = count_angle(raw, CPR, gear_ratio=2.0, direction=direction)
    assert angle.wraps.size > 10 and angle.shape == whole.shape
    for key in (slice(None), slice(0, 1_048_577), slice(1_048_570, 2_500_003),
                slice(None, None, 137), slice(5, 2_999_990, 1001), slice(2_999_000, None)):
        assert np.array_equal(angle[key], whole[key]), key
    for i in (0, 1, 1_234_567, -1):
        assert angle[i] == whole[i]
    for start, stop in ((0, 3_000_000), (777, 1_600_000), (1_499_000, 2_999_999)):
        part = angle.window(start, stop)
        assert np.array_equal(part[:], whole[start:stop])
        assert np.array_equal(part[10:50_000:7], whole[start:stop][10:50_000:7])
        inner = part.window(100, 200_000)
        assert np.array_equal(inner[:], whole[start + 100:start + 200_000])


def test_float_counts_that_are_not_whole_are_refused() -> None:
    with pytest.raises(ValueError, match="finite whole numbers"):
        count_angle(np.array([1.0, 2.5, 3.0]), CPR)


def test_a_counter_that_never_wraps() -> None:
    raw = np.arange(100_000, dtype=np.int32) * 3 - 1000
    angle = count_angle(raw, CPR)
    assert angle.wraps.size == 0
    whole = counts_to_angle(unwrap_counts(raw), CPR)
    assert np.array_equal(angle[:], whole) and angle[-1] == whole[-1]
    assert np.array_equal(angle.window(10, 5000)[::3], whole[10:5000:3])
