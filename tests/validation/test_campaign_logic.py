"""Campaign machinery with a small stand-in validation: outcomes, errors, resume, summary, CLI.

The stand-in reads a one-column CSV named by a tiny TOML "scene", scores its mean against a
threshold, and writes a report, a metrics file and a netCDF file with a ``validation`` group. Its
results are known in closed form, so the campaign's bookkeeping can be checked exactly and fast,
one run after the other in this process (the cluster path is tested in test_campaign_cluster.py).
"""

from __future__ import annotations

import io
import json
import pickle
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import xarray as xr

import rigval.validation.campaign.engine as campaign
import rigval.validation.campaign.runs as runs
from rigval.acquisition.errors import ConfigError, DataFileError
from rigval.validation.campaign.engine import RunError, RunReport, plan_runs, run_campaign, run_one
from rigval.validation.campaign.report import (
    metrics_table,
    open_campaign,
    plot_metrics_against_speed,
    write_campaign_report,
)
from rigval.validation.cli import main
from rigval.validation.commands.campaign import _ProgressLine

LIMIT = 1.0
CALLS: list[str] = []


def standin_validate(scene: Path, run_dir: Path) -> RunReport:
    """Score the mean of the scene's data column against ``<= LIMIT``."""
    CALLS.append(scene.stem)
    spec = tomllib.loads(scene.read_text())
    data = scene.parent / spec["data"]
    try:
        values = np.loadtxt(data, ndmin=1)
    except ValueError as error:
        raise DataFileError("not a column of numbers", where={"file": data},
                            hint="write one number per line") from error
    rows = [{"comparison": "acc1", "metric": "mean", "value": float(values.mean()),
             "threshold": f"<= {LIMIT}", "passed": bool(values.mean() <= LIMIT)},
            {"comparison": "acc1", "metric": "peak", "value": float(values.max()),
             "threshold": None, "passed": None}]
    report = run_dir / "report.html"
    report.write_text("<html>report</html>")
    table = run_dir / "metrics.json"
    table.write_text(json.dumps(rows))
    metrics = xr.DataArray([[values.mean(), values.max()]], dims=("channel", "metric"),
                           coords={"channel": ["acc1"], "metric": ["mean", "peak"]})
    netcdf = run_dir / f"{scene.stem}.nc"
    xr.DataTree.from_dict({"/validation": xr.Dataset({"metrics": metrics})}).to_netcdf(netcdf)
    return RunReport(passed=all(r["passed"] is not False for r in rows), metrics=tuple(rows),
                     outputs=(report, table, netcdf), inputs=(data,),
                     speed_rev_s=spec["speed"])


def write_run(folder: Path, name: str, speed: float, values: list[float] | str) -> Path:
    """Write a stand-in scene and its data file; return the scene path."""
    folder.mkdir(parents=True, exist_ok=True)
    text = values if isinstance(values, str) else "\n".join(map(str, values))
    (folder / f"{name}.csv").write_text(text)
    scene = folder / f"{name}.toml"
    scene.write_text(f'speed = {speed}\ndata = "{name}.csv"\n')
    return scene


@pytest.fixture
def scenes(tmp_path: Path) -> list[Path]:
    CALLS.clear()
    data = tmp_path / "data"
    return [write_run(data, "slow", 0.5, [0.2, 0.4]),
            write_run(data, "broken", 0.8, "not numbers"),
            write_run(data, "fast", 1.5, [1.0, 2.0])]


def test_campaign_reports_each_run_and_carries_the_error(tmp_path: Path,
                                                         scenes: list[Path]) -> None:
    outcomes = run_campaign(scenes, tmp_path / "out", scheduler="none",
                            validate=standin_validate)
    assert [o.name for o in outcomes] == ["slow", "broken", "fast"]
    assert [o.status for o in outcomes] == ["passed", "error", "failed"]
    slow, broken, fast = outcomes
    assert slow.metrics[0]["value"] == pytest.approx(0.3)
    assert fast.metrics[1]["value"] == pytest.approx(2.0)
    assert fast.speed_rev_s == 1.5
    error = broken.error
    assert error is not None
    assert error.kind == "DataFileError"
    assert error.where == {"file": scenes[1].parent / "broken.csv"}
    assert error.hint == "write one number per line"
    assert "standin_validate" in error.traceback
    assert isinstance(error.exception, DataFileError)
    assert broken.metrics == ()
    assert not (tmp_path / "out" / "broken" / runs.MANIFEST_NAME).exists()


