"""Pair shares and axial/bending on synthetic pairs of known split, lag and bending."""

from __future__ import annotations

import numpy as np
import pytest

from rigval.acquisition.errors import DataError
from rigval.validation.diagnosis.symmetry import axial_bending, pair_shares
from tests.validation.revolution_grid import PHI, N


def _load(shift: float = 0.0) -> np.ndarray:
    p = PHI - shift
    return 800.0 * np.sin(p) + 300.0 * np.cos(2.0 * p + 0.4) + 90.0 * np.sin(5.0 * p)


def _pair(share: float, seed: int, *, gains: tuple[float, float] = (0.0, 0.0), lag: float = 0.0,
          n_cycles: int = 20, noise: float = 2.0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    # the load wanders from revolution to revolution (level), each channel has its own noise
    level = 1.0 + 0.01 * rng.standard_normal((n_cycles, 1))
    a = (1.0 + gains[0]) * share * level * _load() + 7.0
    b = (1.0 + gains[1]) * (1.0 - share) * level * _load(lag) - 3.0
    return (a + noise * rng.standard_normal(a.shape), b + noise * rng.standard_normal(b.shape))


def test_share_lag_and_interval_on_a_clean_split() -> None:
    a, b = _pair(0.53, 1, lag=0.01)
    out = pair_shares(a, b, u_first=0.01, u_second=0.01, speed=2.0 * np.pi)
    # the pair's sum is not exactly the load when b lags: share to first order in the lag
    assert abs(out.share - 0.53) < 3.0 * out.u_share
    assert out.lower < 0.53 < out.upper
    assert out.asymmetric
    # the calibration part: s (1 - s) sqrt(2) 1 %
    np.testing.assert_allclose(out.u_calibration, 0.53 * 0.47 * np.sqrt(2.0) * 0.01, rtol=0.01)
    assert abs(out.lag - 0.01) < 3.0 * out.u_lag + 1e-4
    np.testing.assert_allclose(out.lag_s, out.lag / (2.0 * np.pi))


def test_gain_error_moves_the_share_by_s_one_minus_s_g() -> None:
    a, b = _pair(0.5, 2, gains=(0.02, 0.0), noise=0.0)
    out = pair_shares(a, b, u_first=0.0, u_second=0.0)
    exact = 1.02 * 0.5 / (1.02 * 0.5 + 0.5)
    np.testing.assert_allclose(out.share, exact, rtol=1e-9)


def test_common_calibration_cancels() -> None:
    a, b = _pair(0.5, 3)
    own = pair_shares(a, b, u_first=0.01, u_second=0.01, u_common=0.0098)
    np.testing.assert_allclose(own.u_calibration, 0.25 * np.sqrt(2.0 * (1e-4 - 0.0098**2)),
                               rtol=1e-6)


def test_symmetric_pair_is_flagged_about_five_percent_of_the_time() -> None:
    # gains drawn from the stated 1 %: the flag's false-alarm rate is what the interval says
    rng = np.random.default_rng(40)
    flagged, covered = 0, 0
    for seed in range(200):
        gains = tuple(rng.normal(0.0, 0.01, 2))
        a, b = _pair(0.5, seed, gains=gains)
        out = pair_shares(a, b, u_first=0.01, u_second=0.01)
        flagged += out.asymmetric
        truth = 1.0 * (1 + gains[0]) * 0.5 / ((1 + gains[0]) * 0.5 + (1 + gains[1]) * 0.5)
        covered += out.lower <= truth <= out.upper
    # 95 % interval, 200 draws: 10 expected, binomial sd 3.1
    assert flagged <= 20
    assert covered >= 180


def test_axial_and_bending_parts() -> None:
    rng = np.random.default_rng(5)
    axial = _load()
    bend = 0.2 * 800.0 * np.cos(PHI)
    a = axial + bend + rng.normal(0.0, 2.0, (20, N)) + 11.0
    b = axial - bend + rng.normal(0.0, 2.0, (20, N))
    out = axial_bending(a, b, u_first=0.01, u_second=0.01)
    np.testing.assert_allclose(out.bending_rms, 0.2 * 800.0 / np.sqrt(2.0), rtol=0.01)
    np.testing.assert_allclose(out.axial_rms, np.sqrt(np.mean(axial**2)), rtol=0.01)
    assert out.bending


def test_gain_mismatch_alone_is_not_bending() -> None:
    rng = np.random.default_rng(6)
    axial = _load()
    a = 1.01 * axial + rng.normal(0.0, 2.0, (20, N))
    b = 0.995 * axial + rng.normal(0.0, 2.0, (20, N))
    out = axial_bending(a, b, u_first=0.01, u_second=0.01)
    assert not out.bending


def test_pair_of_two_shapes_is_refused() -> None:
    with pytest.raises(DataError, match="one shape"):
        pair_shares(np.zeros((5, 10)), np.zeros((4, 10)), u_first=0.0, u_second=0.0)
    with pytest.raises(DataError, match="3 whole revolutions"):
        axial_bending(np.zeros((2, 10)), np.zeros((2, 10)), u_first=0.0, u_second=0.0)
