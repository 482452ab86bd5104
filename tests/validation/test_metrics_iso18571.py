"""ISO/TS 18571 rating: closed forms, brute-force references and the TU Graz reference values."""

from __future__ import annotations

import math

import hypothesis.extra.numpy as hnp
import numpy as np
import pytest
import xarray as xr
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from rigval.acquisition.errors import ConfigError, DataError
from rigval.validation.metrics.iso18571 import (
    IsoParameters,
    _circular_correlation,
    _overlap_correlation,
    dtw_path,
    grade,
    iso18571,
    iso18571_periodic,
)

N_TIME = 1501
TIME = np.arange(N_TIME) * 1e-4


def pulse(t0: float, width: float) -> np.ndarray:
    return np.exp(-(((TIME - t0) / width) ** 2))


def two_pulses() -> np.ndarray:
    return pulse(0.05, 0.01) - 0.4 * pulse(0.09, 0.008)


def revolution(n: int = 720, lag_deg: float = 0.0) -> np.ndarray:
    """A band-limited signal over one revolution, delayed by ``lag_deg``."""
    theta = np.arange(n) * 2 * np.pi / n - np.radians(lag_deg)
    return np.sin(theta) + 0.4 * np.sin(3 * theta + 0.5) + 0.1 * np.cos(7 * theta)


smooth_coefficients = hnp.arrays(np.float64, 6, elements=st.floats(-1, 1)).filter(
    lambda a: np.abs(a).max() > 0.1)


def smooth(coefficients: np.ndarray, n: int = 240) -> np.ndarray:
    theta = np.arange(n) * 2 * np.pi / n
    return sum(a * np.sin((k + 1) * theta + k) for k, a in enumerate(coefficients))


# Values computed with the TU Graz reference implementation (objective-rating-metrics 1.3,
# ISO18571(...).overall_rating/corridor/phase/magnitude/slope with ndigits=-1) on the same curves.
TU_GRAZ = {
    "scale 1.3": (lambda: (two_pulses(), 1.3 * two_pulses()),
                  (0.8984275847571629, 0.8962127640260813, 1.0, 0.8497123957336515, 0.85)),
    "delay 4 ms": (lambda: (two_pulses(), np.interp(TIME - 0.004, TIME, two_pulses())),
                   (0.9035853706184226, 0.8255856783781695, 0.8667554963357762, 1.0, 1.0)),
    "shift beyond window": (lambda: (pulse(0.03, 0.005), pulse(0.11, 0.005)),
                            (0.3303144832203561, 0.8254530967917297, 0.0006662225183210814,
                             0.0, 0.0)),
    "inverted sine": (lambda: (np.sin(2 * np.pi * 25 * TIME), -np.sin(2 * np.pi * 25 * TIME)),
                      (0.492398220225749, 0.06410680972493427, 0.3337774816788807, 1.0, 1.0)),
    "offset": (lambda: (two_pulses(), two_pulses() + 0.1),
               (0.8076852573885296, 0.7901234567879305, 1.0, 0.45817937336678694, 1.0)),
}


@pytest.mark.parametrize("case", sorted(TU_GRAZ))
def test_matches_tu_graz_reference(case):
    make, expected = TU_GRAZ[case]
    measured, model = make()
    scores = iso18571(measured, model, fs=1e4)
    got = (scores.rating, scores.corridor, scores.phase, scores.magnitude, scores.slope)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)


def test_window_edge_quirk_of_the_reference():
    # N = 1501: the window is floor(0.2 N) = 300 samples but eps_P N = 300.2, so a shift beyond
    # the window still scores 0.2 / 300.2 (research note, pairs P13/P14).
    scores = iso18571(pulse(0.03, 0.005), pulse(0.11, 0.005), fs=1e4)
    assert abs(scores.shift_samples) == 300
    assert scores.phase == pytest.approx(0.2 / 300.2, abs=1e-15)


@settings(max_examples=15)
@given(smooth_coefficients)
def test_identical_signals_score_one(coefficients):
    signal = smooth(coefficients)
    for scores in (iso18571(signal, signal, dt=1e-3), iso18571_periodic(signal, signal)):
        assert scores.rating == 1.0
        assert (scores.corridor, scores.phase, scores.magnitude, scores.slope) == (1, 1, 1, 1)
        assert scores.grade == "excellent"
        assert scores.shift_samples == 0


