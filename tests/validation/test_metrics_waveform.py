"""Sprague-Geers, Russell, NRMSE, Pearson r, peak error and circular lag against closed forms."""

from __future__ import annotations

import hypothesis.extra.numpy as hnp
import numpy as np
import pytest
import xarray as xr
from hypothesis import given
from hypothesis import strategies as st

from rigval.acquisition.errors import ConfigError, DataError
from rigval.validation.metrics import waveform as wf
from tests.validation.revolution_grid import PHI, N


def wave(lag_deg: float = 0.0, n: int = N) -> np.ndarray:
    """Band-limited signal over one revolution, delayed by ``lag_deg``."""
    theta = np.arange(n) * 2 * np.pi / n - np.radians(lag_deg)
    return np.sin(theta) + 0.5 * np.sin(2 * theta + 1.0) + 0.2 * np.cos(5 * theta)


signals = hnp.arrays(np.float64, st.integers(8, 200), elements=st.floats(-10, 10)).filter(
    lambda a: np.ptp(a) > 1e-3)
factors = st.floats(0.05, 20.0)


@given(signals, factors, st.booleans())
def test_sprague_geers_pure_scaling(measured, k, periodic):
    scores = wf.sprague_geers(measured, k * measured, periodic=periodic)
    assert scores.magnitude == pytest.approx(k - 1, rel=1e-12, abs=1e-12)
    assert scores.phase == pytest.approx(0.0, abs=1e-6)  # arccos near 1: sqrt(eps) resolution
    assert scores.comprehensive == pytest.approx(np.hypot(scores.magnitude, scores.phase))
    inverted = wf.sprague_geers(measured, -k * measured, periodic=periodic)
    assert inverted.magnitude == pytest.approx(k - 1, rel=1e-12, abs=1e-12)
    assert inverted.phase == pytest.approx(1.0, abs=1e-6)


@given(st.floats(0.0, 180.0))
def test_sprague_geers_phase_of_shifted_sinusoid(angle_deg):
    phi = np.radians(angle_deg)
    scores = wf.sprague_geers(np.sin(PHI), np.sin(PHI - phi), periodic=True)
    assert scores.phase == pytest.approx(phi / np.pi, abs=1e-7)
    assert scores.magnitude == pytest.approx(0.0, abs=1e-12)
    # an interval whose both ends are samples: the trapezoid rule is exact as well
    closed = np.linspace(0, 2 * np.pi, N + 1)
    trapezoid = wf.sprague_geers(np.sin(closed), np.sin(closed - phi))
    assert trapezoid.phase == pytest.approx(phi / np.pi, abs=1e-7)


pairs = st.integers(8, 200).flatmap(lambda n: st.tuples(
    *[hnp.arrays(np.float64, n, elements=st.floats(-10, 10)).filter(lambda a: np.ptp(a) > 1e-3)]
    * 2))


@given(pairs)
def test_sprague_geers_symmetries(pair):
    a, b = pair
    forward, backward = wf.sprague_geers(a, b), wf.sprague_geers(b, a)
    assert forward.phase == pytest.approx(backward.phase, abs=1e-12)
    assert (1 + forward.magnitude) * (1 + backward.magnitude) == pytest.approx(1.0, rel=1e-12)


@given(signals, factors)
def test_russell_pure_scaling_closed_form(measured, k):
    scores = wf.russell(measured, k * measured)
    m = (k**2 - 1) / k
    assert scores.magnitude == pytest.approx(np.sign(m) * np.log10(1 + abs(m)), abs=1e-12)
    assert scores.comprehensive == pytest.approx(
        np.sqrt(np.pi / 4 * (scores.magnitude**2 + scores.phase**2)), abs=1e-15)


def test_russell_is_antisymmetric_in_over_and_under_prediction():
    measured = wave()
    double, half = wf.russell(measured, 2 * measured), wf.russell(measured, 0.5 * measured)
    assert double.magnitude == pytest.approx(np.log10(2.5), abs=1e-12)  # 0.398
    assert half.magnitude == pytest.approx(-double.magnitude, abs=1e-12)
    forward, backward = wf.russell(measured, wave(30)), wf.russell(wave(30), measured)
    assert forward.magnitude == pytest.approx(-backward.magnitude, abs=1e-12)
    assert forward.phase == pytest.approx(wf.sprague_geers(measured, wave(30)).phase)


@pytest.mark.parametrize(("normaliser", "scale"), [
    ("range", lambda m: np.ptp(m)), ("rms", lambda m: np.sqrt(np.mean(m**2))),
    ("peak", lambda m: np.abs(m).max())])
@given(offset=st.floats(-5, 5))
def test_nrmse_of_an_offset(normaliser, scale, offset):
    measured = wave()
    scores = wf.nrmse(measured, measured + offset, normaliser=normaliser)
    assert scores.rmse == pytest.approx(abs(offset), abs=1e-12)
    assert scores.nrmse == pytest.approx(abs(offset) / scale(measured), abs=1e-12)
    assert scores.normaliser == normaliser
    assert scores.normaliser_value == pytest.approx(scale(measured))


def test_nrmse_rms_is_relative_l2_error():
    measured, model = wave(), 1.2 * wave(10)
    expected = np.linalg.norm(model - measured) / np.linalg.norm(measured)
    assert wf.nrmse(measured, model, "rms").nrmse == pytest.approx(expected, rel=1e-12)


