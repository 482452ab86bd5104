"""classify_pulses on trains where spurious pulses crowd the running window (issue 14 item 13)."""

from __future__ import annotations

import numpy as np

from rigval.processing.pulses import classify_pulses


def test_two_spurious_pulses_near_the_end_leave_the_real_ones() -> None:
    # The opt1 edges of the 10 s virtual-rig run at 1.0 rev/s, seed 1: two spurious pulses
    # among the last six intervals pulled the running median of the intervals to 0.58 s.
    t = np.array([0.9997, 2.0027, 3.0037, 4.0024, 5.0001, 5.5649, 5.9997, 6.5957, 6.9984,
                  7.9987, 9.0005])
    train = classify_pulses(t)
    assert np.flatnonzero(train.spurious).tolist() == [5, 7]
    assert train.missing_times.size == 0


def test_random_trains_with_spurious_and_missing_pulses() -> None:
    rng = np.random.default_rng(5)
    for _ in range(100):
        n = int(rng.integers(8, 40))
        period = rng.uniform(0.2, 2.0)
        # speed wander of 0.4 % and 20 us jitter, as the rig's sensors have
        real = np.cumsum(period * (1 + 0.004 * rng.standard_normal(n)))
        real += 20e-6 * rng.standard_normal(n)
        missing = rng.choice(np.arange(1, n - 1), size=int(rng.integers(0, 2)), replace=False)
        kept = np.delete(real, missing)
        # spurious pulses at least five periods apart, none in the first or last period (where
        # one neighbour alone must decide), each off the grid by 20 ... 80 % of a period
        k = int(rng.integers(0, (n - 3) // 5 + 1))
        after = 1 + 5 * rng.choice((n - 3) // 5, size=k, replace=False)
        spurious = real[after] + period * rng.uniform(0.2, 0.8, size=k)
        times = np.concatenate((kept, spurious))
        order = np.argsort(times)
        truth = np.concatenate((np.zeros(kept.size, bool), np.ones(k, bool)))[order]
        train = classify_pulses(times[order])
        assert np.array_equal(train.spurious, truth)
        np.testing.assert_allclose(np.sort(train.missing_times), np.sort(real[missing]),
                                   atol=0.05 * period)
