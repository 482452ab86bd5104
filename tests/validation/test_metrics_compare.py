"""compare, baseline, V&V 20 and thresholds: flat scores, noise floor, uncertainty, pass/fail."""

from __future__ import annotations

import json
import pickle

import numpy as np
import pytest
import xarray as xr
from hypothesis import given
from hypothesis import strategies as st

from rigval.acquisition.errors import ConfigError, DataError
from rigval.validation.metrics.compare import (
    DEFAULT_METRICS,
    METRICS,
    ThresholdCheck,
    baseline,
    check_thresholds,
    compare,
    orientation,
    parse_threshold,
    sprague_geers,
    vv20,
)
from tests.validation.revolution_grid import PHI, N


def wave(lag_deg: float = 0.0) -> np.ndarray:
    theta = PHI - np.radians(lag_deg)
    return np.sin(theta) + 0.5 * np.sin(2 * theta + 1.0) + 0.2 * np.cos(5 * theta)


def test_compare_identical_signals_scores_perfect():
    scores = compare(wave(), wave(), PHI)
    assert scores["iso18571_periodic.rating"] == 1.0
    assert scores["iso18571_periodic.grade"] == "excellent"
    assert scores["sprague_geers.magnitude"] == 0.0
    assert scores["sprague_geers.phase"] == pytest.approx(0.0, abs=1e-7)
    assert scores["russell.comprehensive"] == pytest.approx(0.0, abs=1e-7)
    assert scores["nrmse"] == 0.0 and scores["nrmse.normaliser"] == "range"
    assert scores["pearson_r"] == pytest.approx(1.0, abs=1e-15)
    assert scores["peak_error.relative_error"] == 0.0
    assert scores["circular_lag.lag_deg"] == pytest.approx(0.0, abs=1e-9)


def test_compare_names_and_units():
    scores = compare(wave(), 1.1 * wave(7.0), PHI)
    prefixes = {key.split(".")[0] for key in scores}
    assert prefixes == set(DEFAULT_METRICS)
    assert all(isinstance(value, int | float | str) for value in scores.values())
    json.dumps(scores)  # tabulates and serialises as it is
    assert scores["circular_lag.lag_deg"] == pytest.approx(7.0, abs=1e-8)
    assert scores["iso18571_periodic.shift"] == pytest.approx(7.0)
    assert scores["peak_error.shift"] == pytest.approx(7.0)  # degrees
    assert scores["sprague_geers.magnitude"] == pytest.approx(0.1, abs=1e-12)
    assert scores == compare(wave(), 1.1 * wave(7.0))  # default grid k * 2 pi / n


def test_compare_runs_every_metric_and_accepts_dataarrays():
    measured = xr.DataArray(wave(), dims="angle", coords={"angle": PHI})
    model = xr.DataArray(wave(3.0), dims="angle", coords={"angle": PHI})
    scores = compare(measured, model, metrics=METRICS, normaliser="rms",
                     uncertainty={"u_measurement_rel": 0.02})
    assert scores["iso18571.shift"] == pytest.approx(3.0)
    assert scores["nrmse.normaliser"] == "rms"
    assert scores["vv20.peak.u_data"] == pytest.approx(0.02 * np.abs(wave()).max())
    shifted = model.assign_coords(angle=PHI + 0.01)
    with pytest.raises(DataError, match="different 'angle' coordinates"):
        compare(measured, shifted)


def test_compare_bad_requests():
    with pytest.raises(ConfigError, match="unknown metric 'theil'") as info:
        compare(wave(), wave(), metrics=("nrmse", "theil"))
    assert info.value.where["key"] == "metrics"
    with pytest.raises(DataError, match="repeats the first"):
        compare(np.append(wave(), 0.0), np.append(wave(), 0.0),
                np.linspace(0, 2 * np.pi, N + 1))
    with pytest.raises(ConfigError, match="unknown uncertainty option 'u_sensor'") as info:
        compare(wave(), wave(), metrics=("vv20",), uncertainty={"u_sensor": 0.1})
    assert info.value.where["key"] == "uncertainty.u_sensor"


