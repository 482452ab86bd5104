"""np.interp's values on a read-only record without the whole copy np.interp makes of it.

A Dataset's time index is read-only, and ``np.interp`` copies a read-only ``xp`` or ``fp``
whole before interpolating (137 MiB for a 1 h time axis at 5 kHz): :func:`interp_minus` with no
shift takes the samples a block at a time, with the values ``np.interp`` gives, bit for bit.
"""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from rigval.processing import encoder
from rigval.processing.angle import zero_at_reference
from rigval.processing.encoder import interp_minus


def _read_only(values: np.ndarray) -> np.ndarray:
    values.setflags(write=False)
    return values


@pytest.mark.parametrize("block", [3, 1 << 16])
def test_interp_without_shift_equals_np_interp_bit_for_bit(block, monkeypatch) -> None:
    monkeypatch.setattr(encoder, "_INTERP_BLOCK", block)
    rng = np.random.default_rng(11)
    xp = _read_only(np.cumsum(rng.uniform(0.1, 1.0, 200_001)))
    fp = _read_only(np.cumsum(rng.uniform(-1.0, 1.0, xp.size)))
    fp_with_zeros = _read_only(np.where(rng.uniform(size=xp.size) < 0.1, -0.0, fp))
    cases = [np.sort(rng.uniform(xp[0] - 5, xp[-1] + 5, 5_000)),   # beyond both ends too
             rng.uniform(xp[0], xp[-1], (40, 70)),                  # unsorted, 2-D
             xp[::3].copy(),                                        # at the samples
             np.array([xp[-1]]), np.array([xp[0] - 1.0])]
    for values in (fp, fp_with_zeros):
        for x in cases:
            expected = np.interp(x, xp, values)
            got = interp_minus(x, xp, values)
            assert got.shape == expected.shape
            assert np.array_equal(got.view(np.uint64), expected.view(np.uint64))


def test_few_points_on_a_read_only_record_copy_no_whole_record() -> None:
    n = 2_000_000                                                   # 15.3 MiB a record
    t = _read_only(np.arange(n) / 5000.0)
    phi = _read_only(2 * np.pi * t + 0.1 * np.sin(t))
    events = np.arange(1.0, 399.0) + 0.3
    tracemalloc.start()
    try:
        np.interp(events, t, phi)
        copied = tracemalloc.get_traced_memory()[1]
        tracemalloc.reset_peak()
        interp_minus(events, t, phi)
        blocks = tracemalloc.get_traced_memory()[1]
        tracemalloc.reset_peak()
        zero_at_reference(t, phi, events)
        zeroing = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert copied > t.nbytes                                        # np.interp copies t whole
    assert blocks < t.nbytes / 10
    assert zeroing < t.nbytes / 2                                   # its finite mask alone
