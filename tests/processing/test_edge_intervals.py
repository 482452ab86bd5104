"""Honest clock intervals for first-order pulse edges (docs/processing.md, "Edge shapes").

The hard case of the clock fit: an optical sensor rising with a first-order time constant of a
third of a sample period, sampled at 1612.9 S/s without an anti-alias filter, with a drive period
0.002 sample from a whole number of samples, so the sampling phase beats slowly and every edge's
mid-level crossing is off by the same 80-150 us. The truth (the sensor's onset, the simulated
clock) comes from :mod:`rigval.sample_data.edge_runs`, not from the fit.
"""

from __future__ import annotations

import numpy as np
import pytest

from rigval.processing.clock_fit import estimate_clock, quantisation_limit
from rigval.processing.pulses import detect_edges, time_edges
from rigval.sample_data.edge_runs import STAMP_WINDOW_S, edge_run

FS = 50_000.0 / 31


def _fit(run, times, bounds):
    clock = estimate_clock(run.ref, times, coarse_offset_s=run.coarse_offset_s,
                           max_offset_error_s=STAMP_WINDOW_S, timing_bound_s=bounds,
                           min_events=3)
    return (abs(clock.offsets_s[0] - run.offset_s), clock.offsets_u95_s[0],
            abs(clock.drift - run.drift), clock.drift_u95)


@pytest.mark.parametrize(("seed", "rise", "period", "n", "noise"), [
    (1, 1 / 3, 1613.002, 20, 1e-3),   # the reported case: tau T/3, period near 1613 samples
    (2, 1 / 3, 645.0, 60, 0.0),        # exactly a whole number of samples, no noise
    (3, 2.0, 800.37, 40, 5e-3),       # slow rise, far from a whole number
    (4, 0.05, 700.001, 30, 1e-3),     # nearly sample-switched
])
def test_first_order_edges_intervals_hold(seed, rise, period, n, noise):
    run = edge_run(np.random.default_rng(seed), edge="first-order", n=n, near=True, fs=FS,
                   period_samples=period, rise_samples=rise, noise=noise, wander=False)
    crossings = detect_edges(run.x_dev, run.t_dev, refine="sinc", holdoff_s=0.01)
    timing = time_edges(run.x_dev, run.t_dev, crossings, fs=FS)
    e_off, u_off, e_drift, u_drift = _fit(run, timing.times, timing.bounds_s)
    assert e_off <= u_off and e_drift <= u_drift, (e_off, u_off, e_drift, u_drift)
    limit_offset, limit_drift = quantisation_limit(timing.times, FS)
    assert u_off <= 4 * limit_offset and u_drift <= 4 * limit_drift
    # each onset lies within its bound of the truth (plus 4 sigma of the reference jitter)
    truth = (run.ref - run.offset_s) / (1 + run.drift)
    assert np.all(np.abs(timing.times - truth) <= timing.bounds_s + 8e-6)


def test_crossings_alone_miss_the_truth_on_the_reported_case():
    """The interval of the mid-level crossings with no edge bound (the fit before the edge
    shapes) misses the truth of the reported case: the test above can fail."""
    run = edge_run(np.random.default_rng(1), edge="first-order", n=20, near=True, fs=FS,
                   period_samples=1613.002, rise_samples=1 / 3, noise=1e-3, wander=False)
    crossings = detect_edges(run.x_dev, run.t_dev, refine="sinc", holdoff_s=0.01)
    e_off, u_off, _, _ = _fit(run, crossings, 0.0)
    assert e_off > 3 * u_off and e_off > 50e-6


def test_band_limited_and_digital_edges_keep_their_treatment():
    """A band-limited step keeps its sinc crossings (bound 0); a logic level is sample-switched."""
    for edge, shape in (("band-limited", "symmetric"), ("digital", "switched")):
        run = edge_run(np.random.default_rng(5), edge=edge, n=20, near=True, fs=FS,
                       period_samples=1000.001, noise=1e-3 if edge != "digital" else 0.0)
        crossings = detect_edges(run.x_dev, run.t_dev, refine="sinc", holdoff_s=0.01)
        timing = time_edges(run.x_dev, run.t_dev, crossings, fs=FS)
        assert timing.shape == shape
        np.testing.assert_array_equal(timing.times, crossings)
