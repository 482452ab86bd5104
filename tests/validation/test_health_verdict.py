"""A clipped torque channel changes its comparison's verdict line, alignment.json, run.nc, report.

A 12 s virtual-rig run (seed 7, 1 rev/s) whose tor2 the rig clips at 6e-5 V/V (its range set
too small); the truth of what was clipped comes from truth.json.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
import xarray as xr

from rigval.sample_data import RigSettings, simulate_rig
from rigval.sample_data.faults import Fault
from rigval.validation.run.validate import validate_scene
from rigval.validation.verdict import run_verdict

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def validated(tmp_path_factory: pytest.TempPathFactory):
    folder = tmp_path_factory.mktemp("clipped")
    files = simulate_rig(folder, RigSettings(speed=1.0, duration=12.0, seed=7, faults=(
        Fault("clipping", "wls1", "tor2", 6e-5),)))
    truth = json.loads(files.path("truth.json").read_text())["faults"][0]
    out = tmp_path_factory.mktemp("report")
    return validate_scene(files.path("scene.toml"), out), out, truth


def test_the_clipped_comparisons_say_so_on_their_verdict_line(validated):
    result, _, truth = validated
    rows = {row["comparison"]: row for row in run_verdict(result)["comparisons"]}
    clipped = [name for name, row in rows.items() if not row["trusted"]]
    # tor2 alone and the sum of the main shaft's torques use the clipped channel
    assert clipped == ["tor2", "torque_F"]
    (line,) = rows["tor2"]["health"]
    share = float(re.search(r"([\d.]+) % of samples clipped at 6e-05 V/V", line).group(1))
    stream_samples = truth["stream_samples"]
    # the share given is that of the samples the rig clipped (runs of 3 or more: within 1 %)
    assert share == pytest.approx(100 * truth["samples"] / stream_samples, rel=0.05)
    assert line.startswith("wls1.tor2: ") and line.endswith("; not trusted")
    assert all(row["health"] == [] and row["trusted"] for name, row in rows.items()
               if name not in clipped)
    assert "tor2: wls1.tor2: " in run_verdict(result)["statement"]


def test_alignment_json_netcdf_and_report_carry_the_finding(validated):
    _, out, truth = validated
    page = (out / "report.html").read_text()
    assert "Sensor health: 1 finding" in page and "wls1.tor2: " in page
    health = json.loads((out / "alignment.json").read_text())["wls1"]["health"]
    assert [(h["channel"], h["fault"], h["trusted"]) for h in health] == [
        ("wls1.tor2", "clipping", False)]
    assert abs(health[0]["samples"] - truth["samples"]) <= 0.05 * truth["samples"]
    nc = next(Path(out).glob("*.nc"))
    with xr.open_dataset(nc, group="health") as stored:
        assert list(stored["channel"].values) == ["wls1.tor2"]
        assert list(stored["fault"].values) == ["clipping"]
        assert int(stored["samples"][0]) == health[0]["samples"]
        assert int(stored["trusted"][0]) == 0 and stored["text"].values[0] == health[0]["text"]
