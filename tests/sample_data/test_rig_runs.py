"""Whole virtual-rig runs: files read back, truth equal to the model, files like NI's, seeds."""

from __future__ import annotations

import hashlib
import json
import warnings

import numpy as np
import pandas as pd
import pytest
from nptdms import TdmsFile

from rigval.acquisition import read
from rigval.acquisition.errors import DataFileError
from rigval.model import builtin_mechanism, solve
from rigval.processing.accelerometer import acceleration_from_voltage, invert_highpass
from rigval.processing.bridge import strain_from_ratio
from rigval.processing.torsion import torque_from_ratio
from rigval.sample_data import (
    Imperfections,
    RigSettings,
    load_truth,
    runs_dir,
    shipped_runs,
    simulate_rig,
)
from rigval.validation.cli import main
from rigval.validation.scene import load_scene


def _read_all(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the CSV reader notes its guesses
        streams = read(path)
    assert len(streams) == 1
    return next(iter(streams.values()))


def _file_values(path, group, channel):
    if path.suffix == ".csv":
        frame = pd.read_csv(path, sep=";", decimal=",", skiprows=2)
        column = next(c for c in frame.columns if c.startswith(channel + " "))
        return frame[column].to_numpy()
    return TdmsFile.read(path)[group][channel][:]


def _rising_edges(x, t):
    """Times of 50 % rising crossings, linearly interpolated."""
    mid = 0.5 * (np.min(x) + np.max(x))
    k = np.flatnonzero((x[:-1] < mid) & (x[1:] >= mid))
    return t[k] + (mid - x[k]) / (x[k + 1] - x[k]) * (t[k + 1] - t[k])


def test_acquisition_recovers_every_channel(rig_run):
    truth = load_truth(rig_run.path("truth.json"))
    for name, info in truth.record["streams"].items():
        path = rig_run.folder / info["file"]
        stream = _read_all(path)
        expected = truth.streams[name]
        assert set(info["channels"]) <= set(stream.data_vars)
        assert stream.sizes["time"] == expected.sizes["time"]
        # The reader's time axis is the one the device's start stamps and rate imply.
        np.testing.assert_allclose(stream["time"], expected["time_device"], rtol=0, atol=2e-6)
        np.testing.assert_array_equal(stream["segment"], expected["segment"])
        assert stream.attrs["gap_count"] == len(info["gaps"])
        for channel in info["channels"]:
            np.testing.assert_allclose(stream[channel], _file_values(path, info["group"], channel),
                                       rtol=1e-12, atol=0)


def test_ideal_run_inverts_to_the_truth(ideal_run):
    truth = load_truth(ideal_run.path("truth.json"))
    streams = truth.record["streams"]
    cdaq = truth.streams["cdaq"]
    t = cdaq["time_true"].to_numpy()
    path = ideal_run.path("cdaq.tdms")
    meta = streams["cdaq"]["channels"]
    for name in ("acc1", "acc2", "acc3"):
        sensor = meta[name]["sensor"]
        volts = _file_values(path, "cDAQ1 task", name)
        fs = streams["cdaq"]["fs_true"]
        raw = invert_highpass(volts, fs, sensor["highpass_hz"])
        accel = acceleration_from_voltage(raw, charge_sensitivity=sensor["charge_sensitivity"],
                                          amplifier_gain=sensor["amplifier_gain"])
        true = cdaq[name].to_numpy()
        error = (accel - accel.mean()) - (true - true.mean())
        # One ADC step in m s-2: quantisation (0.29 steps rms) bounds what any inversion gets.
        step = acceleration_from_voltage(meta[name]["slope"],
                                         charge_sensitivity=sensor["charge_sensitivity"],
                                         amplifier_gain=sensor["amplifier_gain"])
        assert np.sqrt(np.mean(error**2)) < 0.5 * step + 1e-3 * np.std(true), name
    bridge = meta["str1"]["sensor"]
    delay = meta["str1"]["input_delay_s"]
    strain = strain_from_ratio(_file_values(path, "cDAQ1 task", "str1"), "half_i",
                               gauge_factor=bridge["gauge_factor"], poisson=bridge["poisson"])
    stress = bridge["youngs_modulus"] * strain
    expected = np.interp(t - delay, t, cdaq["str1"].to_numpy())
    inside = t - delay >= t[0]
    lsb = 0.025 / (2**23 - 1) * 4 / bridge["gauge_factor"] / 1.3 * bridge["youngs_modulus"]
    assert np.max(np.abs(stress - expected)[inside]) < 2 * lsb + 1e-4 * np.ptp(expected)
    for name in ("enc1", "enc2"):
        counts = _file_values(path, "cDAQ1 task", name)
        true_angle = cdaq[name].to_numpy()
        angle = true_angle[0] + 2 * np.pi * counts / 8192
        assert np.all(np.abs(angle - true_angle) <= 2 * np.pi / 8192 + 1e-9), name
    opt1 = _rising_edges(_file_values(path, "cDAQ1 task", "opt1"), t)
    rises = np.array(truth.record["pulses"]["opt1"]["rise_true_s"])
    rises = rises[(rises > t[0]) & (rises < t[-1])]
    np.testing.assert_allclose(opt1, rises, atol=1e-4)
    for stream, names, opt in (("wls1", ("tor1", "tor2"), "opt2"),
                               ("wls2", ("tor3", "tor4"), "opt3")):
        data = truth.streams[stream]
        tw = data["time_true"].to_numpy()
        file = ideal_run.folder / streams[stream]["file"]
        delay = streams[stream]["channels"][names[0]]["input_delay_s"]
        inside = tw - delay >= tw[0]
        for name in names:
            sensor = streams[stream]["channels"][name]["sensor"]
            torque = torque_from_ratio(_file_values(file, "WLS1 task", name), "full",
                                       gauge_factor=sensor["gauge_factor"],
                                       shear_modulus=sensor["shear_modulus"],
                                       outer_diameter=sensor["outer_diameter"],
                                       inner_diameter=sensor["inner_diameter"])
            expected = np.interp(tw - delay, tw, data[name].to_numpy())
            error = np.abs(torque - expected)[inside]
            assert np.max(error) < 1e-3 * np.ptp(expected), name
        edges = _rising_edges(_file_values(file, "WLS1 task", opt), tw) - delay
        period = 1 / streams[stream]["fs_true"]
        rises = np.array(truth.record["pulses"][opt]["rise_true_s"])
        rises = rises[(rises > tw[0] - delay) & (rises < tw[-1] - delay)]
        # A band-limited edge timed by linear interpolation: a few hundredths of a sample.
        np.testing.assert_allclose(edges, rises, atol=0.1 * period)


def test_truth_equals_the_model_at_the_sample_times(rig_run):
    truth = load_truth(rig_run.path("truth.json"))
    drive = truth.drive
    for stream, quantity in (("cdaq", "point_acceleration"), ("wls1", "driver_torque"),
                             ("wls2", "driver_torque")):
        data = truth.streams[stream]
        t = data["time_true"].to_numpy()[::97]
        result = solve(builtin_mechanism("pendulum"), t, drives=drive.angles(t),
                       outputs=(quantity,))
        if stream == "cdaq":
            for name, point in (("acc1", "P1"), ("acc2", "P2")):
                model = result[quantity].sel(point=point, axis="x").to_numpy()
                np.testing.assert_allclose(data[name].to_numpy()[::97], model, rtol=0,
                                           atol=1e-5 * np.ptp(model))
        else:
            driver = "theta_F" if stream == "wls1" else "theta_H"
            names = ("tor1", "tor2") if stream == "wls1" else ("tor3", "tor4")
            model = result[quantity].sel(driver=driver).to_numpy()
            total = sum(data[n].to_numpy()[::97].astype(np.float64) for n in names)
            np.testing.assert_allclose(total, model, rtol=0, atol=1e-5 * np.ptp(model))


def test_truth_without_signals_has_the_same_clocks_and_needs_no_arrays(rig_run, tmp_path):
    full = load_truth(rig_run.path("truth.json"))
    light_json = tmp_path / rig_run.path("truth.json").name  # the JSON alone, no .npz beside it
    light_json.write_bytes(rig_run.path("truth.json").read_bytes())
    light = load_truth(light_json, signals=False)
    assert light.streams == {} and light.record == full.record and light.drive == full.drive
    for stream in ("wls1", "wls2"):
        assert light.clock_on_reference(stream) == full.clock_on_reference(stream)
    with pytest.raises(DataFileError, match="cannot read virtual-rig truth"):
        load_truth(light_json)  # with signals the arrays file is needed


def test_imperfect_run_pulses_and_gaps(rig_run):
    truth = load_truth(rig_run.path("truth.json"))
    record = truth.record
    for stream, opt in (("cdaq", "opt1"), ("wls1", "opt2"), ("wls2", "opt3")):
        info = record["streams"][stream]
        data = truth.streams[stream]
        t = data["time_true"].to_numpy()
        x = _file_values(rig_run.folder / info["file"], info["group"], opt)
        pulses = record["pulses"][opt]
        delay = info["channels"][opt]["input_delay_s"]
        expected = np.sort(np.array(pulses["rise_true_s"] + pulses["spurious_s"]) + delay)
        detected = []
        for segment in range(len(info["segments"])):
            chosen = data["segment"].to_numpy() == segment
            edges = _rising_edges(x[chosen], t[chosen])
            span = (t[chosen][0] + 0.002, t[chosen][-1] - 0.002)
            detected += [e for e in edges if span[0] < e < span[1]]
            expected_here = expected[(expected > span[0]) & (expected < span[1])]
            # Every pulse in the record and nothing else, each within a sample of its truth.
            inside = [e for e in edges if span[0] < e < span[1]]
            assert len(inside) == expected_here.size, (opt, segment)
            np.testing.assert_allclose(inside, expected_here, atol=1.0 / info["fs_nominal"])
        assert len(detected) > 0
    wls = record["streams"]["wls1"]
    assert len(wls["segments"]) == 2 and len(wls["gaps"]) == 1
    gap = wls["gaps"][0]
    assert 0.05 <= gap["duration_true_s"] <= 0.4
    assert abs(wls["drift_ppm"]) <= 50.0
    shares = [record["streams"]["wls1"]["channels"][n]["sensor"]["share"] for n in ("tor1", "tor2")]
    assert sum(shares) == pytest.approx(1.0) and shares[0] != 0.5


def test_files_look_like_real_ni_files(rig_run, realdata_dir):
    real_ai = TdmsFile.read(realdata_dir / "nidaqmx-python" / "data_ai.tdms")
    real_ci = TdmsFile.read(realdata_dir / "nidaqmx-python" / "data_ci1.tdms")
    ours = TdmsFile.read(rig_run.path("cdaq.tdms"))
    real_ai_channel = real_ai.groups()[0].channels()[0]
    real_ci_channel = real_ci.groups()[0].channels()[0]
    assert [g.name for g in ours.groups()] == ["cDAQ1 task"]
    for channel in ours.groups()[0].channels():
        real = real_ci_channel if channel.name.startswith("enc") else real_ai_channel
        assert set(real.properties) == set(channel.properties), channel.name
        for key in ("NI_Scaling_Status", "NI_Scale[1]_Scale_Type", "wf_start_offset",
                    "wf_samples", "NI_Number_Of_Scales"):
            assert channel.properties[key] == real.properties[key]
        raw = channel.read_data(scaled=False)
        expected = np.uint32 if channel.name.startswith("enc") else (
            np.int32 if channel.name == "str1" else np.int16)
        assert list(raw) == [0] and raw[0].dtype == expected
        assert channel[:].dtype == np.float64
    assert set(ours.properties) == set(real_ai.properties)
    wls = TdmsFile.read(rig_run.path("wls1.tdms"))
    assert wls["WLS1 task"]["tor1"].properties["wf_increment"] == pytest.approx(31 / 50000)
    frame = pd.read_csv(rig_run.path("wls2.csv"), sep=";", decimal=",", skiprows=2)
    assert list(frame.columns) == ["Time [s]", "tor3 [V/V]", "tor4 [V/V]", "opt3 [V/V]"]
    assert all(dtype == np.float64 for dtype in frame.dtypes)


def test_scene_parses_and_carries_the_generated_calibration(rig_run):
    scene = load_scene(rig_run.path("scene.toml"))
    record = json.loads(rig_run.path("truth.json").read_text())
    channels = scene.streams["cdaq"].channels
    acc1 = record["streams"]["cdaq"]["channels"]["acc1"]["sensor"]
    assert channels["acc1"].params["charge_sensitivity"] == acc1["charge_sensitivity"]
    assert channels["acc1"].params["amplifier_gain"] == pytest.approx(
        acc1["amplifier_gain"] * 1e-3)
    tor3 = record["streams"]["wls2"]["channels"]["tor3"]["sensor"]
    assert scene.streams["wls2"].channels["tor3"].params["gauge_factor"] == tor3["gauge_factor"]
    theta_h = scene.model.drivers["theta_H"].angle_at_reference
    assert theta_h == record["angle_at_reference"]["theta_H"]


def _digest(files):
    return [hashlib.sha256(p.read_bytes()).hexdigest() for p in files]


def test_same_seed_gives_the_same_bytes(tmp_path):
    args = ["simulate-rig", "--speed", "0.9", "--duration", "2", "--seed", "11"]
    assert main([*args, "--out", str(tmp_path / "a")]) == 0
    assert main([*args, "--out", str(tmp_path / "b")]) == 0
    a = sorted((tmp_path / "a").iterdir())
    b = sorted((tmp_path / "b").iterdir())
    assert [p.name for p in a] == [p.name for p in b] and len(a) == 7
    assert _digest(a) == _digest(b)
    assert main([*args[:-1], "12", "--out", str(tmp_path / "c")]) == 0
    c = sorted((tmp_path / "c").iterdir())
    assert all(x != y for x, y in zip(_digest(a), _digest(c), strict=True))


def test_shipped_runs_regenerate_byte_for_byte(tmp_path):
    scenes = shipped_runs()
    assert len(scenes) >= 2
    total = sum(p.stat().st_size for p in runs_dir().iterdir())
    assert total < 20e6
    for scene in scenes:
        stem = scene.name.removesuffix("_scene.toml")
        record = json.loads((scene.parent / f"{stem}_truth.json").read_text())
        settings = dict(record["settings"])
        settings["imperfections"] = Imperfections(**settings["imperfections"])
        files = simulate_rig(tmp_path, RigSettings(**settings))
        assert files.stem == stem
        shipped = [scene.parent / p.name for p in files.files]
        changed = [p.name for p, a, b in zip(shipped, _digest(files.files), _digest(shipped),
                                             strict=True) if a != b]
        assert set(changed) <= {f"{stem}_truth.npz"}, f"{stem}: files differ: {changed}"
        # The truth arrays carry the model's numerics to the last bit of float32; a later change
        # of the model's arithmetic may move last bits (then rewrite the shipped runs with the
        # commands of sample_data/README.md), never more than 1e-6 of a signal's range.
        with np.load(files.path("truth.npz")) as new, np.load(shipped[-1]) as old:
            assert new.files == old.files
            for key in new.files:
                span = float(np.ptp(old[key]))
                np.testing.assert_allclose(new[key], old[key], rtol=0, atol=1e-6 * span,
                                           err_msg=key)


def test_cli_options_reach_the_rig(tmp_path):
    args = ["simulate-rig", "--out", str(tmp_path), "--duration", "2", "--seed", "3", "--ideal",
            "--dropouts", "2", "--index-reset"]
    assert main(args) == 0
    record = json.loads((tmp_path / "run_1p0_truth.json").read_text())
    wls1 = record["streams"]["wls1"]
    assert len(wls1["segments"]) == 3 and wls1["drift_ppm"] == 0.0
    assert all(s["stamp_error_s"] == 0.0 for s in wls1["segments"])
    assert wls1["channels"]["tor1"]["sensor"]["share"] == 0.5
    assert record["streams"]["cdaq"]["channels"]["enc1"]["sensor"]["index_reset"] is True
    counts = TdmsFile.read(tmp_path / "run_1p0_cdaq.tdms")["cDAQ1 task"]["enc1"][:]
    assert counts.max() < 8192 and np.any(np.diff(counts) < 0)  # reloaded at the index
