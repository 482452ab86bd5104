"""Virtual rig, stage by stage: drive law, sensors, devices and writers, checked independently."""

from __future__ import annotations

import itertools
import struct

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from nptdms import TdmsFile

from rigval.acquisition.errors import ConfigError
from rigval.sample_data import RigSettings, run_stem
from rigval.sample_data.devices import MODULES, dropout_segments
from rigval.sample_data.drive import DriveMotion, Harmonic, SpeedWander
from rigval.sample_data.rig import Imperfections, draw_rig
from rigval.sample_data.sensors import Encoder, OpticalSensor, PulseTrain, optical_pulses
from rigval.sample_data.tdms_writer import Acquisition, RawChannel, write_daqmx_tdms
from rigval.sample_data.writers import write_european_csv, write_npz
from rigval.validation.cli import main

DRIVE = DriveMotion(1.1, 1.46, 4.59, (Harmonic(0.05, 1, 0.0), Harmonic(0.007, 2, 1.0)),
                    (Harmonic(0.1, 1, 0.0), Harmonic(0.005, 2, 2.0)),
                    (SpeedWander(0.9, 0.003, 0.4), SpeedWander(2.1, 0.002, 1.3)))


def test_drive_derivatives_equal_finite_differences():
    t = np.linspace(0.0, 5.0, 101)
    h = 1e-5
    for name in ("theta_F", "theta_H"):
        _angle, speed, accel = DRIVE.angles(t)[name]
        plus, minus = DRIVE.angles(t + h)[name], DRIVE.angles(t - h)[name]
        np.testing.assert_allclose(speed, (plus[0] - minus[0]) / (2 * h), rtol=0, atol=1e-7)
        np.testing.assert_allclose(accel, (plus[1] - minus[1]) / (2 * h), rtol=0, atol=1e-5)
        assert np.all(speed > 0)


def test_drive_without_wander_is_the_mechanism_law():
    omega = 2 * np.pi
    drive = DriveMotion(1.0, 1.4613, 4.5895, (Harmonic(0.05, 1, 0.0),), (Harmonic(0.1, 1, 0.0),))
    t = np.linspace(0.0, 3.0, 50)
    np.testing.assert_allclose(drive.angles(t)["theta_F"][0],
                               1.4613 + omega * t + 0.05 * np.sin(omega * t), atol=1e-12)
    np.testing.assert_allclose(drive.angles(t)["theta_H"][0],
                               4.5895 + 2 * omega * t + 0.1 * np.sin(omega * t), atol=1e-12)


def test_crossing_times_invert_the_angle_law():
    targets = DRIVE.theta_f0 + np.linspace(0.3, 40.0, 37)
    times = DRIVE.crossing_times("theta_F", targets)
    np.testing.assert_allclose(DRIVE.angles(times)["theta_F"][0], targets, atol=1e-11)
    targets_h = DRIVE.theta_h0 + 2 * np.pi * np.arange(1, 20)
    times_h = DRIVE.crossing_times("theta_H", targets_h)
    np.testing.assert_allclose(DRIVE.angles(times_h)["theta_H"][0], targets_h, atol=1e-11)


def _brute_force_counts(angle, start, cpr):
    """Count edges (multiples of 2 pi / cpr) in (start, angle] one by one."""
    edges = np.arange(np.floor(start * cpr / (2 * np.pi)) + 1,
                      np.floor(angle.max() * cpr / (2 * np.pi)) + 1) * 2 * np.pi / cpr
    return np.searchsorted(edges, angle, side="right")


