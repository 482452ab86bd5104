"""Faults the virtual rig injects: their truth in truth.json, and the health checks find them.

One 6 s run at 1 rev/s (seed 5) with a fault on each of four channels; the places come from
truth.json (what the rig changed), the findings from the files as written and read back.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from rigval.acquisition import read
from rigval.acquisition.errors import ConfigError
from rigval.processing.health_check import stream_health
from rigval.sample_data import RigSettings, simulate_rig
from rigval.sample_data.faults import Fault

FAULTS = (Fault("clipping", "wls1", "tor2", 5e-5),
          Fault("flat line", "wls2", "tor3", 0.0, 0.5, 1.0),
          Fault("spikes", "cdaq", "str1", 1e-5, 0.1, 0.9, 4),
          Fault("count jump", "cdaq", "enc1", 40.0, 0.6))


@pytest.fixture(scope="module")
def faulted(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str, list[dict]]:
    files = simulate_rig(tmp_path_factory.mktemp("faults"),
                         RigSettings(speed=1.0, duration=6.0, seed=5, faults=FAULTS))
    truth = json.loads(files.path("truth.json").read_text())["faults"]
    return files.folder, files.stem, truth


def _stream(folder: Path, stem: str, name: str):
    return next(iter(read(folder / f"{stem}_{name}.{'csv' if name == 'wls2' else 'tdms'}")
                     .values()))


def test_truth_lists_every_fault_with_its_samples(faulted):
    folder, stem, truth = faulted
    assert [t["kind"] for t in truth] == [f.kind for f in FAULTS]
    clip = truth[0]
    tor2 = _stream(folder, stem, "wls1")["tor2"].to_numpy()
    # the file holds the clipped codes: as many samples at +-5e-5 (one code) as the truth says
    at_level = np.abs(np.abs(tor2) - 5e-5) < 3e-9
    assert clip["samples"] == int(at_level.sum()) > 0
    assert truth[2]["samples"] == 4 and len(truth[2]["indices"]) == 4


def test_health_finds_each_fault_at_its_place(faulted):
    folder, stem, truth = faulted
    kinds = {"wls1": {"tor1": "analog", "tor2": "analog"}, "wls2": {"tor3": "analog"},
             "cdaq": {"str1": "analog", "enc1": "counter"}}
    found = {}
    for name, channels in kinds.items():
        for f in stream_health(_stream(folder, stem, name), channels, name=name,
                               counts_per_rev={"enc1": 8192}):
            found[(f.channel, f.fault)] = f
    assert set(found) == {("wls1.tor2", "clipping"), ("wls2.tor3", "flat line"),
                          ("cdaq.str1", "spikes"), ("cdaq.enc1", "count jump")}
    assert abs(found["wls2.tor3", "flat line"].first_sample - truth[1]["first_sample"]) <= 2
    assert set(truth[2]["indices"]) <= set(found["cdaq.str1", "spikes"].indices)
    assert found["cdaq.enc1", "count jump"].indices == (truth[3]["first_sample"],)
    assert abs(found["wls1.tor2", "clipping"].samples - truth[0]["samples"]) <= 0.05 * truth[0][
        "samples"]


def test_a_fault_on_an_unknown_channel_is_refused(tmp_path):
    with pytest.raises(ConfigError, match="no channel 'tor9'"):
        simulate_rig(tmp_path, RigSettings(duration=2.0, faults=(
            Fault("clipping", "wls1", "tor9", 1e-5),)))
    with pytest.raises(ConfigError, match="unknown fault kind"):
        RigSettings(faults=(Fault("melted", "wls1", "tor1", 1.0),)).check()
