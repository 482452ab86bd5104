"""The virtual rig's departures from the rigid planar model, checked against independent physics.

Each check compares a run with a departure against the same seed without it (every other draw is
the same), or against a closed form.
"""

from __future__ import annotations

import json
import tomllib

import numpy as np
import pytest
from nptdms import TdmsFile
from scipy.signal import welch

from rigval.acquisition.errors import ConfigError
from rigval.processing.bridge import strain_from_ratio
from rigval.sample_data import Imperfections, RigSettings, load_truth, simulate_rig
from rigval.sample_data.departures import Departures, resonance
from rigval.validation.cli import main

#: An ideal rig apart from the sensor noise: the departures are then all that differs.
QUIET = Imperfections.none()


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    """The same seed without and with a mode of rod B, rod bending, errors, a lag, a split."""
    base = RigSettings(speed=1.0, duration=8.0, seed=5, imperfections=QUIET)
    plain = simulate_rig(tmp_path_factory.mktemp("plain"), base)
    departed = Departures(mode_body="B", mode_hz=23.0, mode_damping=0.03, mode_level=0.08,
                          rod_bending=1.0, calibration_error=1.0, lag_channel="tor1",
                          lag_s=0.002, split_main=0.53, mass_scale=(("A", 1.08),))
    other = simulate_rig(tmp_path_factory.mktemp("departed"),
                         RigSettings(speed=1.0, duration=8.0, seed=5, imperfections=QUIET,
                                     departures=departed))
    return plain, other


def test_resonance_matches_the_closed_form_frequency_response():
    fs, fn, zeta = 1000.0, 20.0, 0.03
    t = np.arange(0.0, 12.0, 1.0 / fs)
    for f in (5.0, 20.0, 31.0):
        u = np.sin(2 * np.pi * f * t)
        y = resonance(t, u, fn, zeta)
        r = f / fn
        gain = 1.0 / np.hypot(1.0 - r**2, 2 * zeta * r)
        phase = -np.arctan2(2 * zeta * r, 1.0 - r**2)
        late = t > 8.0  # transients decayed: exp(-zeta wn 8 s) ~ 1e-13
        expected = gain * np.sin(2 * np.pi * f * t + phase)
        # linear-between-samples input: error (2 pi f / fs)^2 / 12 of the amplitude, < 4e-3
        assert np.max(np.abs(y - expected)[late]) < 4e-3 * gain, f
        acc = resonance(t, u, fn, zeta, acceleration=True)
        assert np.max(np.abs(acc + (2 * np.pi * f) ** 2 * expected)[late]) < (
            5e-3 * gain * (2 * np.pi * f) ** 2), f


def test_mode_is_the_only_difference_in_str1_and_has_its_level_and_frequency(pair):
    plain, other = pair
    a = load_truth(plain.path("truth.json")).streams["cdaq"]["str1"].to_numpy().astype(float)
    truth = load_truth(other.path("truth.json"))
    b = truth.streams["cdaq"]["str1"].to_numpy().astype(float)
    mode = b - a
    # the heavier arm changes the rigid stress too: take the mode above 12 Hz, where the rigid
    # signal has nothing (its orders fall off long before)
    f, p_mode = welch(mode, fs=5000.0, nperseg=2**14)
    band = (f > 12.0) & (f < 60.0)
    peak = f[band][np.argmax(p_mode[band])]
    assert abs(peak - 23.0) < 0.6  # Welch resolution 0.3 Hz
    record = truth.record["departures"]["mode"]
    assert record["achieved_level"] == pytest.approx(0.08, rel=1e-9)
    high = np.sqrt(np.sum(p_mode[f > 8.0]) * (f[1] - f[0]))  # the mode's broadband part
    assert high == pytest.approx(0.08 * np.ptp(a) / np.sqrt(2.0), rel=0.15)


def test_lag_delays_tor1_and_split_and_mass_reach_the_truth(pair):
    plain, other = pair
    record = json.loads(other.path("truth.json").read_text())
    channels = record["streams"]["wls1"]["channels"]
    assert channels["tor1"]["lag_s"] == 0.002 and "lag_s" not in channels["tor2"]
    assert channels["tor1"]["sensor"]["share"] == 0.53
    assert channels["tor2"]["sensor"]["share"] == pytest.approx(0.47)
    truth = load_truth(other.path("truth.json")).streams["wls1"]
    t = truth["time_true"].to_numpy()
    ratio = TdmsFile.read(other.path("wls1.tdms"))["WLS1 task"]["tor1"][:]
    delay = channels["tor1"]["input_delay_s"]
    torque = truth["tor1"].to_numpy().astype(float)
    inside = t - delay - 0.01 > t[0]

    def misfit(lag):
        x = np.interp(t - delay - lag, t, torque)[inside]
        design = np.column_stack([x, np.ones_like(x)])
        coef = np.linalg.lstsq(design, ratio[inside], rcond=None)[0]
        return np.std(ratio[inside] - design @ coef)

    assert misfit(0.002) < 0.2 * misfit(0.0)
    # the 8 % heavier arm: the main drive torque truth differs from the nominal run's
    nominal = load_truth(plain.path("truth.json")).streams["wls1"]
    whole_plain = (nominal["tor1"] + nominal["tor2"]).to_numpy()
    whole_heavy = (truth["tor1"] + truth["tor2"]).to_numpy()
    assert np.std(whole_heavy - whole_plain) > 0.01 * np.ptp(whole_plain)