def test_summary_files_list_every_run_metric_and_error(tmp_path: Path,
                                                       scenes: list[Path]) -> None:
    out = tmp_path / "out"
    outcomes = run_campaign(scenes, out, scheduler="none", validate=standin_validate)
    files = write_campaign_report(outcomes, out, details={"scheduler": "none"})
    table = pd.read_csv(files.metrics_csv)
    assert list(table["run"]) == ["slow", "slow", "fast", "fast"]
    assert table.loc[table["metric"] == "mean", "value"].tolist() == pytest.approx([0.3, 1.5])
    document = json.loads(files.outcomes_json.read_text())
    assert document["counts"] == {"passed": 1, "failed": 1, "error": 1}
    assert document["runs"][1]["error"]["kind"] == "DataFileError"
    page = files.html.read_text()
    assert 'href="slow/report.html"' in page
    assert "not a column of numbers" in page
    assert "write one number per line" in page
    assert page.count("<svg") >= 1


def test_rigval_error_survives_pickling_with_its_fields() -> None:
    error = DataFileError("bad", where={"file": "x.tdms"}, hint="fix it")
    record = pickle.loads(pickle.dumps(RunError.from_exception(error)))
    assert (record.kind, record.message, record.where, record.hint) == (
        "DataFileError", "bad", {"file": "x.tdms"}, "fix it")
    assert isinstance(record.exception, DataFileError)
    assert record.exception.where == {"file": "x.tdms"}


def test_unpicklable_exception_is_described_without_the_object() -> None:
    class Local(Exception):  # a local class cannot be pickled
        pass

    record = RunError.from_exception(Local("boom"))
    assert (record.kind, record.message, record.exception) == ("Local", "boom", None)
    assert record.hint


def test_up_to_date_runs_are_reused_and_changed_ones_recomputed(
        tmp_path: Path, scenes: list[Path], monkeypatch: pytest.MonkeyPatch) -> None:
    out = tmp_path / "out"
    first = run_campaign(scenes, out, scheduler="none", validate=standin_validate)
    CALLS.clear()
    second = run_campaign(scenes, out, scheduler="none", validate=standin_validate)
    assert CALLS == ["broken"]  # errors are never reused
    assert [o.reused for o in second] == [True, False, True]
    assert [(o.status, o.metrics, o.speed_rev_s) for o in second] == [
        (o.status, o.metrics, o.speed_rev_s) for o in first]
    assert [(o.elapsed_s, o.cpu_s) for o in second[::2]] == [  # of the original computation
        (o.elapsed_s, o.cpu_s) for o in first[::2]]

    (scenes[0].parent / "slow.csv").write_text("0.1\n0.2\n")  # an input changed
    (out / "fast" / "metrics.json").unlink()  # an output lost
    CALLS.clear()
    third = run_campaign(scenes, out, scheduler="none", validate=standin_validate)
    assert CALLS == ["slow", "broken", "fast"]
    assert third[0].metrics[0]["value"] == pytest.approx(0.15)

    CALLS.clear()
    monkeypatch.setattr(runs, "_rigval_version", lambda: "99.0")
    run_campaign(scenes[:1], out, scheduler="none", validate=standin_validate)
    assert CALLS == ["slow"]
    CALLS.clear()
    run_campaign(scenes[:1], out, scheduler="none", validate=standin_validate, force=True)
    assert CALLS == ["slow"]


def test_changed_scene_is_recomputed(tmp_path: Path, scenes: list[Path]) -> None:
    run_one(scenes[0], tmp_path / "run", validate=standin_validate)
    scenes[0].write_text(scenes[0].read_text().replace("0.5", "0.6"))
    outcome = run_one(scenes[0], tmp_path / "run", validate=standin_validate)
    assert not outcome.reused
    assert outcome.speed_rev_s == 0.6