def test_nrmse_bad_normaliser():
    with pytest.raises(ConfigError, match="unknown NRMSE normaliser") as info:
        wf.nrmse(wave(), wave(), normaliser="mean")
    assert info.value.where["key"] == "normaliser"
    with pytest.raises(DataError, match="range is zero"):
        wf.nrmse(np.ones(10), np.arange(10.0))


@given(signals, st.floats(0.1, 10), st.floats(-10, 10))
def test_pearson_ignores_scale_and_offset(measured, k, offset):
    assert wf.pearson_r(measured, k * measured + offset).pearson_r == pytest.approx(1.0, abs=1e-9)
    assert wf.pearson_r(measured, offset - k * measured).pearson_r == pytest.approx(-1.0, abs=1e-9)


def test_pearson_matches_numpy_and_is_symmetric():
    a, b = wave(), wave(40) + 0.1 * np.cos(9 * PHI)
    r = wf.pearson_r(a, b).pearson_r
    assert r == pytest.approx(np.corrcoef(a, b)[0, 1], abs=1e-14)
    assert r == pytest.approx(wf.pearson_r(b, a).pearson_r, abs=1e-15)
    with pytest.raises(DataError, match="measured signal is constant"):
        wf.pearson_r(np.ones(10), np.arange(10.0))


def test_peak_error_value_and_angle():
    degrees = np.degrees(PHI)
    scores = wf.peak_error(np.sin(PHI), 1.1 * np.sin(PHI - np.radians(10)), degrees,
                        period=360.0)
    assert scores.measured_peak == pytest.approx(1.0)
    assert scores.model_peak == pytest.approx(1.1)
    assert scores.error == pytest.approx(0.1)
    assert scores.relative_error == pytest.approx(0.1)
    assert (scores.measured_at, scores.model_at, scores.shift) == (90.0, 100.0, 10.0)


def test_peak_error_wraps_shift_and_keeps_polarity():
    degrees = np.degrees(PHI)
    measured = -np.exp(-((degrees - 355) / 5) ** 2) - np.exp(-((degrees + 5) / 5) ** 2)
    model = 0.8 * np.roll(measured, 10) + 0.85 * np.sin(PHI) ** 40  # larger positive bump
    scores = wf.peak_error(measured, model, degrees, period=360.0)
    assert scores.measured_at == 355.0 and scores.model_at == 5.0
    assert scores.shift == 10.0  # not -350
    assert scores.model_peak < 0  # the model's extreme of the measured peak's sign
    assert scores.relative_error == pytest.approx(-0.2, abs=1e-3)


def test_peak_error_uses_dataarray_coordinate():
    measured = xr.DataArray(np.sin(PHI), dims="angle", coords={"angle": PHI})
    assert wf.peak_error(measured, measured).measured_at == pytest.approx(np.pi / 2)


@pytest.mark.parametrize("samples", [-90, -1, 0, 7, 179])
def test_circular_lag_of_whole_samples(samples):
    lag = wf.circular_lag(wave(), np.roll(wave(), samples), PHI)
    assert lag.lag_deg == pytest.approx(samples * 360 / N, abs=1e-9)
    assert lag.correlation == pytest.approx(1.0, abs=1e-12)


@given(st.floats(-179.0, 179.0))
def test_circular_lag_recovers_any_shift(lag_deg):
    lag = wf.circular_lag(wave(), wave(lag_deg))
    assert lag.lag_deg == pytest.approx(lag_deg, abs=1e-8)
    assert wf.circular_lag(wave(lag_deg), wave()).lag_deg == pytest.approx(-lag_deg, abs=1e-8)


def test_circular_lag_of_odd_length_and_noisy_signal():
    n = 361
    rng = np.random.default_rng(1)
    measured = wave(0, n) + 0.05 * rng.normal(size=n)
    lag = wf.circular_lag(measured, wave(12.5, n))
    assert lag.lag_deg == pytest.approx(12.5, abs=0.3)


def test_circular_lag_checks_the_angle_grid():
    on_grid = xr.DataArray(wave(), dims="angle", coords={"angle": np.degrees(PHI)})
    with pytest.raises(DataError, match="degrees"):
        wf.circular_lag(on_grid, wave())
    with pytest.raises(DataError, match="repeats the first"):
        wf.circular_lag(wave(0, N + 1), wave(0, N + 1), np.linspace(0, 2 * np.pi, N + 1))
    with pytest.raises(DataError, match="degrees"):
        wf.circular_lag(wave(), wave(), np.degrees(PHI))
    with pytest.raises(DataError, match="constant"):
        wf.circular_lag(np.ones(N), wave())


def test_scores_as_dict_are_plain_python():
    scores = wf.sprague_geers(wave(), 1.1 * wave(5))
    values = scores.as_dict()
    assert list(values) == ["magnitude", "phase", "comprehensive"]
    assert all(type(v) is float for v in values.values())
    assert wf.nrmse(wave(), wave(3)).as_dict()["normaliser"] == "range"


def test_zero_energy_is_refused():
    with pytest.raises(DataError, match="model signal is zero everywhere"):
        wf.sprague_geers(wave(), np.zeros(N))
    with pytest.raises(DataError, match="measured signal is zero everywhere"):
        wf.russell(np.zeros(N), wave())