@pytest.mark.parametrize("delay", [1, 17, 60, 119])
def test_pure_delay_time_signal(delay):
    n = 600
    measured = np.exp(-(((np.arange(n) - 250) / 40.0) ** 2))
    model = np.concatenate((np.zeros(delay), measured[:-delay]))
    scores = iso18571(measured, model, dt=2e-3)
    window = 0.2 * n
    assert scores.shift_samples == delay
    assert scores.shift == pytest.approx(delay * 2e-3)
    assert scores.phase == pytest.approx((window - delay) / window, abs=1e-14)
    assert scores.magnitude == 1.0 and scores.slope == 1.0  # truncated curves are identical
    corridor = np.mean([_corridor_point(m, c, 1.0) for m, c in zip(measured, model, strict=True)])
    assert scores.corridor == pytest.approx(corridor, abs=1e-12)
    assert scores.rating == pytest.approx(0.4 * corridor + 0.2 * scores.phase + 0.4, abs=1e-12)


def _corridor_point(measured: float, model: float, peak: float) -> float:
    """Corridor score of one sample, written out case by case."""
    distance = abs(model - measured)
    inner, outer = 0.05 * peak, 0.5 * peak
    if distance <= inner:
        return 1.0
    if distance >= outer:
        return 0.0
    return ((outer - distance) / (outer - inner)) ** 2


@pytest.mark.parametrize("delay", [-100, -3, 5, 90, 144])
def test_pure_rotation_periodic(delay):
    n = 720
    measured = revolution(n)
    model = np.roll(measured, delay)  # model[i] = measured[i - delay]: delayed by `delay`
    scores = iso18571_periodic(measured, model)
    window = 0.2 * n
    assert scores.shift_samples == delay
    assert scores.shift == pytest.approx(delay * 360 / n)
    assert scores.phase == pytest.approx(max(window - abs(delay), 0) / window, abs=1e-14)
    assert scores.magnitude == 1.0 and scores.slope == 1.0


def test_rotation_beyond_window_scores_zero_phase():
    # A single harmonic delayed by 108 deg: best shift within the 72-deg window is its edge.
    measured = np.sin(np.arange(720) * 2 * np.pi / 720)
    scores = iso18571_periodic(measured, np.roll(measured, 216))
    assert scores.shift_samples == 144
    assert scores.phase == 0.0


@settings(max_examples=15)
@given(st.floats(0.6, 1.4), st.sampled_from(["time", "periodic"]))
def test_pure_scaling(k, variant):
    measured = revolution(360)
    scores = (iso18571(measured, k * measured, dt=1.0) if variant == "time"
              else iso18571_periodic(measured, k * measured))
    assert scores.phase == 1.0
    # slopes scale by k: relative L1 slope error |k - 1|, scored linearly against 2
    assert scores.slope == pytest.approx(1 - abs(k - 1) / 2, abs=1e-12)
    peak = np.abs(measured).max()
    corridor = np.mean([_corridor_point(m, k * m, peak) for m in measured])
    assert scores.corridor == pytest.approx(corridor, abs=1e-12)


def test_small_scaling_stays_inside_inner_corridor_and_offset_closed_form():
    measured = revolution(360)
    assert iso18571_periodic(measured, 1.04 * measured).corridor == 1.0
    offset = 0.2 * np.abs(measured).max()
    scores = iso18571_periodic(measured, measured + offset)
    assert scores.corridor == pytest.approx((0.3 / 0.45) ** 2, abs=1e-12)
    assert scores.phase == 1.0 and scores.slope == pytest.approx(1.0, abs=1e-12)


