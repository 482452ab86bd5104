"""Long virtual-rig runs in bounded memory: the windowed writers give what writing at once gives."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import numpy as np
import pytest

import rigval.sample_data.simulate as simulate
from rigval.acquisition import read
from rigval.acquisition.errors import ConfigError
from rigval.sample_data import RigSettings, RunFiles
from rigval.sample_data.tdms_writer import (
    Acquisition,
    DaqmxTdmsWriter,
    RawChannel,
    write_daqmx_tdms,
)
from rigval.sample_data.truth import TruthGrid
from rigval.sample_data.writers import write_npz, write_npz_from_files
from tests.sample_data.run_pairs import runs_with_and_without


def _acquisitions(rng: np.random.Generator) -> list[Acquisition]:
    start = np.datetime64("2026-01-01T00:00:00", "ns")
    return [Acquisition("g", start + np.timedelta64(i, "s"), 1e-3, (
        RawChannel("a", rng.integers(-2**15, 2**15, n).astype(np.int16), 1e-3, 0.0, "V"),
        RawChannel("c", rng.integers(0, 2**32, n, dtype=np.uint64).astype(np.uint32), 1.0,
                   0.0, None)))
            for i, n in enumerate((2500, 1000))]


def test_tdms_written_in_pieces_equals_all_at_once(tmp_path: Path) -> None:
    acquisitions = _acquisitions(np.random.default_rng(0))
    whole = write_daqmx_tdms(tmp_path / "whole.tdms", acquisitions, block_samples=300,
                             file_name="x").read_bytes()
    with DaqmxTdmsWriter(tmp_path / "pieces.tdms", block_samples=300, file_name="x") as writer:
        for acq in acquisitions:
            cuts = [0, 7, 301, 302, 999, acq.channels[0].raw.size]
            first = [RawChannel(c.name, c.raw[:cuts[1]], c.slope, c.intercept, c.unit)
                     for c in acq.channels]
            writer.start(Acquisition(acq.group, acq.start_time, acq.increment, tuple(first)))
            for a, b in itertools.pairwise(cuts[1:]):
                writer.append([c.raw[a:b] for c in acq.channels])
    assert (tmp_path / "pieces.tdms").read_bytes() == whole


def test_tdms_writer_refuses_unequal_pieces_and_leaves_no_file(tmp_path: Path) -> None:
    acq = _acquisitions(np.random.default_rng(1))[0]
    path = tmp_path / "bad.tdms"
    with pytest.raises(ConfigError, match="differ in length"), DaqmxTdmsWriter(path) as writer:
        writer.start(acq)
        writer.append([np.zeros(3, np.int16), np.zeros(4, np.uint32)])
    assert not path.exists()


def test_npz_from_files_equals_npz(tmp_path: Path) -> None:
    arrays = {"b.x": np.arange(100000, dtype=np.float32) ** 0.5,
              "a.y": np.linspace(0, 1, 777, dtype=np.float32)}
    files = {}
    for name, values in arrays.items():
        files[name] = tmp_path / f"{name}.npy"
        np.save(files[name], values)
    whole = write_npz(tmp_path / "whole.npz", arrays).read_bytes()
    pieces = write_npz_from_files(tmp_path / "pieces.npz", files, chunk_bytes=1000)
    assert pieces.read_bytes() == whole


def test_truth_window_keeps_the_whole_grids_spline() -> None:
    t = np.arange(20001) / 1000.0
    grid = TruthGrid(t, {"s": np.sin(7.0 * t) + 0.3 * np.cos(31.0 * t)})
    probe = np.linspace(8.0, 9.0, 1001)
    part = grid.window(8.0, 9.0)
    assert part.t[0] == pytest.approx(8.0 - 0.064) and part.t[-1] == pytest.approx(9.0 + 0.063)
    np.testing.assert_allclose(part.at("s", probe), grid.at("s", probe), rtol=0, atol=1e-14)


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> tuple[RunFiles, ...]:
    """A 10 s run written in one window and the same seed in 3 s windows."""
    return runs_with_and_without(tmp_path_factory.mktemp("long"), "WINDOW_S", 3.0)


def test_windowed_run_has_the_same_samples_but_for_noise(runs) -> None:
    """Windows change only the order of the noise draws: same samples, times, counts and truth;
    the analog channels differ by two independent noise draws (sqrt(2) x the noise rms)."""
    whole, windows = runs
    truth = json.loads(whole.path("truth.json").read_text())
    for suffix in ("cdaq.tdms", "wls1.tdms", "wls2.csv"):
        a, b = read(whole.path(suffix)), read(windows.path(suffix))
        for group in a:
            x, y = a[group], b[group]
            np.testing.assert_array_equal(x["time"].values, y["time"].values)
            np.testing.assert_array_equal(x["segment"].values, y["segment"].values)
            stream = truth["streams"][suffix.split(".")[0]]
            for name in x.data_vars:
                if name in ("valid", "segment"):
                    continue
                if name.startswith("enc"):  # counters: no noise
                    np.testing.assert_array_equal(x[name].values, y[name].values)
                    continue
                if name.startswith("opt"):  # pulses: noise plus switching edges
                    continue
                noise = stream["channels"][name]["sensor"]["noise_rms"]
                spread = float(np.std(x[name].values - y[name].values))
                assert 0.8 * np.sqrt(2) * noise < spread < 1.25 * np.sqrt(2) * noise, name
    with np.load(whole.path("truth.npz")) as x, np.load(windows.path("truth.npz")) as y:
        assert x.files == y.files
        for key in x.files:
            np.testing.assert_allclose(x[key], y[key], rtol=0, atol=1e-6 * np.ptp(x[key]))


def test_rig_takes_hours_not_days() -> None:
    RigSettings(duration=3600.0).check()
    with pytest.raises(ConfigError, match="duration"):
        RigSettings(duration=14401.0).check()


def test_truth_solved_in_pieces_joins_to_rounding(monkeypatch: pytest.MonkeyPatch) -> None:
    from rigval.sample_data.rig import draw_rig
    from rigval.sample_data.truth import model_truth

    mechanism = simulate.default_mechanism()
    drive = draw_rig(RigSettings(duration=5.0), simulate.mechanism_drivers(mechanism)).drive
    t = -1.0 + np.arange(5000) / 1000.0
    whole = simulate._truth_grid(lambda d, tt: model_truth(mechanism, d, tt), drive, t)
    monkeypatch.setattr(simulate, "TRUTH_POINTS", 777)
    pieces = simulate._truth_grid(lambda d, tt: model_truth(mechanism, d, tt), drive, t)
    assert whole.values.keys() == pieces.values.keys()
    for name, values in whole.values.items():  # point-by-point solves: 1e-14 of the range
        np.testing.assert_allclose(pieces.values[name], values, rtol=0,
                                   atol=1e-12 * np.ptp(values), err_msg=name)