def test_calibration_error_reaches_what_the_scene_states(pair):
    _, other = pair
    record = json.loads(other.path("truth.json").read_text())
    scene = tomllib.loads(other.path("scene.toml").read_text())
    cdaq = record["streams"]["cdaq"]["channels"]
    stated = scene["streams"]["cdaq"]["channels"]["str1"]["gauge_factor"]
    error = cdaq["str1"]["calibration_error"]
    assert cdaq["str1"]["sensor"]["gauge_factor"] == pytest.approx(stated * (1 + error),
                                                                   rel=1e-12)
    # read with the stated gauge factor, the stress is off by the error (1 / (1 + e))
    truth = load_truth(other.path("truth.json")).streams["cdaq"]
    t = truth["time_true"].to_numpy()
    ratio = TdmsFile.read(other.path("cdaq.tdms"))["cDAQ1 task"]["str1"][:]
    sensor = cdaq["str1"]["sensor"]
    stress = sensor["youngs_modulus"] * strain_from_ratio(ratio, "half_i", gauge_factor=stated,
                                                          poisson=sensor["poisson"])
    true = np.interp(t - cdaq["str1"]["input_delay_s"], t, truth["str1"].to_numpy())
    gain = np.polyfit(true - true.mean(), stress - stress.mean(), 1)[0]
    assert gain == pytest.approx(1 + error, abs=2e-4)
    errors = [c["calibration_error"] for c in cdaq.values() if "calibration_error" in c]
    assert len(errors) == 6 and all(abs(e) < 0.1 for e in errors)  # 5 sigma of 2 %


def test_face_gauges_carry_axial_plus_and_minus_bending(pair):
    _, other = pair
    truth = load_truth(other.path("truth.json")).streams["cdaq"]
    s1, s2, s3 = (truth[n].to_numpy().astype(float) for n in ("str1", "str2", "str3"))
    np.testing.assert_allclose(0.5 * (s2 + s3), s1, atol=1e-6 * np.ptp(s1) + 1.0)
    bending = 0.5 * (s2 - s3)
    # the rod's own weight, 35 kg over 1.75 m, as a uniform load: M = m g cos(a) L / 8 with
    # the rod within 15 degrees of level; the mean bending stress is of that order
    weight = 35.0 * 9.81 * 1.7506 / 8.0 / (0.038 * 0.05**2 / 6.0)
    assert 0.5 * weight < abs(np.mean(bending)) < 1.5 * weight
    scene = tomllib.loads(other.path("scene.toml").read_text())
    assert scene["streams"]["cdaq"]["channels"]["str2"]["bridge"] == "quarter_I"
    assert {"str2", "str3"} <= {c["name"] for c in scene["comparisons"]}


def test_default_departures_leave_the_truth_file_as_before(pair):
    plain, _ = pair
    record = json.loads(plain.path("truth.json").read_text())
    assert "departures" not in record and "departures" not in record["settings"]


@pytest.mark.parametrize("changes", [{"mode_body": "Q"}, {"mode_body": "B", "mode_hz": 900.0},
                                     {"lag_channel": "opt1"}, {"split_main": 1.2},
                                     {"mass_scale": (("A", 0.0),)}, {"lag_channel": "str2"}])
def test_bad_departures_are_refused(changes):
    with pytest.raises(ConfigError):
        Departures(**changes).check()


def test_cli_departure_options(tmp_path, capsys):
    assert main(["simulate-rig", "--out", str(tmp_path), "--duration", "2", "--ideal",
                 "--lag", "acc1=-0.001", "--split-lift", "0.45", "--mass-scale", "A=1.05"]) == 0
    record = json.loads((tmp_path / "run_1p0_truth.json").read_text())
    assert record["departures"]["lag_channel"] == "acc1"
    assert record["departures"]["mass_scale"] == {"A": 1.05}
    assert record["streams"]["wls2"]["channels"]["tor3"]["sensor"]["share"] == 0.45
    assert main(["simulate-rig", "--out", str(tmp_path), "--lag", "acc1"]) != 0
    assert "--lag 'acc1' is not NAME=NUMBER" in capsys.readouterr().err
