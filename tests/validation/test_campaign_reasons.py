"""A run that did not pass says why, in the terminal and on the summary page; wide metric
tables show the key scores and fold the rest."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

from rigval.validation.campaign.engine import RunError, RunOutcome
from rigval.validation.campaign.runs import run_reason
from rigval.validation.report.page import Page

STANDIN = '''
import json, sys, tomllib
from pathlib import Path
import numpy as np
import xarray as xr
from rigval.acquisition.errors import DataFileError
from rigval.validation.campaign import runs as campaign
from rigval.validation.cli import main

def standin(scene, run_dir):
    spec = tomllib.loads(Path(scene).read_text())
    data = Path(scene).parent / spec["data"]
    try:
        values = np.loadtxt(data, ndmin=1)
    except ValueError:
        raise DataFileError("not a column of numbers", where={"file": data},
                            hint="write one number per line") from None
    rows = [{"comparison": "acc1", "row": "model", "metric": "nrmse",
             "value": float(values.mean()), "threshold": "<= 1", "passed":
             bool(values.mean() <= 1)}]
    rows += [{"comparison": "acc1", "row": "model", "metric": f"extra{i}", "value": float(i),
              "threshold": None, "passed": None} for i in range(30)]
    report = Path(run_dir) / "report.html"
    report.write_text("<html>report</html>")
    netcdf = Path(run_dir) / "run.nc"
    metrics = xr.DataArray([[values.mean()]], dims=("channel", "metric"),
                           coords={"channel": ["acc1"], "metric": ["nrmse"]})
    xr.DataTree.from_dict({"/validation": xr.Dataset({"metrics": metrics})}).to_netcdf(netcdf)
    return campaign.RunReport(passed=all(r["passed"] is not False for r in rows),
                              metrics=tuple(rows), outputs=(report, netcdf), inputs=(data,),
                              speed_rev_s=spec["speed"])

campaign._validate_with_pipeline = standin
sys.exit(main(sys.argv[1:]))
'''


def _scene(folder: Path, name: str, speed: float, data: str) -> Path:
    (folder / f"{name}.csv").write_text(data)
    scene = folder / f"{name}.toml"
    scene.write_text(f'speed = {speed}\ndata = "{name}.csv"\n')
    return scene


def test_failed_and_broken_runs_say_why_in_terminal_and_page(tmp_path: Path) -> None:
    script = tmp_path / "standin.py"
    script.write_text(STANDIN)
    scenes = [_scene(tmp_path, "slow", 0.5, "0.2\n0.4\n"),
              _scene(tmp_path, "fast", 1.5, "2.0\n4.0\n"),
              _scene(tmp_path, "broken", 0.8, "not numbers\n")]
    out = tmp_path / "out"
    result = subprocess.run([sys.executable, str(script), "campaign", *map(str, scenes),
                             "--out", str(out), "--scheduler", "none"],
                            capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert result.returncode == 3, result.stderr
    err = result.stderr
    assert "rigval: run fast failed: missed acc1 nrmse 3 (needs <= 1)" in err
    assert re.search(r"rigval: run broken error: DataFileError: not a column of numbers "
                     r"\(file: .*broken\.csv\)", err)
    assert "run slow" not in err
    page = (out / "index.html").read_text()
    assert "missed acc1 nrmse 3 (needs &lt;= 1)" in page
    assert "DataFileError: not a column of numbers" in page
    # 31 metrics per run: the key scores shown, all columns folded under <details>
    assert "<summary>all 33 columns of 2 rows (acc1)</summary>" in page


def _outcome(status: str, metrics: tuple = (), error: RunError | None = None) -> RunOutcome:
    return RunOutcome(name="r", scene=Path("r.toml"), run_dir=Path("r"), status=status,
                      metrics=metrics, error=error)


def test_reason_lists_the_missed_thresholds_and_counts_the_rest() -> None:
    rows = tuple({"comparison": f"c{i}", "row": "model", "metric": "nrmse", "value": 0.5 + i,
                  "threshold": "<= 0.15", "passed": False} for i in range(5))
    baseline = ({"comparison": "c9", "row": "baseline median", "metric": "nrmse",
                 "value": 9.0, "threshold": "<= 0.15", "passed": False},)
    assert run_reason(_outcome("failed", rows + baseline)) == (
        "missed c0 nrmse 0.5 (needs <= 0.15); c1 nrmse 1.5 (needs <= 0.15); c2 nrmse 2.5 "
        "(needs <= 0.15); and 2 more")
    assert run_reason(_outcome("passed", ({"row": "model", "passed": True},))) == ""
    error = RunError(kind="AlignmentError", message="no common pulses", where={"stream": "wls1"},
                     hint=None, traceback="")
    assert run_reason(_outcome("error", error=error)) == (
        "AlignmentError: no common pulses (stream: wls1)")


def test_wide_table_shows_key_columns_and_folds_the_rest() -> None:
    rows = [{"run": f"r{i}", "rating": 0.9, **{f"m{k}": k for k in range(50)}} for i in range(3)]
    page = Page("t")
    page.wide_table(rows, key=["run", "rating", "absent"], caption="acc1")
    html = page.render()
    first, folded = html.split("<details>", 1)
    assert first.count("<th class") == 2 and ">rating</th>" in first and ">m0</th>" not in first
    assert folded.count("<th class") == 52 and "all 52 columns of 3 rows (acc1)" in folded
    long = Page("t")
    long.wide_table([{"a": i, "b": i} for i in range(110)], key=["a", "b"], caption="sweep")
    text = long.render()
    assert text.count("<details>") == 1 and "sweep: all 110 rows" in text
    assert text.index("<details>") < text.index("<table>")
