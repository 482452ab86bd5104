"""The pulse-width step search against a median per split (the direct O(n^2) sums)."""

from __future__ import annotations

import numpy as np
import pytest

from rigval.processing import health_events


def _direct(d: np.ndarray) -> tuple[np.ndarray, int]:
    """Each split's cost from the medians of both sides, and the first split within rounding."""
    splits = np.arange(health_events._WIDTH_SIDE, d.size - health_events._WIDTH_SIDE + 1)
    cost = np.array([np.abs(d[:k] - np.median(d[:k])).sum()
                     + np.abs(d[k:] - np.median(d[k:])).sum() for k in splits])
    return cost, int(splits[np.argmax(cost <= cost.min() + health_events._TIE * cost.max())])


@pytest.mark.parametrize("seed", range(6))
def test_deviation_sums_equal_a_median_per_prefix(seed: int) -> None:
    rng = np.random.default_rng(seed)
    d = 1.0 + 0.02 * rng.normal(size=int(rng.integers(1, 300)))
    sums = health_events._deviation_sums(d)
    expected = [0.0] + [np.abs(d[:k] - np.median(d[:k])).sum() for k in range(1, d.size + 1)]
    np.testing.assert_allclose(sums, expected, rtol=1e-12, atol=1e-13)


@pytest.mark.parametrize("case", ["noise", "step", "ties", "constant", "alternating"])
def test_step_split_is_the_first_best_of_the_direct_costs(case: str) -> None:
    rng = np.random.default_rng(7)
    d = 1.0 + 0.01 * rng.normal(size=257)
    if case == "step":
        d[150:] += 0.1
    elif case == "ties":
        d = np.round(d, 2)  # many equal widths: flat stretches of the cost
    elif case == "constant":
        d = np.ones(40)
    elif case == "alternating":
        d = 1.0 + 0.05 * (np.arange(120) % 2)
    _, k_direct = _direct(d)
    k, jump, se = health_events._step(d)
    assert k == k_direct
    assert jump == np.median(d[k:]) - np.median(d[:k])
    if case == "step":
        assert k == 150 and jump == pytest.approx(0.1, abs=0.01) and se < 0.01