def test_encoder_counts_cumulative_and_with_index_reset():
    cpr = 64
    angle = np.linspace(0.31, 0.31 + 3.5 * 2 * np.pi, 5001)
    cumulative = Encoder(cpr, 2.0, False).counts(angle, angle[0]).astype(np.int64)
    np.testing.assert_array_equal(cumulative, _brute_force_counts(angle, angle[0], cpr))
    reset = Encoder(cpr, 2.0, True).counts(angle, angle[0]).astype(np.int64)
    assert reset.min() == 0 and reset.max() == cpr - 1
    drops = np.flatnonzero(np.diff(reset) < 0) + 1
    assert drops.size == 4  # index at 2.0 + 2 pi k: passed at 2.0, 8.3, 14.6 and 20.8 rad
    # After each reload the counter holds the edges passed since the index position.
    index_edge = np.ceil(2.0 * cpr / (2 * np.pi))
    for k in drops:
        edges_since = np.floor(angle[k] * cpr / (2 * np.pi)) - (
            index_edge + cpr * np.floor((angle[k] * cpr / (2 * np.pi) - index_edge) / cpr))
        assert reset[k] == edges_since
    before = np.arange(drops[0])
    np.testing.assert_array_equal(reset[before], cumulative[before])


def test_pulse_train_edges_at_half_level():
    train = PulseTrain(np.array([0.01, 0.03]), np.array([0.015, 0.036]), 0.5, 4.5, 1e-4)
    t = np.linspace(0.0, 0.05, 500001)
    x = train.value(t)
    assert x.min() == pytest.approx(0.5, abs=1e-9) and x.max() == pytest.approx(4.5, abs=1e-9)
    above = x > 2.5
    rises = t[np.flatnonzero(~above[:-1] & above[1:]) + 1]
    np.testing.assert_allclose(rises, [0.01, 0.03], atol=2e-7)
    # 10-90 % rise time as set.
    first = (t > 0.009) & (t < 0.011)
    t10 = t[first][np.argmax(x[first] > 0.9)]
    t90 = t[first][np.argmax(x[first] > 4.1)]
    assert t90 - t10 == pytest.approx(1e-4, rel=1e-3)


def test_optical_pulses_record_missing_and_spurious():
    sensor = OpticalSensor(0.0, 5.0, 1e-4, 0.0, np.deg2rad(10.0), 0.0)
    rng = np.random.default_rng(5)
    train, record = optical_pulses(sensor, DRIVE, "theta_F", DRIVE.theta_f0, 0.0, 60.0, rng,
                                   0.3, 30.0)
    turns = len(record["rise_true_s"]) + len(record["missing_true_s"])
    first, last = (DRIVE.angles(np.array([0.0, 60.0]))["theta_F"][0] - DRIVE.theta_f0) / (2 * np.pi)
    expected = np.floor(last) - np.ceil(first) + 1
    assert turns == expected
    assert 0 < len(record["missing_true_s"]) < turns
    assert len(record["spurious_s"]) > 0
    assert train.rises.size == len(record["rise_true_s"]) + len(record["spurious_s"])
    np.testing.assert_allclose(np.sort(np.concatenate([record["rise_true_s"],
                                                       record["spurious_s"]])), train.rises)


def test_module_quantisation_and_delay():
    module = MODULES["NI 9215"]
    values = np.linspace(-12.0, 12.0, 1001)
    codes, slope = module.quantise(values, 10.0)
    assert codes.dtype == np.int16 and slope == pytest.approx(10.0 / 32767)
    inside = np.abs(values) <= 10.0
    assert np.max(np.abs(codes[inside] * slope - values[inside])) <= slope / 2 + 1e-15
    assert codes.max() == 32767 and codes.min() == -32768
    assert MODULES["NI 9237"].quantise([0.0], 0.025)[0].dtype == np.int32
    assert MODULES["NI 9237"].delay(50000 / 31) == pytest.approx(0.0248106, abs=1e-7)
    assert MODULES["NI 9237"].delay(5000.0) == pytest.approx((40 + 5 / 512) / 5000 + 4.5e-6)
    assert MODULES["NI 9215"].delay(5000.0) == 0.0


