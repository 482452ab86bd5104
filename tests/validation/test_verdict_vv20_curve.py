"""The V&V 20 curve verdict: closed forms of each part of u_val and its behaviour under noise."""

import math

import numpy as np
import pytest

from rigval.acquisition.errors import ConfigError
from rigval.validation.metrics.compare import compare
from rigval.validation.metrics.vv20 import CURVE_PARTS, vv20_curve
from tests.validation.revolution_grid import PHI, N


def test_gain_error_against_calibration():
    data = 100.0 * np.sin(PHI)
    scores = vv20_curve(data, 1.03 * data, u_measurement_rel=0.01)
    assert scores.error == pytest.approx(3.0 / math.sqrt(2), rel=1e-12)
    assert scores.u_calibration == pytest.approx(1.0 / math.sqrt(2), rel=1e-12)
    assert scores.u_val == pytest.approx(scores.u_calibration)
    assert scores.detected and scores.dominant == "u_calibration"
    assert "Model error detected (|E| > k u_val)" in scores.statement("N m")
    within = vv20_curve(data, 1.015 * data, u_measurement_rel=0.01)
    assert not within.detected
    assert within.statement().startswith("Model error not detected (|E| <= k u_val)")


def test_alignment_and_drive_parts_follow_the_slopes():
    data, model = np.sin(PHI), 2.0 * np.sin(PHI)
    scores = vv20_curve(data, model, u_time=1e-3, speed=2 * np.pi, u_drive_angle=1e-3)
    # rms of |d sin/dphi| = 1/sqrt(2); central differences: relative error h^2/6 ~ 5e-5
    assert scores.u_alignment == pytest.approx(2 * np.pi * 1e-3 / math.sqrt(2), rel=1e-4)
    assert scores.u_drive == pytest.approx(2.0 * 1e-3 / math.sqrt(2), rel=1e-4)
    total = math.sqrt(sum(getattr(scores, p) ** 2 for p in CURVE_PARTS))
    assert scores.u_val == pytest.approx(total, rel=1e-12)


def test_scatter_part_and_false_alarm_rate():
    """With the right model and only noise, E is about u_scatter: rarely detected at k = 2."""
    rng = np.random.default_rng(5)
    truth = np.sin(PHI) + 0.3 * np.sin(3 * PHI)
    detected = 0
    for _ in range(200):
        cycles = truth + 0.05 * rng.standard_normal((16, N))
        scores = vv20_curve(cycles.mean(axis=0), truth, cycles=cycles)
        assert scores.u_scatter == pytest.approx(0.05 / 4, rel=0.05)
        detected += scores.detected
    assert detected == 0     # E^2 ~ u_scatter^2 chi2(360)/360: E/u_val > 2 is out of reach


def test_scores_are_in_compare_and_bad_input():
    scores = compare(np.sin(PHI), 1.2 * np.sin(PHI), metrics=("vv20",),
                     uncertainty={"u_measurement_rel": 0.05, "u_time": 0.0, "speed": 5.0})
    assert scores["vv20.curve.detected"] is True
    assert scores["vv20.curve.normalised_error"] > 2
    with pytest.raises(ConfigError, match="u_time"):
        vv20_curve(np.sin(PHI), np.sin(PHI), u_time=-1.0)
    with pytest.raises(ConfigError, match="coverage factor"):
        vv20_curve(np.sin(PHI), np.sin(PHI), k=0.0)