def test_baseline_of_scaled_cycles():
    factors = np.array([0.9, 1.0, 1.05, 1.2, 0.95])
    cycles = factors[:, None] * wave()
    result = baseline(cycles, angle=PHI, metrics=("sprague_geers", "nrmse"))
    mean_factor = factors.mean()
    expected = factors / mean_factor - 1  # Sprague-Geers M of each cycle against the mean
    np.testing.assert_allclose(result.per_cycle["sprague_geers.magnitude"], expected, atol=1e-12)
    assert result.median["sprague_geers.magnitude"] == pytest.approx(np.median(expected))
    assert result.worst_cycle["sprague_geers.magnitude"] == 3  # largest |M|
    assert result.worst["sprague_geers.magnitude"] == pytest.approx(expected[3])
    assert result.worst_cycle["nrmse"] == 3
    assert result.n_cycles == 5
    summary = result.as_dict()
    assert set(summary) == {"n_cycles", "median", "worst", "worst_cycle"}
    json.dumps(summary)


def test_baseline_against_a_given_mean_and_dataarray_cycles():
    rng = np.random.default_rng(2)
    values = wave() + 0.02 * rng.normal(size=(8, N))
    cycles = xr.DataArray(values.T, dims=("angle", "cycle"), coords={"angle": PHI})
    result = baseline(cycles, mean=wave(), metrics=("circular_lag", "pearson_r"))
    direct = [compare(wave(), cycle, metrics=("pearson_r",))["pearson_r"] for cycle in values]
    np.testing.assert_allclose(result.per_cycle["pearson_r"], direct, atol=1e-15)
    assert result.worst["pearson_r"] == min(direct)


def test_baseline_bad_input():
    with pytest.raises(ConfigError, match="vv20"):
        baseline(np.tile(wave(), (3, 1)), metrics=("vv20",))
    with pytest.raises(DataError, match="n_cycles >= 2"):
        baseline(wave()[None, :])
    cycles = np.tile(wave(), (4, 1))
    cycles[2, 5] = np.nan
    with pytest.raises(DataError, match="NaN") as info:
        baseline(cycles)
    assert info.value.where["cycle"] == 2


def test_every_numeric_score_has_an_orientation_or_describes():
    scores = compare(wave(), 1.1 * wave(3.0), metrics=METRICS)
    descriptive = ("n_samples", "_peak", "_at", "normaliser_value", ".simulation", ".data",
                   ".u_num", ".u_input", ".u_data", ".u_val", ".k", ".lower", ".upper",
                   ".u_calibration", ".u_alignment", ".u_scatter", ".u_grid", ".u_drive",
                   ".u_gain_own")
    for key, value in scores.items():
        if isinstance(value, float | int) and not isinstance(value, bool):
            assert orientation(key) is not None or key.endswith(descriptive), key


def test_orientation():
    assert orientation("iso18571_periodic.rating") == "higher"
    assert orientation("nrmse") == "lower"
    assert orientation("sprague_geers.magnitude") == "near_zero"
    assert orientation("peak_error.measured_at") is None


def test_vv20_features_closed_form():
    measured, model = 2.0 * np.sin(PHI), 2.5 * np.sin(PHI)
    result = vv20(measured, model, u_num=0.01, u_input={"peak": 0.1, "rms": 0.05},
                  u_measurement=0.03, u_measurement_rel=0.02)
    peak, rms = result.peak, result.rms
    assert (peak.data, peak.simulation, peak.error) == pytest.approx((2.0, 2.5, 0.5))
    assert rms.error == pytest.approx(0.5 / np.sqrt(2))
    assert peak.u_data == pytest.approx(np.hypot(0.03, 0.02 * 2.0))
    assert peak.u_val == pytest.approx(np.sqrt(0.01**2 + 0.1**2 + 0.03**2 + 0.04**2))
    assert rms.u_input == 0.05
    assert (peak.lower, peak.upper) == pytest.approx((0.5 - 2 * peak.u_val, 0.5 + 2 * peak.u_val))
    assert peak.normalised_error == pytest.approx(0.5 / peak.u_val)
    assert peak.resolved is True
    flat = result.as_dict()
    assert flat["peak.error"] == peak.error and flat["rms.resolved"] is True


def test_vv20_unresolved_and_random_part_from_cycles():
    amplitudes = np.array([1.9, 2.0, 2.1, 2.0])
    cycles = amplitudes[:, None] * np.sin(PHI)
    as_data_array = xr.DataArray(cycles.T, dims=("angle", "cycle"))
    result = vv20(cycles.mean(axis=0), 2.02 * np.sin(PHI), cycles=as_data_array, k=2.0)
    random_peak = np.std(amplitudes, ddof=1) / 2
    assert result.peak.u_data == pytest.approx(random_peak)
    assert result.rms.u_data == pytest.approx(random_peak / np.sqrt(2))
    assert result.peak.resolved is False  # 0.02 < 2 * 0.041