def test_dropout_segments_do_not_overlap():
    rng = np.random.default_rng(2)
    fs = 1612.9
    segments = dropout_segments(0.4, 20.0, fs, 3, 0.02, rng)
    assert len(segments) == 4
    for a, b in itertools.pairwise(segments):
        gap = b.true_start - (a.true_start + a.n_samples / fs)
        assert 0.05 - 1 / fs <= gap <= 0.4 + 1 / fs
    assert segments[0].true_start == 0.4
    span = segments[-1].true_start + segments[-1].n_samples / fs - 0.4
    assert span == pytest.approx(20.0, abs=1 / fs)


def test_daqmx_tdms_round_trip_with_restart(tmp_path):
    rng = np.random.default_rng(1)
    a = rng.integers(-32768, 32767, 5000).astype(np.int16)
    b = rng.integers(-2**23, 2**23, 5000).astype(np.int32)
    c = np.cumsum(rng.integers(0, 5, 5000)).astype(np.uint32)
    first = Acquisition("task", np.datetime64("2026-03-10T08:00:01.250000001", "ns"), 1e-3,
                        (RawChannel("a", a, 3e-4, 0.1, "Volts"),
                         RawChannel("b", b, 3e-9, 0.0, "V/V"), RawChannel("c", c, 1.0, 0.0, None)))
    second = Acquisition("task", np.datetime64("2026-03-10T08:00:09", "ns"), 1e-3,
                         tuple(RawChannel(ch.name, ch.raw[:700], ch.slope, ch.intercept, ch.unit)
                               for ch in first.channels))
    path = write_daqmx_tdms(tmp_path / "x.tdms", [first, second], block_samples=1000,
                            file_name="x")
    tdms = TdmsFile.read(path)
    group = tdms["task"]
    for ch in first.channels:
        channel = group[ch.name]
        raw = channel.read_data(scaled=False)
        assert list(raw) == [0] and raw[0].dtype == ch.raw.dtype  # DAQmx raw: one scaler
        np.testing.assert_array_equal(raw[0], np.concatenate([ch.raw, ch.raw[:700]]))
        np.testing.assert_allclose(channel[:5000], ch.raw * ch.slope + ch.intercept, rtol=1e-15)
        assert channel.properties["wf_start_time"] == np.datetime64("2026-03-10T08:00:09")
    assert "unit_string" not in group["c"].properties
    # Lead-in of every segment: TDSm, DAQmx raw interleaved ToC 0xAE, version 4713.
    data = path.read_bytes()
    pos, starts = 0, []
    while pos < len(data):
        tag, toc, version, next_offset, _ = struct.unpack("<4sIIQQ", data[pos:pos + 28])
        assert (tag, toc, version) == (b"TDSm", 0xAE, 4713)
        starts.append(pos)
        pos += 28 + next_offset
    assert pos == len(data) and len(starts) == 6


def test_daqmx_tdms_rejects_mismatched_lengths(tmp_path):
    acq = Acquisition("g", np.datetime64("2026-01-01T00:00:00", "ns"), 1e-3,
                      (RawChannel("a", np.zeros(3, np.int16), 1.0, 0.0, "V"),
                       RawChannel("b", np.zeros(4, np.int16), 1.0, 0.0, "V")))
    with pytest.raises(ConfigError, match="differ in length"):
        write_daqmx_tdms(tmp_path / "bad.tdms", [acq])


def test_european_csv_reads_back_in_pandas(tmp_path):
    time = np.arange(5) * 0.00062
    values = np.array([1.25e-5, -3.5e-6, 0.0, 2.0e-4, -1.0])
    path = write_european_csv(tmp_path / "w.csv", [("Start time", "11.03.2026 09:07:23,494")],
                              time, [("tor3", "V/V", values, "%.6E")])
    text = path.read_bytes().decode()
    assert text.splitlines()[1] == "Time [s];tor3 [V/V]"
    assert "\r\n" in text and "0,000620;" in text
    frame = pd.read_csv(path, sep=";", decimal=",", skiprows=1)
    assert list(frame.columns) == ["Time [s]", "tor3 [V/V]"]
    np.testing.assert_allclose(frame["tor3 [V/V]"], values, rtol=1e-6)
    np.testing.assert_allclose(frame["Time [s]"], time, atol=5e-7)


