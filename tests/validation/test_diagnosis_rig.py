"""The diagnosis on virtual-rig runs of known cause, a few seeds (the sweep: benchmarks/).

Each case departs from the rig's defaults in one way (``diagnosis_cases.CASES``); what is
asserted is the rig's truth, which the diagnosis does not read: the split the rig used, the
lag it put on tor1, the arm's mass factor.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import pytest
import xarray as xr

from rigval.acquisition.errors import ConfigError
from rigval.sample_data import RigSettings, simulate_rig
from rigval.validation.diagnosis.explain import attach_diagnosis
from rigval.validation.report.page import Page
from rigval.validation.report.run_report import write_metrics, write_netcdf
from rigval.validation.report.why import why_section
from rigval.validation.scene import parse_scene
from tests.validation.diagnosis_cases import PAIR, run_case

pytestmark = pytest.mark.filterwarnings("ignore::rigval.acquisition.errors.DataWarning")


def test_split_is_measured_and_flagged(tmp_path: Path) -> None:
    out = run_case("split 0.53", 2, tmp_path, duration=6.0)
    pair = out["pair"]
    assert pair["lower"] <= 0.53 <= pair["upper"]
    assert pair["asymmetric"]


def test_lag_is_named_on_its_channel(tmp_path: Path) -> None:
    out = run_case("lag 2 ms", 2, tmp_path, duration=6.0)
    cause = out["causes"]["tor1"]
    assert cause["cause"] == "lag tor1"
    assert abs(cause["value"] - 0.002) <= 3.0 * cause["std"] + 1e-4


def test_heavier_arm_is_named_a_mass(tmp_path: Path) -> None:
    out = run_case("arm +8 %", 2, tmp_path, duration=6.0)
    assert "torque_F" in out["detected"]
    cause = out["causes"]["torque_F"]
    assert cause["cause"] == "A.mass" and cause["significant"]
    assert abs(cause["relative"] - 0.08) <= 3.0 * cause["relative_std"] + 0.002
    assert "most likely A.mass" in cause["sentence"]


@pytest.fixture(scope="module")
def rig_scene(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("rig")
    files = simulate_rig(folder, RigSettings(duration=6.0, seed=4))
    scene = files.path("scene.toml")
    scene.write_text(scene.read_text(encoding="utf-8") + PAIR, encoding="utf-8")
    return scene


def test_outputs_carry_the_diagnosis(rig_scene: Path, tmp_path: Path) -> None:
    from rigval.validation.pipeline import run_scene

    result = attach_diagnosis(run_scene(rig_scene))
    write_metrics(result, tmp_path)
    write_netcdf(result, tmp_path / "run.nc")
    document = json.loads((tmp_path / "metrics.json").read_text(encoding="utf-8"))
    diagnosis = document["diagnosis"]
    assert set(diagnosis["attribution"]) == {c.name for c in result.comparisons}
    assert diagnosis["symmetry"][0]["name"] == "main drive shafts"
    assert 0.4 < diagnosis["symmetry"][0]["share"] < 0.6
    with xr.open_datatree(tmp_path / "run.nc") as tree:
        group = tree["/why"].to_dataset()
        assert group["shares_share"].dtype.kind == "f"
        assert group["cause_detected"].dtype.kind == "i"
        assert math.isclose(float(group["shares_share"][0]),
                            diagnosis["symmetry"][0]["share"], rel_tol=1e-12)
    page = Page("why")
    why_section(page, result)
    html = page.render()
    assert 'id="why"' in html and "symmetry pairs" in html
    assert result.diagnosis.pairs[0].sentence in html


def test_rigidity_json_is_written_from_the_diagnosis_without_a_second_analysis(
        rig_scene: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from rigval.validation.diagnosis.rigidity import evidence_record
    from rigval.validation.pipeline import run_scene
    from rigval.validation.report import run_report

    result = attach_diagnosis(run_scene(rig_scene))
    assert set(result.diagnosis.rigidity) == {c.name for c in result.comparisons}

    def again(_result: object) -> None:
        raise AssertionError("rigidity analysed a second time")

    monkeypatch.setattr(run_report, "run_rigidity", again)
    path = run_report.write_rigidity(result, tmp_path)
    written = json.loads(path.read_text(encoding="utf-8"))
    expected = {name: evidence_record(e) for name, e in result.diagnosis.rigidity.items()}
    assert written == json.loads(json.dumps(expected))


@pytest.mark.parametrize(("table", "message"), [
    ('comparisons = ["tor1", "nope"]\nu_measurement_rel = 0.01', "no comparison named"),
    ('comparisons = ["tor1", "tor1"]\nu_measurement_rel = 0.01', "two comparison names"),
    ('comparisons = ["tor1", "acc1"]\nu_measurement_rel = 0.01', "differ in unit"),
    ('comparisons = ["tor1", "tor2"]', "u_measurement_rel"),
    ('comparisons = ["tor1", "tor2"]\nu_measurement_rel = 0.01\n'
     "u_measurement_rel_common = 0.02", "exceeds the whole"),
    ('comparisons = ["tor1", "tor2"]\nu_measurement_rel = 0.01\nkind = "twins"', "twins"),
])
def test_bad_symmetry_pair_is_refused(rig_scene: Path, table: str, message: str) -> None:
    text = re.sub(r"\[\[symmetry\]\].*", "", rig_scene.read_text(encoding="utf-8"), flags=re.S)
    text += f'[[symmetry]]\nname = "pair"\n{table}\n'
    with pytest.raises(ConfigError, match=message) as caught:
        parse_scene(text, rig_scene)
    assert caught.value.where["key"].startswith("symmetry[0]")


@pytest.mark.slow
def test_face_pair_bending_scales_with_the_rigs_bending(tmp_path: Path) -> None:
    """Half the rig's bending, half the bending part; the axial part stays (the rig's truth)."""
    from rigval.sample_data.departures import Departures
    from rigval.validation.pipeline import run_scene

    faces = ('\n[[symmetry]]\nname = "rod B faces"\ncomparisons = ["str2", "str3"]\n'
             'kind = "faces"\nu_measurement_rel = 0.02\n')
    parts = {}
    for level in (1.0, 0.5):
        files = simulate_rig(tmp_path / str(level), RigSettings(
            duration=10.0, seed=2, departures=Departures(rod_bending=level)))
        scene = files.path("scene.toml")
        scene.write_text(scene.read_text(encoding="utf-8") + faces, encoding="utf-8")
        parts[level] = attach_diagnosis(run_scene(scene)).diagnosis.pairs[0].bending
    assert parts[1.0].bending and parts[0.5].bending
    # gauge noise over 8 revolutions: the ratio within 5 %
    assert abs(parts[0.5].bending_rms / parts[1.0].bending_rms - 0.5) < 0.025
    assert abs(parts[0.5].axial_rms / parts[1.0].axial_rms - 1.0) < 0.02