def test_vv20_zero_uncertainty_limits():
    same = vv20(wave(), wave())
    assert same.peak.normalised_error == 0.0 and same.peak.resolved is False
    assert vv20(wave(), 1.1 * wave()).peak.normalised_error == np.inf


@pytest.mark.parametrize(("kwargs", "key"), [
    ({"u_num": -0.1}, "u_num.peak"), ({"u_input": {"max": 0.1}}, "u_input"),
    ({"k": 0.0}, "k"), ({"u_measurement": float("nan")}, "u_measurement.peak")])
def test_vv20_bad_uncertainties_name_their_key(kwargs, key):
    with pytest.raises(ConfigError) as info:
        vv20(wave(), wave(), **kwargs)
    assert info.value.where["key"] == key


@pytest.mark.parametrize(("text", "score", "passed"), [
    (">= 0.8", 0.8, True), (">= 0.8", 0.79, False), ("> 0.8", 0.8, False),
    ("<= 0.1", 0.1, True), ("< 0.1", 0.1, False), ("abs <= 0.1", -0.05, True),
    ("abs <= 0.1", -0.2, False), ("  <=1e-3 ", 5e-4, True), ("> -2", -1.0, True),
    ("<= .5", 0.5, True), (">= 0", float("nan"), False), ("abs < 1", float("nan"), False)])
def test_threshold_syntax(text, score, passed):
    assert parse_threshold(text)(score) is passed


@pytest.mark.parametrize("text", ["0.8", "=> 0.8", ">= ", "== 1", ">= 0.8 or so", "ABS <= 1",
                                  "<= 1,5", 0.8])
def test_bad_threshold_syntax_names_the_key(text):
    with pytest.raises(ConfigError, match="not understood") as info:
        check_thresholds({"nrmse": 0.05}, {"nrmse": text}, key_path="comparisons.torque.thresholds")
    assert info.value.where["key"] == "comparisons.torque.thresholds.nrmse"
    assert "abs <= 0.1" in str(info.value)  # the hint shows the syntax


def test_check_thresholds():
    scores = compare(wave(), 1.05 * wave(2.0))
    checks = check_thresholds(scores, {"iso18571_periodic.rating": ">= 0.8", "nrmse": "<= 0.01",
                                       "sprague_geers.magnitude": "abs <= 0.1"})
    assert [c.metric for c in checks] == ["iso18571_periodic.rating", "nrmse",
                                          "sprague_geers.magnitude"]
    assert [c.passed for c in checks] == [True, False, True]
    assert checks[1] == ThresholdCheck("nrmse", scores["nrmse"], "<= 0.01", False)
    metric, value, threshold, passed = checks[0]
    assert (metric, threshold, passed) == ("iso18571_periodic.rating", ">= 0.8", True)
    assert value == scores["iso18571_periodic.rating"]


def test_check_thresholds_unknown_or_text_score():
    scores = compare(wave(), wave(), metrics=("nrmse", "iso18571_periodic"))
    with pytest.raises(ConfigError, match=r"'iso18571\.rating', which was not computed") as info:
        check_thresholds(scores, {"iso18571.rating": ">= 0.8"}, key_path="scene.thresholds")
    assert info.value.where["key"] == "scene.thresholds.iso18571.rating"
    assert "iso18571_periodic.rating" in str(info.value)  # the hint lists what exists
    with pytest.raises(ConfigError, match="not a number"):
        check_thresholds(scores, {"nrmse.normaliser": ">= 1"})


def test_errors_survive_pickling():
    with pytest.raises(ConfigError) as info:
        check_thresholds({"nrmse": 0.1}, {"nrmse": "big"})
    again = pickle.loads(pickle.dumps(info.value))
    assert str(again) == str(info.value)


@given(st.floats(0.5, 1.5), st.floats(-20, 20))
def test_compare_agrees_with_direct_call(k, lag):
    scores = compare(wave(), k * wave(lag), metrics=("sprague_geers",))
    direct = sprague_geers(wave(), k * wave(lag), periodic=True)
    assert scores == {f"sprague_geers.{name}": value for name, value in direct.as_dict().items()}
