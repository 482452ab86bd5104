"""The low-level noise of a pulse channel, found a chunk at a time, against whole-record arrays."""

from __future__ import annotations

import numpy as np
import pytest

from rigval.processing import pulses


@pytest.mark.parametrize("quantised", [True, False])
@pytest.mark.parametrize("chunk", [1 << 20, 997])
def test_low_level_noise_equals_whole_record(chunk: int, quantised: bool,
                                             monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(pulses, "_LEVEL_CHUNK", chunk)
    rng = np.random.default_rng(3)
    n = 50_000
    x = np.where((np.arange(n) // 500) % 5 == 0, 5.0, 0.0) + rng.normal(0, 0.01, n)
    if quantised:  # as digitised: ties in both medians
        x = np.round(x, 3)
    ok = rng.random(n) > 0.01
    low, high = 0.0, 5.0
    flat = ok & (np.abs(x - low) < 0.1 * (high - low))
    quiet = x[flat]
    expected = 1.4826 * float(np.median(np.abs(quiet - np.median(quiet))))
    assert pulses._low_level_noise(x, ok, low, high) == expected
    assert pulses._low_level_noise(x, np.zeros(n, bool), low, high) == 0.0
