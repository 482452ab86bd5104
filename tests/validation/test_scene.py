"""Scene parsing: the documented example parses, and every bad scene names its key."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

from rigval.acquisition.errors import ConfigError
from rigval.acquisition.units import dimension, same_unit
from rigval.validation.errors import SceneError
from rigval.validation.scene import load_scene, parse_scene

DOC = Path(__file__).resolve().parents[2] / "docs" / "scene.md"


def _example() -> str:
    return re.search(r"```toml\n(.+?)\n```", DOC.read_text(), re.S).group(1)


@pytest.fixture
def scene_dir(tmp_path: Path) -> Path:
    """A folder with the files the documented example names (contents are not read)."""
    for name in ("run_1p0_cdaq.tdms", "run_1p0_wls1.tdms", "run_1p0_wls2.csv",
                 "run_1p0_note.txt"):
        (tmp_path / name).write_bytes(b"")
    return tmp_path


def _write(scene_dir: Path, text: str) -> Path:
    path = scene_dir / "scene.toml"
    path.write_text(text)
    return path


def _key_of(scene_dir: Path, text: str) -> str:
    with pytest.raises(SceneError) as info:
        load_scene(_write(scene_dir, text))
    assert isinstance(info.value, ConfigError)  # the CLI maps it to exit code 2
    assert info.value.where["key"] in str(info.value)
    return info.value.where["key"]


def test_documented_example_parses(scene_dir: Path) -> None:
    scene = load_scene(_write(scene_dir, _example()))
    assert list(scene.streams) == ["cdaq", "wls1", "wls2"]
    assert scene.streams["cdaq"].channels["acc1"].params["charge_sensitivity"] == 10.2
    units = {str(c.measured): scene.units(c.measured) for c in scene.comparisons}
    assert units == {"cdaq.acc1": "m s-2", "wls1.tor1": "N m", "cdaq.str1": "Pa"}
    assert scene.alignment.pulses["wls2"].per_revolution == 2
    assert [c.name for c in scene.comparisons] == ["acc1", "tor1", "str1"]
    assert dict(scene.comparisons[0].thresholds) == {"iso18571_periodic.rating": ">= 0.8",
                                                     "nrmse": "<= 0.15"}
    assert scene.predictions.points == ("P1",)
    assert scene.predictions.supports == ("P3", "P4", "P10", "P11")
    assert scene.model.drivers["theta_H"].angle_at_reference == 4.5895
    assert scene.streams["cdaq"].file == (scene_dir / "run_1p0_cdaq.tdms").resolve()
    assert len(scene.sha256) == 64


def test_scene_is_frozen(scene_dir: Path) -> None:
    scene = load_scene(_write(scene_dir, _example()))
    with pytest.raises(AttributeError):
        scene.title = "x"  # type: ignore[misc]
    with pytest.raises(TypeError):
        scene.streams["x"] = scene.streams["cdaq"]  # type: ignore[index]


BAD = {
    "missing file": (('file = "run_1p0_wls1.tdms"', 'file = "nope.tdms"'), "streams.wls1.file"),
    "unknown channel": (('measured = "cdaq.acc1"', 'measured = "cdaq.acc9"'),
                        "comparisons[0].measured"),
    "unknown stream": (('measured = "wls1.tor1"', 'measured = "wls9.tor1"'),
                       "comparisons[1].measured"),
    "unknown point": (('item = "P1"', 'item = "P13"'), "comparisons[0].model.item"),
    "unknown quantity": (('quantity = "driver_torque"', 'quantity = "driver_power"'),
                         "comparisons[1].model.quantity"),
    "unknown driver": (('item = "theta_F" }', 'item = "theta_Q" }'),
                       "comparisons[1].model.item"),
    "wrong units": (('model = { quantity = "point_acceleration", item = "P1", axis = "x" }',
                     'model = { quantity = "point_velocity", item = "P1", axis = "x" }'),
                    "comparisons[0].model"),
    "missing scale_units": (('scale_units = "m-2"', ""), "comparisons[2].model"),
    "typo in a sensor key": (("gauge_factor = 2.05", "gauge_facter = 2.05"),
                             "streams.cdaq.channels.str1.gauge_facter"),
    "bad bridge": (('bridge = "half_II"', 'bridge = "half_III"'),
                   "streams.cdaq.channels.str1.bridge"),
    "negative sensitivity": (("charge_sensitivity = 10.2", "charge_sensitivity = -10.2"),
                             "streams.cdaq.channels.acc1.charge_sensitivity"),
    "bad threshold": (('"nrmse" = "<= 0.15"', '"nrmse" = "small"'),
                      'comparisons[0].thresholds."nrmse"'),
    "unknown score": (('"nrmse" = "<= 0.15"', '"nrmse_x" = "<= 0.15"'),
                      'comparisons[0].thresholds."nrmse_x"'),
    "unknown metric": (('remove_offset = true', 'metrics = ["cora"]'),
                       "comparisons[0].metrics[0]"),
    "encoder that is no encoder": (('main_encoder = "cdaq.enc1"', 'main_encoder = "cdaq.acc1"'),
                                   "alignment.main_encoder"),
    "stream without pulses": (('wls2 = { channel = "opt3", per_revolution = 2 }', ""),
                              "alignment.pulses.wls2"),
    "string for a number": (("gauge_factor = 2.1", 'gauge_factor = "2.1"'),
                            "streams.wls1.channels.tor1.gauge_factor"),
    "wrong schema": (('schema = "rigval-scene/1"', 'schema = "rigval-scene/2"'), "schema"),
    "drive direction": (("direction = 1", "direction = 2"), "model.drivers.theta_F.direction"),
    "drive encoder that is no encoder": (('encoder = "cdaq.enc2"', 'encoder = "wls1.tor1"'),
                                         "model.drivers.theta_H.encoder"),
    "missing driver": (('[model.drivers.theta_H]\nencoder = "cdaq.enc2"\n'
                        "angle_at_reference = 4.5895\ndirection = 1", ""),
                       "model.drivers.theta_H"),
}


@pytest.mark.parametrize("case", BAD, ids=list(BAD))
def test_bad_scene_names_the_key(scene_dir: Path, case: str) -> None:
    (old, new), key = BAD[case]
    text = _example()
    assert old in text, old
    assert _key_of(scene_dir, text.replace(old, new, 1)) == key


def test_channel_missing_from_file_is_reported_later_not_here(scene_dir: Path) -> None:
    text = _example().replace('source = "acc1"', 'source = "not_in_file"')
    scene = load_scene(_write(scene_dir, text))
    assert scene.streams["cdaq"].channels["acc1"].source == "not_in_file"


def test_invalid_toml_names_the_file(tmp_path: Path) -> None:
    with pytest.raises(SceneError, match="not valid TOML"):
        parse_scene("schema = ", tmp_path / "s.toml")


def test_unit_algebra() -> None:
    assert same_unit("Pa", "N m-2")
    assert same_unit("N m", "kg m2 s-2")
    assert not same_unit("rad", "1")
    assert dimension("1") == {}
    assert dimension("m s-2") == {"m": 1, "s": -2}


def test_mechanism_file_or_builtin(scene_dir: Path) -> None:
    path = scene_dir / "own.toml"
    shutil.copy(load_scene(_write(scene_dir, _example())).mechanism, scene_dir / "mine.toml")
    path.write_text(_example().replace("builtin:pendulum", "mine.toml"))
    assert load_scene(path).mechanism == (scene_dir / "mine.toml").resolve()
    path.write_text(_example().replace("builtin:pendulum", "builtin:pendulumm"))
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert info.value.where["key"] == "mechanism" and "pendulum" in str(info.value)


def test_drive_encoder_must_share_the_reference_clock(scene_dir: Path) -> None:
    text = _example().replace('[streams.wls1.channels.opt2]', '[streams.wls1.channels.enc9]\n'
                              'sensor = "encoder"\ncounts_per_rev = 8192\n\n'
                              '[streams.wls1.channels.opt2]')
    key = _key_of(scene_dir, text.replace('encoder = "cdaq.enc2"', 'encoder = "wls1.enc9"'))
    assert key == "model.drivers.theta_H.encoder"
