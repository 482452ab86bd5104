"""The batched comparison (all revolutions at once) against a plain per-revolution reference.

The reference below rates one revolution at a time with loops and library calls only
(np.corrcoef for the circular phase shift, a full-matrix DTW cell by cell, np.convolve for the
slope, scipy.optimize.brentq for the circular lag): it shares no code with the batched path.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.optimize

from rigval.acquisition.errors import DataError
from rigval.processing.dtw import dtw_path, dtw_paths, workspace_size
from rigval.validation.metrics.compare import (
    DEFAULT_METRICS,
    baseline,
    compare,
    periodic_ratings,
)
from rigval.validation.metrics.core import paired
from rigval.validation.metrics.iso18571 import (
    IsoParameters,
    iso18571_periodic_many,
    iso18571_periodic_sets,
)
from rigval.validation.metrics.waveform import circular_lag_many

_TOLERANCE = 1e-12
"""Scores agree to this (the two paths sum in different orders; paths and shifts are equal)."""


def _dtw_full(x: np.ndarray, y: np.ndarray, radius: int) -> tuple[np.ndarray, np.ndarray]:
    """DTW on the whole cost matrix, cell by cell; ties: vertical, horizontal, diagonal."""
    n = x.size
    total = np.full((n + 1, n + 1), np.inf)
    total[0, 0] = 0.0
    for i in range(1, n + 1):
        for j in range(max(1, i - radius), min(n, i + radius) + 1):
            total[i, j] = (x[i - 1] - y[j - 1]) ** 2 + min(total[i - 1, j], total[i, j - 1],
                                                           total[i - 1, j - 1])
    i = j = n
    path = [(i, j)]
    while (i, j) != (1, 1):
        options = ((total[i - 1, j], i - 1, j), (total[i, j - 1], i, j - 1),
                   (total[i - 1, j - 1], i - 1, j - 1))
        best = min(value for value, _, _ in options)
        i, j = next((a, b) for value, a, b in options if value == best)
        path.append((i, j))
    path.reverse()
    return np.array([a - 1 for a, _ in path]), np.array([b - 1 for _, b in path])


def _limited(error: float, limit: float, exponent: float) -> float:
    return 1.0 if error <= 0 else 0.0 if error >= limit else ((limit - error) / limit) ** exponent


def _slope(values: np.ndarray) -> np.ndarray:
    derivative = 0.5 * (np.roll(values, -1) - np.roll(values, 1))
    wrapped = np.concatenate((derivative[-4:], derivative, derivative[:4]))
    return np.convolve(wrapped, np.full(9, 1.0 / 9.0), mode="valid")


def _rate_one(reference: np.ndarray, model: np.ndarray, params: IsoParameters) -> dict:
    """Periodic ISO/TS 18571 rating of one revolution, by the definitions in docs/metrics.md."""
    n = reference.size
    limit = math.floor(n * params.phase_window)
    shifts = list(range(-limit, limit + 1))
    rho = [np.corrcoef(reference, np.roll(model, -s))[0, 1] if np.ptp(model) > 0 else -np.inf
           for s in shifts]
    best = max(rho)
    tied = [s for s, r in zip(shifts, rho, strict=True) if r >= best - 1e-12]
    shift = min(tied, key=lambda s: (abs(s), s < 0)) if np.isfinite(best) else 0
    rotated = np.roll(model, -shift)
    radius = max(math.ceil(params.dtw_band * n) - 1, 0)
    ix, iy = _dtw_full(np.tile(rotated, 3), np.tile(reference, 3), radius)
    inside = (iy >= n) & (iy < 2 * n)
    warped_model, warped_reference = rotated[ix[inside] % n], reference[iy[inside] % n]
    magnitude_error = (np.abs(warped_model - warped_reference).sum()
                       / np.abs(warped_reference).sum())
    slope_ref, slope_model = _slope(reference), _slope(rotated)
    slope_error = np.abs(slope_model - slope_ref).sum() / np.abs(slope_ref).sum()
    peak = np.abs(reference).max()
    inner, outer = params.inner_width * peak, params.outer_width * peak
    between = np.clip((outer - np.abs(model - reference)) / (outer - inner), 0.0, 1.0)
    scores = {"corridor": float(np.mean(between ** params.corridor_exponent)),
              "phase": _limited(abs(shift), params.phase_window * n, params.phase_exponent),
              "magnitude": _limited(magnitude_error, params.magnitude_limit,
                                    params.magnitude_exponent),
              "slope": _limited(slope_error, params.slope_limit, params.slope_exponent)}
    scores["rating"] = sum(w * scores[k] for w, k in zip(
        params.weights, ("corridor", "phase", "magnitude", "slope"), strict=True))
    scores["shift_samples"] = shift
    return scores


def _lag_one(reference: np.ndarray, model: np.ndarray) -> float:
    """Circular lag in degrees: best whole sample, then Brent on the interpolant's slope."""
    n = reference.size
    dm, dc = reference - reference.mean(), model - model.mean()
    spectrum = np.conj(np.fft.rfft(dm)) * np.fft.rfft(dc)
    whole = float(np.argmax(np.fft.irfft(spectrum, n)))
    orders = np.arange(spectrum.size)
    weights = np.where((orders == 0) | ((n % 2 == 0) & (orders == n // 2)), 1.0, 2.0) * spectrum
    rate = 2j * np.pi * orders / n

    def slope(lag: float) -> float:
        return float(np.sum(np.real(rate * weights * np.exp(rate * lag))))

    lag = whole
    if slope(whole - 1.0) > 0.0 > slope(whole + 1.0):
        lag = scipy.optimize.brentq(slope, whole - 1.0, whole + 1.0, xtol=1e-12, rtol=1e-14)
    return ((lag + n / 2.0) % n - n / 2.0) * 360.0 / n


def _harmonics(rng: np.random.Generator, n: int, delay: float = 0.0) -> np.ndarray:
    theta = np.arange(n) * 2 * np.pi / n - delay
    a, b = rng.normal(size=(2, 4))
    return sum(a[h] * np.cos((h + 1) * theta) + b[h] * np.sin((h + 1) * theta) for h in range(4))


def _cases(name: str, n: int) -> tuple[np.ndarray, np.ndarray]:
    """A reference over one revolution and several models: the hard cases named."""
    rng = np.random.default_rng({"random": 1, "equal": 2, "flat": 3, "wrap": 4, "noise": 5,
                                 "ties": 6}[name])
    reference = _harmonics(rng, n)
    limit = math.floor(0.2 * n)
    if name == "random":
        models = np.array([rng.uniform(0.5, 1.5) * _harmonics(np.random.default_rng(1), n, d)
                           + rng.normal(scale=0.2, size=n) for d in rng.uniform(-1, 1, 6)])
    elif name == "equal":
        models = np.stack([reference] * 4)
    elif name == "flat":  # constant models (no phase information) beside a normal one
        models = np.stack([np.zeros(n), np.full(n, 2.5), reference * 0.9, np.full(n, -1.0)])
    elif name == "wrap":  # shifts at and beyond the window, either way, and across the wrap
        models = np.stack([np.roll(reference, s) for s in (limit, -limit, limit + 1, n - 1, 1,
                                                           n // 2)])
    elif name == "noise":
        models = rng.normal(size=(5, n))
    else:  # quantised: plateaus, so DTW cost ties
        reference = np.round(reference * 2) / 2
        models = np.round((reference + rng.normal(scale=0.4, size=(6, n))) * 2) / 2
    return reference, models


@pytest.mark.parametrize("name", ["random", "equal", "flat", "wrap", "noise", "ties"])
@pytest.mark.parametrize("n", [40, 45])
def test_periodic_many_equals_plain_per_revolution_rating(name, n):
    reference, models = _cases(name, n)
    params = IsoParameters()
    batched = iso18571_periodic_many(reference, models, params=params)
    for scores, model in zip(batched, models, strict=True):
        expected = _rate_one(reference, model, params)
        assert scores.shift_samples == expected["shift_samples"]
        for key in ("rating", "corridor", "phase", "magnitude", "slope"):
            assert abs(getattr(scores, key) - expected[key]) <= _TOLERANCE, (name, key)
    if name == "equal":
        assert all(s.rating == 1.0 and s.magnitude == 1.0 for s in batched)


def test_a_bad_row_is_refused_as_the_pair_check_refuses_the_first_one():
    # the stack is checked at once; a bad row gets the pair check's own error, for the first
    reference, models = _cases("random", 40)
    models[2, 7], models[4, 1] = np.nan, np.inf
    with pytest.raises(DataError) as caught:
        iso18571_periodic_many(reference, models)
    with pytest.raises(DataError) as first:
        paired(reference, models[2])
    assert str(caught.value) == str(first.value)
    assert caught.value.where == first.value.where == {"signal": "model", "index": 7}


def test_the_rated_stack_is_not_written_to():
    reference, models = _cases("wrap", 45)
    kept = models.copy()
    iso18571_periodic_many(reference, models)
    assert np.array_equal(models, kept)


def test_flat_reference_is_refused():
    with pytest.raises(DataError, match="slope is zero"):
        iso18571_periodic_many(np.full(40, 3.0), np.random.default_rng(0).normal(size=(3, 40)))


@pytest.mark.parametrize("name", ["random", "wrap", "noise", "ties"])
def test_circular_lag_many_equals_brentq_per_revolution(name):
    reference, models = _cases(name, 72)
    lags = circular_lag_many(reference, models)["lag_deg"]
    expected = [_lag_one(reference, model) for model in models]
    assert lags.tolist() == expected  # the same Brent iteration: the same bits


def test_constant_model_has_no_lag_and_the_row_is_named():
    reference, models = _cases("flat", 40)
    with pytest.raises(DataError, match="constant") as info:
        circular_lag_many(reference, models)
    assert info.value.where == {"signal": "model", "row": 0}


@pytest.mark.parametrize("seed", [0, 1])
def test_dtw_paths_batches_equal_full_matrix(seed, monkeypatch):
    """Batches of one pair and of all pairs (and a shared y) give the cell-by-cell paths."""
    rng = np.random.default_rng(seed)
    x, y = rng.normal(size=(7, 30)), rng.normal(size=(7, 30))
    if seed:
        x, y = np.round(x * 2) / 2, np.round(y * 2) / 2
    expected = [_dtw_full(a, b, 4) for a, b in zip(x, y, strict=True)]
    for batch_bytes in (1, 10**9):  # one pair per batch; every pair in one batch
        monkeypatch.setattr("rigval.processing.dtw.BATCH_BYTES", batch_bytes)
        for (ix, iy), (ex, ey) in zip(list(dtw_paths(x, y, 4)), expected, strict=True):
            assert ix.tolist() == ex.tolist() and iy.tolist() == ey.tolist()
        shared = list(dtw_paths(x, y[:1], 4))
        for (ix, iy), a in zip(shared, x, strict=True):
            ex, ey = _dtw_full(a, y[0], 4)
            assert ix.tolist() == ex.tolist() and iy.tolist() == ey.tolist()


def test_dtw_paths_in_a_shared_workspace_equal_the_full_matrix(monkeypatch):
    """Stacks of other lengths and radii swept in turn in one work space, dirty from the last."""
    rng = np.random.default_rng(5)
    monkeypatch.setattr("rigval.processing.dtw.BATCH_BYTES", 2 * 40 * 12)  # batches of 2
    stacks = [(rng.normal(size=(5, 40)), rng.normal(size=(1, 40)), 6),
              (np.round(rng.normal(size=(3, 25))), np.round(rng.normal(size=(3, 25))), 0),
              (rng.normal(size=(4, 33)), rng.normal(size=(4, 33)), 40)]
    workspace = np.full(max(workspace_size(x.shape[0], x.shape[1], radius)
                            for x, _, radius in stacks), 255, dtype=np.uint8)
    for x, y, radius in stacks:
        paths = list(dtw_paths(x, y, radius, workspace=workspace))
        for p, (ix, iy) in enumerate(paths):
            ex, ey = _dtw_full(x[p], y[min(p, y.shape[0] - 1)], min(radius, x.shape[1] - 1))
            assert ix.tolist() == ex.tolist() and iy.tolist() == ey.tolist()
    assert not np.all(workspace == 255)  # the paths were swept in it


def test_baseline_equals_compare_per_revolution_on_hard_cycles():
    reference, models = _cases("wrap", 45)
    cycles = np.concatenate((models, _cases("noise", 45)[1]))
    result = baseline(cycles, reference)
    for index, cycle in enumerate(cycles):
        row = compare(reference, cycle, metrics=DEFAULT_METRICS)
        for key, values in result.per_cycle.items():
            assert abs(values[index] - row[key]) <= _TOLERANCE, (index, key)


def test_dtw_paths_from_a_column_return_the_end_of_the_full_path():
    rng = np.random.default_rng(9)
    x, y = rng.normal(size=(5, 60)), rng.normal(size=(1, 60))
    for y_from in (0, 1, 20, 59):
        for (ix, iy), a in zip(dtw_paths(x, y, 6, y_from=y_from), x, strict=True):
            ex, ey = _dtw_full(a, y[0], 6)
            keep = ey >= y_from
            assert ix.tolist() == ex[keep].tolist() and iy.tolist() == ey[keep].tolist()


@pytest.mark.parametrize("seed", range(8))
def test_blocked_sweep_matches_full_matrix(seed):
    """Random lengths across several sweep blocks, radii from 0 to beyond n, tie-prone values."""
    rng = np.random.default_rng(100 + seed)
    n = int(rng.integers(2, 150))
    radius = int(rng.choice([0, 1, rng.integers(2, n + 1), n + 2]))
    x, y = rng.normal(size=n), rng.normal(size=n)
    if seed % 2:
        x, y = np.round(x * 2) / 2, np.round(y * 2) / 2
    ix, iy = dtw_path(x, y, radius)
    expected_x, expected_y = _dtw_full(x, y, radius)
    assert ix.tolist() == expected_x.tolist()
    assert iy.tolist() == expected_y.tolist()


@pytest.mark.parametrize("rows_per_sweep", [1, 12, 256])
def test_sets_swept_together_equal_each_set_rated_alone(rows_per_sweep, monkeypatch):
    """Sets of two sample counts, swept one by one, partly together, all together per count."""
    monkeypatch.setattr("rigval.validation.metrics.iso18571.ROWS_PER_SWEEP", rows_per_sweep)
    sets = [_cases(name, n) for name, n in (("random", 40), ("wrap", 45), ("ties", 40),
                                            ("noise", 45), ("equal", 40))]
    together = iso18571_periodic_sets(sets)
    for (reference, models), rated in zip(sets, together, strict=True):
        assert rated == iso18571_periodic_many(reference, models)  # the same bits


def test_periodic_ratings_are_those_compare_and_baseline_compute():
    rng = np.random.default_rng(7)
    comparisons = []
    for name in ("random", "noise", "wrap"):
        reference, models = _cases(name, 72)
        cycles = reference + rng.normal(scale=0.1, size=(5, 72))
        comparisons.append((cycles.mean(axis=0), models[0], cycles))
    for (mean, model, cycles), (iso_model, iso_cycles) in zip(
            comparisons, periodic_ratings(comparisons), strict=True):
        assert compare(mean, model, metrics=("iso18571_periodic",)) == compare(
            mean, model, metrics=("iso18571_periodic",), iso=iso_model)
        alone = baseline(cycles, mean, metrics=("iso18571_periodic",))
        given = baseline(cycles, mean, metrics=("iso18571_periodic",), iso=iso_cycles)
        for key, values in alone.per_cycle.items():
            np.testing.assert_array_equal(given.per_cycle[key], values)


def test_ratings_of_other_cycles_are_refused():
    reference, models = _cases("random", 40)
    ratings = iso18571_periodic_many(reference, models)
    with pytest.raises(DataError, match="5 ISO ratings given for 6 cycles"):
        baseline(models, reference, metrics=("iso18571_periodic",), iso=ratings[:5])


def test_set_swept_alone_a_batch_of_rows_at_a_time_equals_each_row_rated_alone(monkeypatch):
    """A long record's set: its DTW rows made a batch at a time, the ratings those of each row."""
    from rigval.processing.dtw import pairs_per_batch
    from rigval.validation.metrics import iso18571

    reference, models = _cases("noise", 40)
    models = np.concatenate([models, _cases("wrap", 40)[1][:, :40]])[:7]
    radius = iso18571._band_radius(40, iso18571.IsoParameters())
    pair_bytes = 2 * 120 * (radius + 3) + 120 + 1  # three revolutions of 40 samples
    monkeypatch.setattr("rigval.processing.dtw.BATCH_BYTES", 2 * pair_bytes)
    assert pairs_per_batch(7, 120, radius) == 2
    made = []
    rotated = iso18571._Prepared.rotated

    def spy(self, rows=slice(None)):
        out = rotated(self, rows)
        made.append(out.shape[0])
        return out

    monkeypatch.setattr(iso18571._Prepared, "rotated", spy)
    rated = iso18571_periodic_sets([(reference, models)])[0]
    assert made[:4] == [2, 2, 2, 1]  # the DTW's rows, a batch at a time; then the scores' all
    monkeypatch.setattr(iso18571._Prepared, "rotated", rotated)
    for row, scores in zip(models, rated, strict=True):
        assert scores == iso18571_periodic_many(reference, row[np.newaxis])[0]


def test_baseline_scored_in_blocks_of_rows_equals_all_rows_at_once(monkeypatch):
    """A long record's revolutions scored a block at a time: the same bits as all at once."""
    from rigval.validation.metrics import compare as compare_module

    reference, models = _cases("wrap", 45)
    cycles = np.concatenate((models, _cases("noise", 45)[1], models[::-1] * 1.1))
    metrics = ("iso18571_periodic", "nrmse", "pearson_r", "peak_error", "circular_lag",
               "sprague_geers", "russell")
    whole = baseline(cycles, reference, metrics=metrics)
    monkeypatch.setattr(compare_module, "SCORE_ROWS", 4)  # 17 rows: blocks of 4, 4, 4, 4, 1
    blocked = baseline(cycles, reference, metrics=metrics)
    assert blocked.per_cycle.keys() == whole.per_cycle.keys()
    for key, values in whole.per_cycle.items():
        assert np.array_equal(blocked.per_cycle[key], values, equal_nan=True), key
    assert blocked.median == whole.median and blocked.worst_cycle == whole.worst_cycle
