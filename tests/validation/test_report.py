"""Report folder from a synthetic validation result: files, tables, netCDF layout, browser view."""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from rigval.acquisition.detect import source_checksum
from rigval.model import load_mechanism
from rigval.processing.alignment_summary import StreamAlignment
from rigval.validation.metrics.thresholds import check_thresholds
from rigval.validation.note import read_note
from rigval.validation.report.run_report import write_report
from rigval.validation.results import ComparisonResult, NumericsSummary, ValidationResult
from rigval.validation.scene import load_scene

DOC = Path(__file__).resolve().parents[2] / "docs" / "scene.md"


def _scene(tmp_path: Path):
    for name in ("run_1p0_cdaq.tdms", "run_1p0_wls1.tdms", "run_1p0_wls2.csv",
                 "run_1p0_note.txt"):
        (tmp_path / name).write_bytes(b"")
    text = re.search(r"```toml\n(.+?)\n```", DOC.read_text(), re.S).group(1)
    path = tmp_path / "scene.toml"
    path.write_text(text)
    return load_scene(path)


@pytest.fixture
def result(tmp_path: Path) -> ValidationResult:
    scene = _scene(tmp_path)
    rng = np.random.default_rng(1)
    angle = np.linspace(0, 2 * np.pi, 72, endpoint=False)
    comparisons = []
    for spec in scene.comparisons:
        truth = np.sin(angle) + 0.3 * np.sin(2 * angle)
        cycles = truth + 0.05 * rng.standard_normal((6, angle.size))
        rating = 0.5 if spec.name == "str1" else 0.9  # str1 fails its ">= 0.58"
        scores = {"iso18571_periodic.rating": rating, "iso18571_periodic.grade": "good",
                  "nrmse": 0.05}
        checks = tuple(check_thresholds(scores, spec.thresholds))
        comparisons.append(ComparisonResult(
            spec=spec, units=scene.units(spec.measured), long_name=spec.name,
            angle=angle, cycles=cycles, model=truth * 1.02, offset=0.0, scores=scores,
            baseline={"median": {"iso18571_periodic.rating": 0.97},
                      "worst": {"iso18571_periodic.rating": 0.93}},
            checks=checks))
    alignment = {
        name: StreamAlignment(
            stream=name, device=spec.device, is_reference=name == "cdaq", offset_s=0.1,
            drift_ppm=20.0, residual_rms_s=3e-6, events_matched=19, events_missing=1,
            events_spurious=0, input_delay_s=0.0, segments=1,
            gaps=({"after_s": 5.0, "duration_s": 0.2, "missing_samples": 322},),
            span_s=(0.0, 20.0), residual_time=np.arange(19.0),
            residual_s=3e-6 * rng.standard_normal(19), pulse_time=np.linspace(0, 2, 200),
            pulse_signal=(np.linspace(0, 2, 200) % 1 < 0.1) * 5.0, pulse_units="V",
            edge_times=np.array([0, 1.0]))
        for name, spec in scene.streams.items()}
    supports = ["P3", "P4", "P10", "P11"]
    predictions = xr.Dataset(
        {"support_force": (("angle", "support", "axis"), rng.standard_normal((72, 4, 2)) * 1e3,
                           {"units": "N"}),
         **{q: (("angle", "point", "axis"), rng.standard_normal((72, 1, 2)), {"units": u})
            for q, u in (("point_position", "m"), ("point_velocity", "m s-1"),
                         ("point_acceleration", "m s-2"))}},
        coords={"angle": angle, "support": supports, "point": ["P1"], "axis": ["x", "y"]})
    raw = xr.Dataset({"acc1": ("time", np.arange(10, dtype=np.float32))},
                     coords={"time": np.arange(10.0)})
    tree = xr.DataTree.from_dict({"/raw/cdaq": raw, "/model": predictions})
    numerics = NumericsSummary({"read": 0.5, "align": 0.1}, {"position": 1e-12},
                               {c.name: 1e-6 for c in comparisons}, 72)
    return ValidationResult(scene=scene, comparisons=tuple(comparisons), alignment=alignment,
                            predictions=predictions, numerics=numerics, speed_rev_s=1.0,
                            n_cycles=6, tree=tree, mechanism=load_mechanism(scene.mechanism),
                            note=read_note(scene.note) if scene.note else None,
                            input_digests=tuple((p, source_checksum(p))
                                                for p in scene.input_files))


