"""``rigval predict`` as a user types it (subprocess): --speed, NAME=NUMBER, --list-drivers, the
units printed, swept angles kept in degrees; ``rigval bench``'s closing line."""

from __future__ import annotations

import csv
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from rigval.model import builtin_mechanism, load_mechanism
from rigval.validation.bench.core import BenchRow
from rigval.validation.bench.report import closing_line


def rigval(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "rigval.validation.cli", *args],
                          capture_output=True, text=True, cwd=cwd, timeout=600,
                          env={**os.environ, "OMP_NUM_THREADS": "1"})


def _peaks(folder: Path) -> list[dict[str, str]]:
    with open(folder / "peaks.csv", newline="") as handle:
        return list(csv.DictReader(handle))


def test_speed_option_number_shorthand_and_inline_law_agree(tmp_path: Path) -> None:
    runs = {"speed": ["--speed", "1.5"], "short": ["--drive", "theta_F=1.5"],
            "rpm": ["--drive", "theta_F=90rpm"],
            "law": ["--drive", "theta_F={frequency = 1.5}"], "file": []}
    out = {}
    for name, options in runs.items():
        result = rigval("predict", "builtin:pendulum", "--points", "72", *options,
                        "--out", str(tmp_path / name), cwd=tmp_path)
        assert result.returncode == 0, result.stderr
        out[name] = result.stdout.replace(str(tmp_path / name), "DIR")
    assert out["speed"] == out["short"] == out["rpm"] == out["law"]
    assert out["file"] != out["speed"]  # the file's law runs at 1 rev/s
    law = xr.open_datatree(tmp_path / "speed" / "prediction.nc")["prediction"].to_dataset()
    assert law.attrs["frequency_hz"] == pytest.approx(1.5, rel=1e-12)


def test_number_for_a_secondary_drive_is_a_usage_error(tmp_path: Path) -> None:
    result = rigval("predict", "builtin:pendulum", "--drive", "theta_H=2", "--out",
                    str(tmp_path / "x"), cwd=tmp_path)
    assert result.returncode == 2
    assert "main drive theta_F" in result.stderr and "theta_H" in result.stderr


def test_list_drivers_names_each_driver_of_the_file_without_out(tmp_path: Path) -> None:
    result = rigval("predict", "builtin:pendulum", "--list-drivers", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    mechanism = load_mechanism(builtin_mechanism("pendulum"))
    listed = [line.split(":")[0].strip() for line in result.stdout.splitlines()
              if line.startswith("  ")]
    assert listed == list(mechanism.driver_names)
    assert "main drive theta_F" in result.stdout
    assert not list(tmp_path.iterdir())  # nothing written
    missing = rigval("predict", "builtin:pendulum", cwd=tmp_path)
    assert missing.returncode == 2 and "--out" in missing.stderr


def test_stdout_units_are_the_units_of_the_files(tmp_path: Path) -> None:
    result = rigval("predict", "builtin:pendulum", "--points", "72", "--out",
                    str(tmp_path / "p"), cwd=tmp_path)
    assert result.returncode == 0
    data = xr.open_datatree(tmp_path / "p" / "prediction.nc")["prediction"].to_dataset()
    first, torque = result.stdout.splitlines()[0], result.stdout.splitlines()[1]
    assert first.endswith(f"{float(data['tip_acceleration_peak']):.4g} "
                          f"{data['tip_acceleration_peak'].attrs['units']}")
    assert data["tip_acceleration_peak"].attrs["units"] == "m s-2" and "m/s2" not in first
    assert f"{float(data['torque_peak'].sel(driver='theta_F')):.5g} N m" in torque
    peaks = _peaks(tmp_path / "p")
    assert {row["unit"] for row in peaks} <= {"N", "N m", "m s-2"}
    # on a 72-point grid every peak is at a multiple of 5 degrees, written as such
    assert all(float(row["angle_deg"]) % 5.0 == 0.0 for row in peaks), peaks


def test_sweep_table_keeps_degrees_as_given_and_states_units(tmp_path: Path) -> None:
    result = rigval("predict", "builtin:pendulum", "--points", "36", "--sweep-points", "36",
                    "--sweep", "theta_H.phase=0:268:3deg", "--sweep", "frequency=0.5,1.0",
                    "--summary", "torque_peak", "--out", str(tmp_path / "s"), cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    with open(tmp_path / "s" / "sweep.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert "theta_H.phase [deg]" in rows[0] and "frequency [Hz]" in rows[0]
    assert sorted({row["theta_H.phase [deg]"] for row in rows}, key=float) == ["0.0", "134.0",
                                                                              "268.0"]
    # the netCDF keeps SI (rad): the same points
    tree = xr.open_datatree(tmp_path / "s" / "prediction.nc")
    np.testing.assert_allclose(np.degrees(tree["sweep"]["theta_H_phase"].values),
                               [0.0, 134.0, 268.0], rtol=0, atol=1e-12)


def _row(error: float, bound: float, choice: str = "c") -> BenchRow:
    return BenchRow(stage="model", case="k", choice=choice, baseline="c", metric="m", n=1,
                    time_s=1.0, cpu_s=1.0, error=error, baseline_error=error, unit="1",
                    bound=bound, limit=math.nan)


def test_bench_closing_line_counts_rows_against_their_bounds() -> None:
    assert closing_line([_row(0.0, 1e-9), _row(1e-10, 1e-9)]) == (
        "rigval bench: all 2 rows within their bounds")
    line = closing_line([_row(2e-9, 1e-9, "fast"), _row(1e-10, 1e-9), _row(math.nan, 1.0, "x")])
    assert line.startswith("rigval bench: 2 of 3 rows exceed their bounds:")
    assert "model / k / fast / m" in line and "model / k / x / m" in line


def test_bench_prints_its_closing_line(tmp_path: Path) -> None:
    result = rigval("bench", "--quick", "--stage", "derivatives", "--out", str(tmp_path),
                    cwd=tmp_path)
    with open(tmp_path / "bench.csv", newline="") as handle:
        n = sum(1 for _ in csv.DictReader(handle))
    assert result.returncode == 0
    assert result.stdout.rstrip().splitlines()[-1] == (
        f"rigval bench: all {n} rows within their bounds")
