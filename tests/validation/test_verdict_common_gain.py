"""The common-gain statement: a gain on one channel that no shared calibration error explains."""

import math

import numpy as np
import pytest

from rigval.acquisition.errors import ConfigError
from rigval.validation.metrics.vv20 import common_gain, vv20_curve
from tests.validation.revolution_grid import PHI


def test_curve_gain_and_its_own_uncertainty_closed_form():
    data = 50.0 + 100.0 * np.sin(PHI) + 30.0 * np.cos(2 * PHI)
    centred = data - data.mean()
    # model: 1.5 % larger about its mean, with another offset and a shape error orthogonal
    # to the measurement (sin 3 phi)
    model = data.mean() + 7.0 + 1.015 * centred + 2.0 * np.sin(3 * PHI)
    size = math.sqrt(np.mean(centred**2))
    scores = vv20_curve(data, model, u_measurement_rel=0.01, u_measurement_rel_common=0.006,
                        u_num=0.3)
    assert scores.gain == pytest.approx(0.015, rel=1e-12)
    # own calibration part sqrt(0.01^2 - 0.006^2) = 0.008; the grid part bounded as a gain
    assert scores.u_gain_own == pytest.approx(math.hypot(0.008, 0.3 / size), rel=1e-12)
    whole = vv20_curve(data, model, u_measurement_rel=0.01)
    assert whole.u_gain_own == pytest.approx(0.01, rel=1e-12)
    with pytest.raises(ConfigError, match="exceeds u_measurement_rel"):
        vv20_curve(data, model, u_measurement_rel=0.01, u_measurement_rel_common=0.02)


def test_two_comparisons_closed_form():
    gains = {"F": (-0.013, 0.0025), "H": (-0.001, 0.003)}
    out = common_gain(gains)
    s2 = 1 / (1 / 0.0025**2 + 1 / 0.003**2)
    assert out["F"].group_gain == pytest.approx(s2 * (-0.013 / 0.0025**2 - 0.001 / 0.003**2))
    # with two, both see the same normalised difference (g_F - g_H) / sqrt(u_F^2 + u_H^2)
    z = (-0.013 + 0.001) / math.hypot(0.0025, 0.003)
    assert out["F"].normalised_error == pytest.approx(z, rel=1e-12)
    assert out["H"].normalised_error == pytest.approx(-z, rel=1e-12)
    assert out["F"].detected and out["H"].detected and out["F"].group == "F, H"
    agree = common_gain({"F": (0.004, 0.0025), "H": (0.003, 0.003)})
    assert not any(s.detected for s in agree.values())


def test_shared_calibration_error_is_not_detected_and_false_alarms_are_rare():
    """A common gain of any size cancels; the rate of |z| > 2 is that of a normal variable."""
    rng = np.random.default_rng(7)
    own = np.array([0.002, 0.003, 0.0015])
    z, detected = [], 0
    for _ in range(4000):
        gains = rng.normal(0.0, own) + rng.normal(0.0, 0.05)    # common error 5 % (huge)
        out = common_gain({name: (g, u) for name, g, u in zip("abc", gains, own, strict=True)})
        z += [s.normalised_error for s in out.values()]
        detected += out["a"].detected
    # each z is standard normal under "no model error": std 1 within 3 % (8000+ samples),
    # rate of detection at k = 2 is 4.55 % +- 3 binomial sigma (0.99 %) of 4000
    assert np.std(z) == pytest.approx(1.0, abs=0.03)
    assert abs(detected / 4000 - 0.0455) < 0.0099


def test_bad_groups():
    with pytest.raises(ConfigError, match="two comparisons or more"):
        common_gain({"F": (0.0, 0.01)})
    with pytest.raises(ConfigError, match="finite and positive"):
        common_gain({"F": (0.0, 0.01), "H": (0.0, math.inf)})


def test_gain_uncertainty_from_cycles_and_not_from_shifts():
    data = 100.0 * np.sin(PHI) + 20.0 * np.sin(2 * PHI + 0.3)
    centred = data - data.mean()
    eps = np.array([0.004, -0.002, 0.001, -0.003, 0.0])
    cycles = data + (eps - eps.mean())[:, None] * centred
    scores = vv20_curve(data, data, cycles=cycles, u_measurement_rel=0.01,
                        u_measurement_rel_common=0.01, u_time=0.01, speed=5.0,
                        u_drive_angle=0.002)
    # per-cycle gains are eps - mean(eps): their std / sqrt(5); a time or drive-angle shift
    # moves the curve along phi (slope), orthogonal to it: no share in the gain
    assert scores.u_gain_own == pytest.approx(np.std(eps, ddof=1) / math.sqrt(5), rel=1e-9)
    assert scores.u_alignment > 0.1 and scores.u_drive > 0.1
