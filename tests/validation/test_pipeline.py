"""The pipeline on a virtual-rig run with known truth: alignment, agreement, outputs, exit codes."""

from __future__ import annotations

import json
import re
import runpy
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from rigval.sample_data import RigSettings, load_truth, simulate_rig
from rigval.validation.cli import main
from rigval.validation.pipeline import run_scene
from rigval.validation.read_plan import read_streams
from rigval.validation.run.validate import validate_scene
from rigval.validation.scene import load_scene

DURATION_S = 12.0


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 12 s virtual-rig run at 1 rev/s with every default imperfection (dropouts included)."""
    folder = tmp_path_factory.mktemp("rig")
    simulate_rig(folder, RigSettings(speed=1.0, duration=DURATION_S, seed=7))
    return folder


@pytest.fixture(scope="module")
def scene_path(run_dir: Path) -> Path:
    return next(run_dir.glob("*_scene.toml"))


@pytest.fixture(scope="module")
def report_dir(scene_path: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``rigval demo`` with this run as the shipped sample data: its report folder."""
    out = tmp_path_factory.mktemp("demo")
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr("rigval.sample_data.shipped_runs", lambda: [scene_path])
        assert main(["demo", "--out", str(out), "--workers", "1"]) == 0
    index = (out / "index.html").read_text()
    run = scene_path.name.removesuffix("_scene.toml")
    assert f'href="{run}/report.html"' in index
    return out / run


def _truth(run_dir: Path) -> dict:
    return json.loads(next(run_dir.glob("*_truth.json")).read_text())


def _edited(scene_path: Path, tmp_path: Path, old: str, new: str) -> Path:
    """A copy of the run folder whose scene has ``old`` replaced by ``new``."""
    folder = tmp_path / "run"
    shutil.copytree(scene_path.parent, folder)
    scene = folder / scene_path.name
    text = scene.read_text()
    assert old in text, old
    scene.write_text(text.replace(old, new, 1))
    return scene


def test_clock_offsets_match_the_rig_truth(report_dir: Path, run_dir: Path) -> None:
    alignment = json.loads((report_dir / "alignment.json").read_text())
    truth = load_truth(next(run_dir.glob("*_truth.json")))
    for name in ("wls1", "wls2"):
        # the exact clock on the cDAQ's own drifting clock (what an alignment should recover)
        offsets, drift = truth.clock_on_reference(name)
        # 20 us rms optical jitter on ~12 pulses: tens of us (tests/validation/
        # test_alignment_truth.py derives tight bounds; this is the end-to-end check)
        assert alignment[name]["offset_s"] == pytest.approx(offsets[0], abs=1e-4)
        # what matters is the timing error it leaves at the end of the record (0.036 deg)
        drift_error_s = abs(alignment[name]["drift_ppm"] - drift * 1e6) * 1e-6 * DURATION_S
        assert drift_error_s < 1e-4
        assert alignment[name]["events_matched"] >= DURATION_S - 3


def test_model_and_measurement_agree(report_dir: Path) -> None:
    rows = json.loads((report_dir / "metrics.json").read_text())["rows"]
    ratings = {r["comparison"]: r["value"] for r in rows
               if r["row"] == "model" and r["metric"] == "iso18571_periodic.rating"}
    assert set(ratings) == {"acc1", "acc2", "str1", "tor1", "tor2", "tor3", "tor4", "torque_F",
                            "torque_H"}
    assert all(value > 0.8 for value in ratings.values()), ratings  # ISO "good" or better
    lags = {r["comparison"]: r["value"] for r in rows
            if r["row"] == "model" and r["metric"] == "circular_lag.lag_deg"}
    assert all(abs(v) < 0.5 for v in lags.values()), lags  # aligned to half a degree