@settings(max_examples=15)
@given(smooth_coefficients, smooth_coefficients, st.integers(0, 239))
def test_periodic_rating_has_no_start_angle(a, b, start):
    measured, model = smooth(a), smooth(b)
    first = iso18571_periodic(measured, model)
    rotated = iso18571_periodic(np.roll(measured, start), np.roll(model, start))
    assert rotated.corridor == pytest.approx(first.corridor, abs=1e-12)
    assert rotated.phase == pytest.approx(first.phase, abs=1e-12)
    assert rotated.magnitude == pytest.approx(first.magnitude, abs=1e-9)
    assert rotated.slope == pytest.approx(first.slope, abs=1e-9)
    assert rotated.shift_samples == first.shift_samples
    assert rotated.rating == pytest.approx(first.rating, abs=1e-9)


def test_grades():
    assert [grade(r) for r in (1.0, 0.9401, 0.94, 0.8001, 0.8, 0.5801, 0.58, 0.0)] == [
        "excellent", "excellent", "good", "good", "fair", "fair", "poor", "poor"]
    assert iso18571(two_pulses(), 1.3 * two_pulses(), fs=1e4).grade == "good"
    assert iso18571_periodic(revolution(), -revolution()).grade == "poor"
    assert iso18571_periodic(revolution(), revolution(lag_deg=2.0)).grade == "excellent"


def _brute_force_shift(reference: np.ndarray, comparison: np.ndarray) -> int:
    """The reference implementation's loop: zero, then +m before -m, strictly greater wins."""
    best, shift = np.corrcoef(reference, comparison)[0, 1], 0
    for m in range(1, int(np.floor(reference.size * 0.2)) + 1):
        lagging = np.corrcoef(reference[:-m], comparison[m:])[0, 1]
        if lagging > best:
            best, shift = lagging, m
        leading = np.corrcoef(reference[m:], comparison[:-m])[0, 1]
        if leading > best:
            best, shift = leading, -m
    return shift


@given(hnp.arrays(np.int64, st.integers(20, 120), elements=st.integers(-3, 3)),
       st.integers(-30, 30), st.integers(0, 2**32 - 1))
def test_vectorised_phase_matches_loop(walk_steps, roll, seed):
    reference = np.cumsum(walk_steps).astype(np.float64)  # exact: constant parts are exact
    noise = np.random.default_rng(seed).normal(size=reference.size)
    comparison = np.roll(reference, roll) + 0.3 * noise
    limit = int(np.floor(reference.size * 0.2))
    shifts, rho = _overlap_correlation(reference, comparison, limit)
    assume(np.isfinite(rho).all())
    best = shifts[np.flatnonzero(rho >= rho.max() - 1e-12)]
    expected = _brute_force_shift(reference, comparison)
    assert expected in best
    loop_rho = [np.corrcoef(reference[max(-m, 0):reference.size - max(m, 0)],
                            comparison[max(m, 0):comparison.size - max(-m, 0)])[0, 1]
                for m in shifts]
    np.testing.assert_allclose(rho, loop_rho, atol=1e-9)


def test_circular_correlation_matches_loop():
    rng = np.random.default_rng(3)
    reference, comparison = rng.normal(size=50), rng.normal(size=50)
    shifts, rho = _circular_correlation(reference, comparison, 10)
    loop = [np.corrcoef(reference, np.roll(comparison, -m))[0, 1] for m in shifts]
    np.testing.assert_allclose(rho, loop, atol=1e-12)


def _brute_force_dtw(x: np.ndarray, y: np.ndarray, radius: int) -> tuple[list[int], list[int]]:
    """Full-matrix dynamic programming with the same steps, band and tie order."""
    n = x.size
    cost = np.full((n + 1, n + 1), np.inf)
    cost[0, 0] = 0.0
    step = np.zeros((n + 1, n + 1), dtype=int)
    for i in range(1, n + 1):
        for j in range(1, n + 1):
            if abs(i - j) <= radius:
                previous = [cost[i - 1, j], cost[i, j - 1], cost[i - 1, j - 1]]
                step[i, j] = int(np.argmin(previous))
                cost[i, j] = (x[i - 1] - y[j - 1]) ** 2 + previous[step[i, j]]
    i = j = n
    path = [(i, j)]
    moves = {0: (1, 0), 1: (0, 1), 2: (1, 1)}
    while (i, j) != (1, 1):
        di, dj = moves[step[i, j]]
        i, j = i - di, j - dj
        path.append((i, j))
    path.reverse()
    return [p[0] - 1 for p in path], [p[1] - 1 for p in path]