def test_report_folder_has_every_file(result: ValidationResult, tmp_path: Path) -> None:
    out = tmp_path / "report"
    written = write_report(result, out)
    names = sorted(p.name for p in written)
    assert names == ["alignment.json", "metrics.csv", "metrics.json", "report.html",
                     "rigidity.json", "scene.nc"]
    # a result built without the pipeline keeps no signal for the residual spectra: nothing
    # is analysed, nothing invented (the rig's runs: tests/validation/test_diagnosis_*.py)
    assert json.loads((out / "rigidity.json").read_text()) == {}
    html_text = (out / "report.html").read_text()
    # comparisons, alignment, sketch, predictions: inline SVGs, each with its caption as label
    assert html_text.count("<svg ") == 3 + 3 + 1 + 2 and "<img " not in html_text
    assert 'aria-label="acc1: overlay, residual and harmonic orders"' in html_text
    assert "the mechanism at t = 0" in html_text
    assert "FAILED" in html_text and not result.passed
    rows = list(csv.DictReader((out / "metrics.csv").open()))
    model_rows = [r for r in rows if r["row"] == "model"]
    assert {r["comparison"] for r in model_rows} == {"acc1", "tor1", "str1"}
    assert any(r["row"] == "baseline worst" for r in rows)
    doc = json.loads((out / "metrics.json").read_text())
    assert doc["passed"] is result.passed
    alignment = json.loads((out / "alignment.json").read_text())
    assert alignment["wls1"]["drift_ppm"] == 20.0 and alignment["wls1"]["gaps"][0]["after_s"] == 5


def test_threshold_failures_are_reported(result: ValidationResult) -> None:
    rows = result.metric_rows()
    nrmse = [r for r in rows if r["comparison"] == "acc1" and r["metric"] == "nrmse"]
    assert nrmse == [{"comparison": "acc1", "row": "model", "metric": "nrmse", "value": 0.05,
                      "threshold": "<= 0.15", "passed": True}]
    assert [c.passed for c in result.comparisons] == [True, True, False]
    str1 = [r for r in rows if r["comparison"] == "str1" and r["row"] == "model"]
    assert [r["passed"] for r in str1 if r["threshold"]] == [False]


def test_netcdf_has_provenance_and_compression(result: ValidationResult, tmp_path: Path) -> None:
    write_report(result, tmp_path)
    tree = xr.open_datatree(tmp_path / "scene.nc")
    assert tree.attrs["scene_sha256"] == result.scene.sha256
    assert tree.attrs["Conventions"].startswith("CF-")
    assert len(tree["input_sha256"].values[0]) == 64
    assert [str(p) for p in tree["input_file"].values] == [
        str(p) for p in result.scene.input_files]
    # plain open_dataset shows the root: the verdicts and where the groups are
    with xr.open_dataset(tmp_path / "scene.nc") as root:
        assert list(root["comparison"].values) == [c.name for c in result.comparisons]
        assert list(root["passed"].values) == [int(c.passed) for c in result.comparisons]
        assert "2 of 3 comparisons pass" in root.attrs["summary"] and "str1" in root.attrs[
            "summary"]
        assert "open_datatree" in root.attrs["summary"]
        assert root.attrs["groups"].split() == [  # in the file's order, /health too
            node.path for node in tree.subtree if node.path != "/" and node.has_data]
    assert tree["raw/cdaq"]["acc1"].dtype == np.float32
    assert tree["raw/cdaq"]["acc1"].encoding["zlib"] and tree["raw/cdaq"]["acc1"].encoding[
        "complevel"] == 4


def test_comparison_figure_draws_the_data(result: ValidationResult) -> None:
    from matplotlib.figure import Figure

    from rigval.validation.report.plots import plot_comparison

    comparison = result.comparisons[0]
    fig = plot_comparison(comparison)
    assert isinstance(fig, Figure)
    top, residual, spectrum = fig.axes
    lines = {line.get_label(): line for line in top.get_lines()}
    np.testing.assert_allclose(lines["measured mean"].get_ydata()[:-1], comparison.mean)
    np.testing.assert_allclose(lines["model"].get_ydata()[:-1], comparison.model)
    assert lines["model"].get_xdata()[-1] == 360.0  # periodic curve closed at 360 deg
    (difference,) = residual.get_lines()[:1]
    np.testing.assert_allclose(difference.get_ydata()[:-1], comparison.model - comparison.mean)
    # the synthetic signal is sin + 0.3 sin 2: orders 1 and 2 carry the amplitude
    measured_bars = spectrum.collections[0]  # one rectangle per order, left to right
    assert measured_bars.get_label() == "measured mean"
    heights = [path.vertices[:4, 1].max() for path in measured_bars.get_paths()]
    assert len(heights) == 10
    assert heights[0] == pytest.approx(1.0, abs=0.05) and heights[1] == pytest.approx(0.3,
                                                                                       abs=0.05)