def test_run_names_are_unique_and_stable(tmp_path: Path) -> None:
    scenes = [tmp_path / "a" / "run.toml", tmp_path / "b" / "run.toml", tmp_path / "a" / "x.toml",
              tmp_path / "a" / "run.toml", tmp_path / "a" / "run_0p8_scene.toml",
              tmp_path / "day3" / "scene.toml"]
    plan = plan_runs(scenes, tmp_path / "out")
    assert [name for name, _, _ in plan] == ["a_run", "b_run", "x", "run_0p8", "day3"]
    assert plan[2][2] == tmp_path / "out" / "x"


def test_open_campaign_stacks_runs(tmp_path: Path, scenes: list[Path]) -> None:
    out = tmp_path / "out"
    outcomes = run_campaign(scenes, out, scheduler="none", validate=standin_validate)
    write_campaign_report(outcomes, out)
    with open_campaign(out) as data:
        assert list(data["run"].values) == ["slow", "fast"]
        assert data["speed_rev_s"].values.tolist() == [0.5, 1.5]
        expected = metrics_table(outcomes).pivot_table(index="run", columns="metric",
                                                       values="value", sort=False)
        np.testing.assert_allclose(data["metrics"].sel(channel="acc1", metric="mean").values,
                                   expected["mean"].to_numpy())


