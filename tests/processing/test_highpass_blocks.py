"""The amplifier high-pass undone a chunk at a time against the whole-record formula."""

from __future__ import annotations

import numpy as np
import pytest

from rigval.processing.accelerometer import _coefficients, apply_highpass, invert_highpass


@pytest.mark.parametrize("n", [1, 2, 1000, 2_500_003])  # the last crosses two chunk edges
def test_invert_highpass_equals_whole_record_cumsum(n: int) -> None:
    fs, corner, z0 = 5000.0, 0.1, 0.3
    rng = np.random.default_rng(n)
    y = np.sin(np.arange(n) / 300.0) + 0.01 * rng.normal(size=n)
    decay, c1 = _coefficients(fs, corner)
    increments = ((1.0 - decay - c1) * y[:-1] + c1 * y[1:]) / (1.0 - c1)
    z = np.empty(n)
    z[0] = z0
    z[1:] = np.cumsum(increments)
    z[1:] += z0
    np.testing.assert_array_equal(invert_highpass(y, fs, corner, z0), y + z)


def test_invert_highpass_undoes_the_highpass() -> None:
    fs = 5000.0
    x = np.sin(2 * np.pi * 2.0 * np.arange(2_200_000) / fs)
    y = apply_highpass(x, fs, 0.1, 0.0)
    np.testing.assert_allclose(invert_highpass(y, fs, 0.1, 0.0), x, atol=1e-9)


@pytest.mark.parametrize("n", [1, 2, 1000, 2_500_003])  # the last crosses two chunk edges
def test_invert_highpass_into_its_input_equals_a_new_output(n: int) -> None:
    # each chunk reads one sample past its outputs: written into y itself, the result must be
    # the one of a separate output array, bit for bit
    fs, corner, z0 = 5000.0, 0.1, -0.2
    y = np.cos(np.arange(n) / 170.0) + 0.01 * np.random.default_rng(n + 1).normal(size=n)
    expected = invert_highpass(y, fs, corner, z0)
    own = y.copy()
    result = invert_highpass(own, fs, corner, z0, out=own)
    assert result is own
    assert result.tobytes() == expected.tobytes()