def test_netcdf_layout(report_dir: Path, scene_path: Path) -> None:
    tree = xr.open_datatree(next(report_dir.glob("*.nc")))
    # the scene has no [output] table: the angle domain only, no raw or aligned streams
    assert {"angle", "model", "validation"} <= set(tree.children)
    assert not {"raw", "aligned"} & set(tree.children)
    assert tree["model"]["support_force"].dtype == np.float64
    assert tree["model"]["support_force"].encoding["complevel"] == 4
    assert tree.attrs["scene_toml"] == scene_path.read_text()
    angle = tree["angle"].to_dataset()
    assert angle["acc1"].dims == ("cycle", "angle") and angle["acc1_mean"].dims == ("angle",)
    assert tree["validation"]["metrics_model"].dims == ("comparison", "score")
    assert len(tree.attrs["history"].splitlines()) >= 2


def test_report_predicts_supports_and_tip(report_dir: Path) -> None:
    html = (report_dir / "report.html").read_text()
    for support in ("P3", "P4", "P10", "P11"):
        assert f">{support}<" in html
    assert "P1: vertical position, absolute speed and acceleration" in html


def test_support_forces_balance_gravity_on_average(report_dir: Path) -> None:
    """Over a revolution the frame carries the machine's weight: time-mean support = m g.

    The momentum of a periodic motion returns to its start, so its rate averages to zero over a
    revolution in time (samples uniform in angle are weighted with dt = dphi / omega_F).
    """
    tree = xr.open_datatree(next(report_dir.glob("*.nc")))
    force = tree["model"]["support_force"].sel(axis="y").sum("support")
    dt = 1.0 / tree["model"]["drive_theta_F_dot"]
    mean_vertical = float((force * dt).sum() / dt.sum())
    total_mass = 400 + 35 + 20 + 20 + 60 + 50 + 25 + 30  # pendulum.toml
    # support_force is the force ON the ground: the weight pushes down
    assert mean_vertical == pytest.approx(-total_mass * 9.81, rel=2e-4)


def test_threshold_failure_exits_1(scene_path: Path, tmp_path: Path,
                                   capsys: pytest.CaptureFixture[str]) -> None:
    scene = _edited(scene_path, tmp_path, '"nrmse" = "<= 0.15"', '"nrmse" = "<= 1e-9"')
    assert main(["validate", str(scene), "--out", str(tmp_path / "out")]) == 1
    assert "FAIL: nrmse" in capsys.readouterr().out


def test_wrong_sign_is_caught(scene_path: Path, tmp_path: Path) -> None:
    """A torque compared with the wrong sign fails its ISO threshold."""
    text = scene_path.read_text()
    block = re.search(r'name = "tor1".*?scale = 0\.5', text, re.S).group(0)
    scene = _edited(scene_path, tmp_path, block, block.replace("scale = 0.5", "scale = -0.5"))
    result = run_scene(scene)
    tor1 = next(c for c in result.comparisons if c.name == "tor1")
    assert not tor1.passed and tor1.scores["pearson_r"] < -0.99


BAD_SCENES = {
    "missing file": ('file = "', 'file = "missing_', "streams.cdaq.file"),
    "channel not in file": ('source = "acc1"', 'source = "acc9"', "streams.cdaq"),
    "unknown model output": ('item = "P1"', 'item = "P13"', "comparisons[0].model.item"),
    "wrong units": ('quantity = "point_acceleration"', 'quantity = "point_velocity"',
                    "comparisons[0].model"),
}