def test_without_dask_runs_go_one_after_the_other(
        tmp_path: Path, scenes: list[Path], monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(campaign, "dask_available", lambda: False)
    outcomes = run_campaign(scenes[:1], tmp_path / "out", validate=standin_validate)
    assert outcomes[0].status == "passed"
    with pytest.raises(ConfigError, match="needs Dask"):
        run_campaign(scenes[:1], tmp_path / "out", scheduler="local", validate=standin_validate)


def test_unknown_scheduler_is_a_config_error(tmp_path: Path, scenes: list[Path]) -> None:
    with pytest.raises(ConfigError, match="unknown scheduler"):
        run_campaign(scenes[:1], tmp_path / "out", scheduler="fast")


@pytest.mark.parametrize(("names", "code"), [(["slow"], 0), (["slow", "fast"], 1),
                                             (["slow", "fast", "broken"], 3)])
def test_cli_exit_code_says_the_worst_run(tmp_path: Path, scenes: list[Path], names: list[str],
                                         code: int, monkeypatch: pytest.MonkeyPatch,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setattr(runs, "_validate_with_pipeline", standin_validate)
    chosen = [s for s in scenes if s.stem in names]
    out = tmp_path / "out"
    assert main(["campaign", *map(str, chosen), "--out", str(out), "--scheduler", "none"]) == code
    captured = capsys.readouterr()
    assert (out / "index.html").is_file()
    assert captured.out.splitlines()[-1].startswith(
        f"{names.count('slow')} passed, {names.count('fast')} failed, "
        f"{names.count('broken')} errors")
    assert ("DataFileError" in captured.err) == ("broken" in names)


def test_unreachable_scheduler_is_a_config_error(tmp_path: Path, scenes: list[Path]) -> None:
    dask = pytest.importorskip("dask", reason="the parallel extra is not installed")
    with (dask.config.set({"distributed.comm.timeouts.connect": "1s"}),
          pytest.raises(ConfigError, match="cannot reach the Dask scheduler")):
        run_campaign(scenes[:1], tmp_path / "out", scheduler="tcp://127.0.0.1:1")


def test_speed_plot_shows_each_run_and_rings_missed_thresholds(tmp_path: Path,
                                                               scenes: list[Path]) -> None:
    outcomes = run_campaign(scenes, tmp_path / "out", scheduler="none", validate=standin_validate)
    fig = plot_metrics_against_speed(metrics_table(outcomes))
    mean_ax, peak_ax = (ax for ax in fig.axes if ax.get_visible())
    assert mean_ax.get_title() == f"mean (pass: <= {LIMIT})"
    line, rings, limit = mean_ax.get_lines()
    np.testing.assert_allclose(line.get_xydata(), [[0.5, 0.3], [1.5, 1.5]])
    np.testing.assert_allclose(rings.get_xydata(), [[1.5, 1.5]])  # the failed run only
    assert limit.get_ydata()[0] == LIMIT
    np.testing.assert_allclose(peak_ax.get_lines()[0].get_xydata(), [[0.5, 0.4], [1.5, 2.0]])


def test_progress_line_counts_runs_by_status(tmp_path: Path, scenes: list[Path]) -> None:
    stream = io.StringIO()
    progress = _ProgressLine(3, stream, enabled=True)
    run_campaign(scenes, tmp_path / "out", scheduler="none", validate=standin_validate,
                 on_result=progress.update)
    progress.close()
    last = stream.getvalue().rstrip("\n").split("\r")[-1]
    assert "3/3 runs (1 passed, 1 failed, 1 errors)" in last


@pytest.mark.parametrize("text", ["{", '{"schema": "rigval-run-manifest/1"}', '{"result": 1}'])
def test_unreadable_manifest_means_recompute(tmp_path: Path, scenes: list[Path],
                                            text: str) -> None:
    run_one(scenes[0], tmp_path / "run", validate=standin_validate)
    (tmp_path / "run" / runs.MANIFEST_NAME).write_text(text)
    outcome = run_one(scenes[0], tmp_path / "run", validate=standin_validate)
    assert (outcome.status, outcome.reused) == ("passed", False)
    assert json.loads((tmp_path / "run" / runs.MANIFEST_NAME).read_text())["result"]


def test_runs_at_one_speed_are_not_joined_by_a_line(tmp_path: Path) -> None:
    rows = ({"comparison": "acc1", "metric": "nrmse", "value": 0.1},)
    outcomes = [runs.RunOutcome(name=f"day{i}", scene=tmp_path / f"day{i}.toml",
                                    run_dir=tmp_path / f"day{i}", status="passed", metrics=rows,
                                    speed_rev_s=1.0) for i in range(2)]
    (line,) = plot_metrics_against_speed(metrics_table(outcomes)).axes[0].get_lines()[:1]
    assert line.get_linestyle() == "None"
    np.testing.assert_allclose(line.get_xydata(), [[1.0, 0.1], [1.0, 0.1]])


def _summary_drawn_by_a_drawer() -> None:
    """The summary page's figure drawn by a drawer forked first equals the one drawn here,
    and this process never imports matplotlib (what ``rigval demo`` relies on)."""
    import re
    import sys
    import tempfile

    from rigval.validation.beside import Standby
    from rigval.validation.report.drawing import DRAWING_MODULES, Drawers
    from tests.validation.fresh_process import no_fork_here

    if no_fork_here():
        return
    standbys = Standby.group(1, (*DRAWING_MODULES, "rigval.validation.campaign.speed_plot"))
    with standbys[0], tempfile.TemporaryDirectory() as folder:
        data = Path(folder) / "data"
        runs = [write_run(data, "slow", 0.5, [0.2, 0.4]), write_run(data, "fast", 1.5, [1.0, 2.0])]
        outcomes = run_campaign(runs, Path(folder) / "out", scheduler="none",
                                validate=standin_validate)
        drawn = write_campaign_report(outcomes, Path(folder) / "a", drawers=Drawers(standbys))
        drawn_page = drawn.html.read_text(encoding="utf-8")
        assert "matplotlib" not in sys.modules
        here = write_campaign_report(outcomes, Path(folder) / "b").html.read_text(encoding="utf-8")
    svgs = [re.findall(r"<svg.*?</svg>", page, flags=re.S) for page in (drawn_page, here)]
    assert len(svgs[0]) == 1 and svgs[0] == svgs[1]


def test_the_summary_page_figure_is_drawn_by_a_drawer_without_matplotlib_here():
    from tests.validation.fresh_process import run_in_a_fresh_process

    run_in_a_fresh_process("test_campaign_logic", "_summary_drawn_by_a_drawer")
