"""The pairwise-slope median selected pass by pass equals numpy.median of all the slopes.

The clock fit's Theil-Sen line takes the median of every pairwise slope of a segment's events
(an hour's 7000 events: 24.5 M slopes). Above ``SLOPES_HELD`` the median is selected without
holding them; the second method is numpy.median of the whole array, and they must agree exactly.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import rigval.processing.event_match as event_match
from rigval.processing.event_match import pairwise_slope_median


def _all_slopes(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    i, j = np.triu_indices(x.size, k=1)
    return (y[j] - y[i]) / (x[j] - x[i])


@pytest.mark.parametrize(("n", "seed"), [(400, 1), (401, 2), (1000, 3), (57, 4)])
def test_selected_median_equals_numpys_of_all_slopes(monkeypatch, n, seed):
    rng = np.random.default_rng(seed)
    x = np.sort(rng.uniform(0.0, 100.0, n)) + np.arange(n) * 1e-9
    y = 1.000021 * x + 3e-5 * rng.standard_normal(n)
    y[rng.integers(0, n, n // 20)] += 0.3  # strays, as the clock fit meets them
    expected = float(np.median(_all_slopes(x, y)))
    assert pairwise_slope_median(x, y) == expected  # held at once
    monkeypatch.setattr(event_match, "SLOPES_HELD", 500)  # selected pass by pass
    assert pairwise_slope_median(x, y) == expected


def test_ties_and_a_sample_far_from_the_median_are_still_exact(monkeypatch):
    # slopes of only three values: the bins from a sample of rows have few distinct edges and
    # the middle ranks fall in a bin of many equal slopes
    x = np.arange(300, dtype=float)
    y = np.where(np.arange(300) % 3 == 0, 2.0 * x, x)
    expected = float(np.median(_all_slopes(x, y)))
    monkeypatch.setattr(event_match, "SLOPES_HELD", 50)
    assert pairwise_slope_median(x, y) == expected
    # a sample of the first rows only: their slopes lie far from the median of all, so the
    # middle ranks fall in a full bin beyond the sampled edges
    y2 = x.copy()
    y2[:20] = -50.0 * x[:20]
    assert pairwise_slope_median(x, y2) == float(np.median(_all_slopes(x, y2)))


def test_a_nan_slope_gives_nan_as_numpy_does(monkeypatch):
    x = np.arange(200, dtype=float)
    y = x.copy()
    y[150] = np.nan
    monkeypatch.setattr(event_match, "SLOPES_HELD", 100)
    assert math.isnan(pairwise_slope_median(x, y))
    assert math.isnan(float(np.median(_all_slopes(x, y))))


@pytest.mark.parametrize("bins", [1, 2, 7])
def test_few_bins_keep_the_middle_ranks_exact(monkeypatch, bins):
    # coarse bins: the two middle ranks may lie in different bins, or beyond every edge
    rng = np.random.default_rng(bins)
    x = np.sort(rng.uniform(0.0, 10.0, 301))
    y = 0.5 * x + rng.standard_normal(301)
    monkeypatch.setattr(event_match, "SLOPES_HELD", 1000)
    monkeypatch.setattr(event_match, "SLOPE_BINS", bins)
    assert pairwise_slope_median(x, y) == float(np.median(_all_slopes(x, y)))