@pytest.mark.parametrize("case", BAD_SCENES, ids=list(BAD_SCENES))
def test_bad_scene_exits_2_naming_the_key(case: str, scene_path: Path, tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    old, new, key = BAD_SCENES[case]
    scene = _edited(scene_path, tmp_path, old, new)
    assert main(["validate", str(scene), "--out", str(tmp_path / "out")]) == 2
    assert key in capsys.readouterr().err


def test_corrupt_data_file_exits_3(scene_path: Path, tmp_path: Path,
                                   capsys: pytest.CaptureFixture[str]) -> None:
    scene = _edited(scene_path, tmp_path, "schema", "schema")
    tdms = next(scene.parent.glob("*_wls1.tdms"))
    tdms.write_bytes(b"version https://git-lfs.github.com/spec/v1\noid sha256:0\nsize 1\n")
    assert main(["validate", str(scene), "--out", str(tmp_path / "out")]) == 3
    assert "wls1.tdms" in capsys.readouterr().err


def test_output_keys_keep_raw_and_aligned_streams(scene_path: Path, tmp_path: Path) -> None:
    """``[output] raw = true, aligned = true``: both groups, raw equal to the file as read."""
    text = scene_path.read_text()
    scene = _edited(scene_path, tmp_path, text, text + "\n[output]\nraw = true\naligned = true\n")
    tree = run_scene(scene).tree
    assert set(tree["raw"].children) == set(tree["aligned"].children) == {"cdaq", "wls1", "wls2"}
    read = read_streams(load_scene(scene))
    for stream, ds in read.items():
        for name, var in ds.data_vars.items():
            kept = tree[f"raw/{stream}"][name]
            assert kept.shape == var.shape, (stream, name)
            if var.dtype.kind == "f":  # kept as float32: equal to float32 rounding
                assert kept.dtype == np.float32
                np.testing.assert_array_equal(kept.values, var.values.astype(np.float32))
    acc1 = tree["aligned/cdaq"]["acc1"]
    assert acc1.dtype == np.float32 and acc1.attrs["units"] == "m s-2"


def test_channel_by_channel_equals_the_whole_record(scene_path: Path, tmp_path: Path) -> None:
    """Without [output] the pipeline reads the alignment's channels first and each stream's
    compared channels after the model: the same revolutions and scores as reading every
    channel at once (what [output] aligned = true does), to rounding."""
    text = scene_path.read_text()
    whole = _edited(scene_path, tmp_path, text, text + "\n[output]\naligned = true\n")
    lazy, full = run_scene(scene_path), run_scene(whole)
    assert [c.name for c in lazy.comparisons] == [c.name for c in full.comparisons]
    for a, b in zip(lazy.comparisons, full.comparisons, strict=True):
        assert a.cycles.shape == b.cycles.shape and a.cycles.shape[0] >= 10
        np.testing.assert_allclose(a.cycles, b.cycles, rtol=1e-12, atol=0, err_msg=a.name)
        for key, value in b.scores.items():
            if isinstance(value, float):
                assert a.scores[key] == pytest.approx(value, rel=1e-9, abs=1e-12), (a.name, key)
    assert "aligned" not in lazy.tree.children and "aligned" in full.tree.children


def test_block_processing_equals_the_whole_record(scene_path: Path,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    """Smoothing the encoders piece by piece, sampling the drives at the grid times and the
    uniform-sample spline give the revolutions and scores of whole-record processing: one piece
    per run and scipy's not-a-knot spline over whole runs (docs/bench/history-long-records.md, long
    records)."""
    from rigval.processing import angle, excitation
    monkeypatch.setattr(excitation, "_PIECE", 7_000)              # 12 s at 5 kHz: 9 pieces
    monkeypatch.setattr(angle, "_CHUNK", 5_000)
    blocks = run_scene(scene_path)
    monkeypatch.setattr(excitation, "_PIECE", 1 << 40)
    monkeypatch.setattr(angle, "_CHUNK", 1 << 40)
    monkeypatch.setattr(angle, "_UNIFORM_TOLERANCE", -1.0)        # make_interp_spline only
    whole = run_scene(scene_path)
    for a, b in zip(blocks.comparisons, whole.comparisons, strict=True):
        assert a.cycles.shape == b.cycles.shape and a.cycles.shape[0] >= 10
        scale = np.abs(b.cycles).max()
        np.testing.assert_allclose(a.cycles, b.cycles, rtol=0, atol=1e-9 * scale, err_msg=a.name)
        np.testing.assert_allclose(a.model, b.model, rtol=0, atol=1e-9 * np.abs(b.model).max(),
                                   err_msg=a.name)
        for key, value in b.scores.items():
            if isinstance(value, float):
                assert a.scores[key] == pytest.approx(value, rel=1e-6, abs=1e-9), (a.name, key)


def test_validate_scene_returns_what_a_campaign_needs(scene_path: Path, tmp_path: Path) -> None:
    result = validate_scene(scene_path, tmp_path)
    assert result.passed
    assert {p.name for p in result.outputs} >= {"report.html", "metrics.csv", "alignment.json"}
    assert result.speed_rev_s == pytest.approx(1.0, rel=0.01)
    assert scene_path.parent / next(scene_path.parent.glob("*_cdaq.tdms")).name in result.inputs


@pytest.mark.browser
def test_report_renders_in_chromium(report_dir: Path, tmp_path: Path, chromium_probe) -> None:
    html = report_dir / "report.html"
    figures = html.read_text().count("<svg ")
    assert figures >= 7 + 3 + 2
    # A script writes each inline SVG's drawn width and its number of texts laid out with a
    # width into the page: 0 means the figure or its text is not shown.
    script = ("<script>window.addEventListener('load',()=>{const r=[...document.querySelectorAll("
              "'figure > svg')].map(s=>[Math.round(s.getBoundingClientRect().width),[...s."
              "querySelectorAll('text')].filter(t=>t.getBBox().width>0).length]);const p="
              "document.createElement('pre');p.id='probe';p.textContent=JSON.stringify(r);"
              "document.body.appendChild(p);});</script>")
    shown = chromium_probe(html, script, tmp_path)
    assert len(shown) == figures and all(w > 0 and texts > 0 for w, texts in shown), shown


EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.mark.parametrize("script", ["import_run_to_netcdf.py", "convert_and_align.py",
                                    "compare_one_channel.py"])
def test_example_runs(script: str, scene_path: Path, tmp_path: Path,
                      monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    out = {"import_run_to_netcdf.py": [str(tmp_path / "run.nc")], "convert_and_align.py": [],
           "compare_one_channel.py": ["tor1", str(tmp_path / "tor1.png")]}[script]
    monkeypatch.setattr(sys, "argv", [script, str(scene_path), *out])
    runpy.run_path(str(EXAMPLES / script), run_name="__main__")
    printed = capsys.readouterr().out
    if script == "import_run_to_netcdf.py":
        assert set(xr.open_datatree(tmp_path / "run.nc")["raw"].children) == {"cdaq", "wls1",
                                                                              "wls2"}
    elif script == "convert_and_align.py":
        assert re.search(r"wls2\s+offset \+\d\.\d+ s", printed)
    else:
        assert (tmp_path / "tor1.png").read_bytes()[:4] == b"\x89PNG"
        assert "iso18571_periodic.rating" in printed


def test_analytic_drives_agree_at_the_law_speed(scene_path: Path, tmp_path: Path) -> None:
    """The mechanism file's law (1 rev/s) stands in for the measured drives of a 1 rev/s run."""
    text = scene_path.read_text()
    measured = re.search(r'\[model\]\ndrives = "measured"\n.*?(?=\n\[\[comparisons\]\])', text,
                         re.S).group(0)
    scene = _edited(scene_path, tmp_path, measured, '[model]\ndrives = "analytic"\n')
    result = run_scene(scene)
    assert result.tree["/model"].attrs["cycle_period_s"] == pytest.approx(1.0)
    ratings = {c.name: c.scores["iso18571_periodic.rating"] for c in result.comparisons}
    assert min(ratings.values()) > 0.9, ratings


def test_file_unit_that_does_not_fit_the_sensor_exits_2(scene_path: Path, tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]
                                                         ) -> None:
    """acc1 declared as already in m s-2 while the file holds volts."""
    block = re.search(r'sensor = "charge_accelerometer"\n(.*\n)*?correct_highpass = true',
                      scene_path.read_text()).group(0)
    scene = _edited(scene_path, tmp_path, block, 'sensor = "physical"\nunits = "m s-2"')
    assert main(["validate", str(scene), "--out", str(tmp_path / "out")]) == 2
    assert "streams.cdaq.channels.acc1" in capsys.readouterr().err