def test_npz_is_deterministic_and_loads(tmp_path):
    arrays = {"b": np.arange(4, dtype=np.float32), "a": np.eye(2)}
    one = write_npz(tmp_path / "one.npz", arrays).read_bytes()
    two = write_npz(tmp_path / "two.npz", dict(reversed(arrays.items()))).read_bytes()
    assert one == two
    with np.load(tmp_path / "one.npz") as loaded:
        np.testing.assert_array_equal(loaded["b"], arrays["b"])
        np.testing.assert_array_equal(loaded["a"], arrays["a"])


def test_draws_depend_only_on_the_seed():
    drivers = {"theta_F": (1.46, (Harmonic(0.05, 1, 0.0),)),
               "theta_H": (4.59, (Harmonic(0.1, 1, 0.0),))}
    one = draw_rig(RigSettings(seed=4), drivers)
    two = draw_rig(RigSettings(seed=4), drivers)
    other = draw_rig(RigSettings(seed=5), drivers)
    assert one.clocks == two.clocks and one.drive == two.drive and one.torsion == two.torsion
    assert one.clocks != other.clocks
    split = one.torsion["tor1"].share + one.torsion["tor2"].share
    assert split == pytest.approx(1.0, abs=1e-15)
    assert abs(one.torsion["tor1"].share - 0.5) <= 0.03


def test_bad_settings_are_config_errors(tmp_path):
    with pytest.raises(ConfigError, match="speed"):
        RigSettings(speed=-1.0).check()
    with pytest.raises(ConfigError, match="missing_pulse_probability"):
        RigSettings(imperfections=Imperfections(missing_pulse_probability=1.5)).check()
    assert main(["simulate-rig", "--out", str(tmp_path), "--speed", "0"]) == 2
    assert main(["simulate-rig", "--out", str(tmp_path), "--mechanism",
                 str(tmp_path / "missing.toml")]) == 2
    assert not any(tmp_path.iterdir())


def test_run_stem_names():
    assert run_stem(0.8) == "run_0p8"
    assert run_stem(1.0) == "run_1p0"
    assert run_stem(1.25) == "run_1p25"


@given(st.lists(st.sampled_from(["<i2", "<i4", "<u4"]), min_size=1, max_size=5),
       st.lists(st.integers(1, 700), min_size=1, max_size=3), st.integers(1, 300))
@settings(max_examples=25, deadline=None)
def test_daqmx_tdms_any_layout_reads_back_in_nptdms(tmp_path_factory, dtypes, lengths, block):
    rng = np.random.default_rng(len(dtypes) * 1000 + sum(lengths) + block)
    acquisitions = []
    for k, n in enumerate(lengths):
        channels = tuple(
            RawChannel(f"ch{i}", rng.integers(np.iinfo(d).min, np.iinfo(d).max, n,
                                              endpoint=True).astype(d), 0.5 + i, -1.0, "V")
            for i, d in enumerate(dtypes))
        acquisitions.append(Acquisition("g", np.datetime64("2026-01-01T00:00:00", "ns")
                                        + np.timedelta64(k, "s"), 1e-3, channels))
    path = write_daqmx_tdms(tmp_path_factory.mktemp("tdms") / "p.tdms", acquisitions,
                            block_samples=block)
    group = TdmsFile.read(path)["g"]
    for i, dtype in enumerate(dtypes):
        expected = np.concatenate([a.channels[i].raw for a in acquisitions])
        raw = group[f"ch{i}"].read_data(scaled=False)[0]
        assert raw.dtype == np.dtype(dtype)
        np.testing.assert_array_equal(raw, expected)
        np.testing.assert_allclose(group[f"ch{i}"][:], expected * (0.5 + i) - 1.0, rtol=1e-15)
