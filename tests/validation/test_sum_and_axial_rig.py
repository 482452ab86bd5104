"""On the virtual rig: a sum or difference of channels and the rod's axial force as comparisons.

The rig splits each drive's torque between two shafts with a share drawn per run (here up to
0.5 +- 0.3): tor1 + tor2 must agree with the whole drive torque whatever the split, and
tor1 - tor2 with (share1 - share2) times it. The strain gauge on rod B measures its axial force
(the rig's truth: the mean of its two end forces along the rod); the model's
``joint_axial_force`` of P5 on B is the force at the crank end, which differs from the mid-length
force by half the rod's inertial load (35 kg times a few m s-2, under 1 % of the range).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from rigval.sample_data import Imperfections, RigSettings, simulate_rig
from rigval.validation.pipeline import run_scene

AREA = 1.9e-3  # m2, the rig's rod B cross-section (sample_data.rig)

EXTRA = """
[[comparisons]]
name = "tor12"
measured = "wls1.tor1 + wls1.tor2"
model = { quantity = "driver_torque", item = "theta_F" }

[[comparisons]]
name = "tor1m2"
measured = ["wls1.tor1", "-wls1.tor2"]
model = { quantity = "driver_torque", item = "theta_F" }
scale = SHARE_DIFFERENCE

[[comparisons]]
name = "str1_axial"
measured = "cdaq.str1"
model = { quantity = "joint_axial_force", item = "P5", body = "B" }
scale = INVERSE_AREA
scale_units = "m-2"
lowpass_hz = 20.0
"""


@pytest.fixture(scope="module")
def rig_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict]:
    folder = tmp_path_factory.mktemp("rig")
    settings = RigSettings(speed=1.0, duration=12.0, seed=5,
                           imperfections=Imperfections(torque_split=0.3))
    files = simulate_rig(folder, settings)
    truth = json.loads(files.path("truth.json").read_text())
    channels = truth["streams"]["wls1"]["channels"]
    shares = (channels["tor1"]["sensor"]["share"], channels["tor2"]["sensor"]["share"])
    assert abs(shares[0] - shares[1]) > 0.05  # a split far from even
    scene = files.path("scene.toml")
    text = scene.read_text().split("[predictions]")[0] + EXTRA.replace(
        "SHARE_DIFFERENCE", repr(shares[0] - shares[1])).replace("INVERSE_AREA",
                                                                 repr(1.0 / AREA))
    scene.write_text(text)
    result = run_scene(scene)
    return scene, {c.name: c for c in result.comparisons}


def test_sum_of_shaft_torques_matches_the_whole_drive_torque(rig_run) -> None:
    _, results = rig_run
    whole, half = results["tor12"].scores, results["tor1"].scores
    assert results["tor12"].spec.measured_text == "wls1.tor1 + wls1.tor2"
    assert results["tor12"].long_name == "wls1.tor1 + wls1.tor2"
    # within a few % of range, where one shaft against half the torque is off by its share
    assert whole["nrmse"] < 0.03
    assert half["nrmse"] > 2 * whole["nrmse"]
    assert whole["iso18571_periodic.rating"] > 0.9


def test_difference_of_shaft_torques_matches_the_share_difference(rig_run) -> None:
    _, results = rig_run
    assert results["tor1m2"].spec.measured_text == "wls1.tor1 - wls1.tor2"
    assert results["tor1m2"].scores["nrmse"] < 0.08


def test_axial_force_of_rod_b_matches_its_strain_gauge(rig_run) -> None:
    _, results = rig_run
    axial = results["str1_axial"].scores
    assert axial["nrmse"] < 0.01
    assert axial["iso18571_periodic.rating"] > 0.9
    assert str(results["str1_axial"].spec.model) == "joint_axial_force[P5] on B"
