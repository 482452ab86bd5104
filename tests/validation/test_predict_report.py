"""``rigval predict``: the report folder, its data files and the exit codes."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import xarray as xr

from rigval.model.predict import file_excitation, predict, resolve_mechanism
from rigval.validation.cli import EXIT_OK, EXIT_USAGE, main


@pytest.fixture(scope="module")
def report_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("predict")
    code = main(["predict", "builtin:pendulum", "--out", str(out), "--points", "72",
                 "--sweep-points", "36", "--joint", "P2", "--sweep", "frequency=0.5:1.5:3",
                 "--sweep", "theta_H.phase=0:240:3deg"])
    assert code == EXIT_OK
    return out


def test_report_page_shows_every_section(report_dir: Path) -> None:
    html = (report_dir / "report.html").read_text(encoding="utf-8")
    for heading in ("Tip P1", "Drive torques and power", "Support forces on the frame",
                    "Joint forces", "Sweep"):
        assert f">{heading}</h2>" in html
    assert "vertical range of the P1 path" in html
    assert "rigval predict builtin:pendulum --out" in html and "theta_H.phase=0:240:3deg" in html
    assert len(re.findall(r"<img src=\"data:image/png;base64,", html)) == 8  # with the sketch
    assert "the mechanism at t = 0" in html
    assert "src=\"http" not in html  # self-contained


def test_data_files_agree_with_each_other(report_dir: Path) -> None:
    tree = xr.open_datatree(report_dir / "prediction.nc", engine="h5netcdf")
    assert tree.attrs["Conventions"].startswith("CF") and "rigval predict" in tree.attrs["history"]
    prediction = tree["prediction"].to_dataset()
    cycle = pd.read_csv(report_dir / "cycle.csv")
    assert len(cycle) == 72
    np.testing.assert_allclose(cycle["support_P3_x_N"],
                               prediction["support_force"].sel(support="P3", axis="x").values)
    np.testing.assert_allclose(cycle["joint_P2_y_N"],
                               prediction["joint_force"].sel(joint="P2", axis="y").values)
    peaks = pd.read_csv(report_dir / "peaks.csv")
    p3 = peaks[(peaks["where"] == "P3") & (peaks["component"] == "magnitude")].iloc[0]
    magnitude = np.hypot(cycle["support_P3_x_N"], cycle["support_P3_y_N"])
    assert p3["peak"] == pytest.approx(magnitude.max())
    assert p3["angle_deg"] == pytest.approx(cycle["angle_deg"][magnitude.idxmax()])
    sweep = pd.read_csv(report_dir / "sweep.csv")
    assert len(sweep) == 9 and set(sweep["frequency [Hz]"]) == {0.5, 1.0, 1.5}
    # given in degrees, shown in degrees (exactly: 240, not 239.99999999999997); stored in rad
    assert sorted(set(sweep["theta_H.phase [deg]"])) == [0.0, 120.0, 240.0]
    swept = tree["sweep"].to_dataset()
    assert swept["torque_peak"].shape == (3, 3, 2)


def test_profile_option_matches_the_file_law(tmp_path: Path) -> None:
    """A tabulated main-drive profile of the file's own law predicts the same torques."""
    mechanism = resolve_mechanism("builtin:pendulum")
    law = file_excitation(mechanism).law("theta_F")
    t = np.linspace(0.0, 1.0, 241)
    theta = law.evaluate(t, 2 * math.pi)[0]
    csv = tmp_path / "main.csv"
    pd.DataFrame({"time_s": t, "angle_rad": theta}).to_csv(csv, index=False)
    from_profile = predict(mechanism, [f"theta_F={csv}"], n_points=72)
    assert "stated error" in from_profile.attrs["drive_laws"]
    exact = predict(mechanism, n_points=72)
    np.testing.assert_allclose(from_profile["driver_torque"].values,
                               exact["driver_torque"].values,
                               atol=1e-6 * float(np.abs(exact["driver_torque"]).max()))


def test_measured_excitation_file(tmp_path: Path) -> None:
    """Encoder angles counted from zero plus offsets reproduce the file-law prediction."""
    mechanism = resolve_mechanism("builtin:pendulum")
    measured = file_excitation(mechanism).to_dataset(np.arange(0.0, 3.0, 2e-3))
    offsets = {name: float(measured[name][0]) for name in ("theta_F", "theta_H")}
    for name, offset in offsets.items():
        measured[name] = measured[name] - offset
    path = tmp_path / "excitation.nc"
    measured.to_netcdf(path)
    code = main(["predict", "builtin:pendulum", "--out", str(tmp_path / "out"), "--points", "36",
                 "--measured", str(path),
                 *(f"--measured-offset={k}={v!r}" for k, v in offsets.items())])
    assert code == EXIT_OK
    tree = xr.open_datatree(tmp_path / "out" / "prediction.nc", engine="h5netcdf")
    exact = predict(mechanism, n_points=36)
    np.testing.assert_allclose(tree["prediction"]["driver_torque"].values,
                               exact["driver_torque"].values,
                               atol=1e-6 * float(np.abs(exact["driver_torque"]).max()))


@pytest.mark.parametrize("options", [
    ["--drive", "theta_X={phase = 1}"],
    ["--drive", "theta_H={speed = 2}"],
    ["--sweep", "frequency=1:2"],
    ["--sweep", "a=1", "--sweep", "b=2", "--sweep", "c=3"],
    ["--sweep", "frequency=1,2", "--summary", "nonsense"],
    ["--joint", "P99"],
    ["--measured", "x.nc", "--drive", "theta_F={phase = 1}"],
])
def test_bad_options_are_usage_errors(tmp_path: Path, options: list[str],
                                      capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["predict", "builtin:pendulum", "--out", str(tmp_path), "--points", "24",
                 *options])
    assert code == EXIT_USAGE
    assert "rigval: configuration error" in capsys.readouterr().err
