"""The validate netCDF holds data, not JSON text, and its times decode as CF (issue 18).

One short virtual-rig run with raw and aligned groups kept: every attribute in every group is a
number, a string that is not JSON, or an array of them; thresholds and low-pass corners read back
equal to the scene; aligned times decode to wall clock on the reference stream's origin.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from rigval.acquisition.schema import string_table
from rigval.sample_data import RigSettings, simulate_rig
from rigval.validation.pipeline import run_scene
from rigval.validation.report.run_report import write_netcdf
from rigval.validation.scene import load_scene


@pytest.fixture(scope="module")
def written(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    folder = tmp_path_factory.mktemp("rig")
    simulate_rig(folder, RigSettings(speed=1.0, duration=12.0, seed=7))
    scene = next(folder.glob("*_scene.toml"))
    scene.write_text(scene.read_text() + "\n[output]\nraw = true\naligned = true\n")
    path = folder / "run.nc"
    write_netcdf(run_scene(scene), path)
    return scene, path


def _is_json_text(value: object) -> bool:
    if not isinstance(value, str) or not value.strip().startswith(("[", "{")):
        return False
    try:
        json.loads(value)
    except ValueError:
        return False
    return True


def test_no_attribute_is_json_text(written: tuple[Path, Path]) -> None:
    _, path = written
    with xr.open_datatree(path) as tree:
        found = [(node.path, name, key) for node in tree.subtree
                 for name, attrs in [("", node.attrs)] + [(v, node[v].attrs)
                                                           for v in node.variables]
                 for key, value in attrs.items() if _is_json_text(value)]
        assert found == []
        assert set(tree["aligned"].children) == {"cdaq", "wls1", "wls2"}
        wls2 = tree["raw/wls2"].attrs  # the CSV stream: its header is a string table
        assert "text_header" not in wls2 and isinstance(string_table(wls2, "text_header"), dict)


def test_thresholds_and_lowpass_read_back_as_in_the_scene(written: tuple[Path, Path]) -> None:
    scene_path, path = written
    scene = load_scene(scene_path)
    with xr.open_datatree(path) as tree:
        validation = tree["validation"].to_dataset()
        for spec in scene.comparisons:
            rules = validation["threshold"].sel(comparison=spec.name)
            kept = {str(s): str(r) for s, r in zip(rules["score"].values, rules.values,
                                                   strict=True) if str(r)}
            assert kept == dict(spec.thresholds)
            attrs = tree["angle"][spec.name].attrs
            if spec.lowpass_hz is None:
                assert "lowpass_hz" not in attrs
            else:
                assert attrs["lowpass_hz"] == spec.lowpass_hz


def test_aligned_times_decode_on_the_reference_origin(written: tuple[Path, Path]) -> None:
    _, path = written
    with xr.open_datatree(path, decode_times=False) as tree:
        units = {name: tree[f"aligned/{name}"]["time"].attrs["units"]
                 for name in ("cdaq", "wls1", "wls2")}
        assert set(units.values()) == {tree["raw/cdaq"]["time"].attrs["units"]}
        assert units["cdaq"].startswith("seconds since ")
        aligned = xr.decode_cf(tree["aligned/cdaq"].to_dataset())
        raw = xr.decode_cf(tree["raw/cdaq"].to_dataset())
        assert aligned["time"].dtype.kind == "M"
        np.testing.assert_array_equal(aligned["time"].values, raw["time"].values)
        wls1 = xr.decode_cf(tree["aligned/wls1"].to_dataset())
        segments = np.atleast_1d(wls1.attrs["segments"])
        offsets = np.atleast_1d(wls1.attrs["segment_clock_offset_s"])
        assert segments.dtype.kind == "i" and offsets.shape == segments.shape
        assert np.atleast_1d(wls1.attrs["unaligned_segments"]).dtype.kind in "if"