@given(st.integers(2, 40).flatmap(lambda n: st.tuples(
    hnp.arrays(np.float64, n, elements=st.floats(-5, 5)),
    hnp.arrays(np.float64, n, elements=st.floats(-5, 5)),
    st.integers(0, n))))
def test_dtw_matches_full_matrix(case):
    x, y, radius = case
    ix, iy = dtw_path(x, y, radius)
    expected_x, expected_y = _brute_force_dtw(x, y, radius)
    assert ix.tolist() == expected_x
    assert iy.tolist() == expected_y


def test_long_signals_are_resampled():
    n = 6000
    t = np.arange(n) / n
    measured = np.sin(2 * np.pi * 3 * t) * np.exp(-2 * t)
    model = 1.1 * np.sin(2 * np.pi * 3 * (t - 0.01)) * np.exp(-2 * t)
    full = iso18571(measured, model, dt=1 / n, max_samples=n)
    reduced = iso18571(measured, model, dt=1 / n, max_samples=2000)
    assert full.n_samples == n and reduced.n_samples == 2000
    assert reduced.shift == pytest.approx(full.shift, abs=1.5 / 2000)
    assert reduced.rating == pytest.approx(full.rating, abs=0.01)
    periodic = iso18571_periodic(revolution(3600, 5.0), revolution(3600), max_samples=720)
    assert periodic.n_samples == 720
    assert periodic.shift == pytest.approx(-5.0)  # band-limited: Fourier resampling is exact


def test_dataarray_time_coordinate_gives_spacing():
    signal = xr.DataArray(two_pulses(), dims="time", coords={"time": TIME})
    model = xr.DataArray(np.interp(TIME - 0.004, TIME, two_pulses()), dims="time",
                         coords={"time": TIME})
    scores = iso18571(signal, model)
    assert scores.shift == pytest.approx(0.004)


def test_bad_input():
    with pytest.raises(ConfigError, match="sample spacing is missing"):
        iso18571(two_pulses(), two_pulses())
    with pytest.raises(ConfigError, match="not both"):
        iso18571(two_pulses(), two_pulses(), dt=1e-4, fs=1e4)
    with pytest.raises(ConfigError, match="positive") as info:
        iso18571(two_pulses(), two_pulses(), fs=-1.0)
    assert info.value.where["key"] == "fs"
    with pytest.raises(DataError, match="repeats the first"):
        iso18571_periodic(revolution(100), revolution(100), np.linspace(0, 2 * np.pi, 100))
    with pytest.raises(DataError, match="equal lengths"):
        dtw_path(np.zeros(5), np.zeros(6), 1)
    broken = two_pulses()
    broken[[7, 9]] = np.nan
    with pytest.raises(DataError, match="2 NaN") as info:
        iso18571(broken, two_pulses(), fs=1e4)
    assert info.value.where == {"signal": "measured", "index": 7}
    with pytest.raises(DataError, match="differ in length"):
        iso18571(two_pulses(), two_pulses()[:-1], fs=1e4)
    with pytest.raises(DataError, match="zero everywhere"):
        iso18571_periodic(np.zeros(100), revolution(100))
    with pytest.raises(DataError, match="at least 16"):
        iso18571_periodic(np.arange(10.0), np.arange(10.0))


@pytest.mark.parametrize(("key", "value"), [("inner_width", 0.6), ("phase_window", 0.5),
                                            ("dtw_band", 0.0), ("slope_limit", 0.0),
                                            ("weights", (0.5, 0.2, 0.2, 0.2))])
def test_bad_parameters_name_their_key(key, value):
    with pytest.raises(ConfigError) as info:
        IsoParameters(**{key: value})
    assert info.value.where["key"] == key


def test_custom_weights_change_rating():
    measured, model = two_pulses(), 1.3 * two_pulses()
    scores = iso18571(measured, model, fs=1e4, params=IsoParameters(weights=(1.0, 0, 0, 0)))
    assert scores.rating == pytest.approx(scores.corridor)
    assert math.isclose(scores.corridor, TU_GRAZ["scale 1.3"][1][1], abs_tol=1e-12)
