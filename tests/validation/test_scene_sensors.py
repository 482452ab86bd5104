"""The linear, IEPE and load-cell sensor kinds in a scene: conversion and errors naming the key."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from rigval.acquisition.channel_map import load_stream
from rigval.acquisition.errors import ConfigError
from rigval.sample_data import runs_dir
from rigval.validation.errors import SceneError
from rigval.validation.scene import load_scene
from rigval.validation.stage_settings import convert_stream

G0 = 9.80665  # m s-2


def _scene(tmp_path: Path, acc3: str) -> Path:
    """The shipped 0.8 rev/s scene with absolute file paths and acc3's table replaced."""
    text = (runs_dir() / "run_0p8_scene.toml").read_text()
    text = re.sub(r'(file|note) = "(run_[^"]+)"',
                  lambda m: f'{m.group(1)} = "{(runs_dir() / m.group(2)).as_posix()}"', text)
    text = re.sub(r"\[streams\.cdaq\.channels\.acc3\]\n(.*?)\n\n",
                  f"[streams.cdaq.channels.acc3]\nsource = \"acc3\"\n{acc3}\n\n", text,
                  flags=re.S)
    path = tmp_path / "scene.toml"
    path.write_text(text)
    return path


def _converted_acc3(scene_path: Path) -> tuple[np.ndarray, np.ndarray, str]:
    scene = load_scene(scene_path, check_mechanism=False)
    raw = load_stream(scene.streams["cdaq"])
    out = convert_stream(raw, scene.streams["cdaq"])
    assert raw["acc3"].attrs["units"] == "V"
    return raw["acc3"].to_numpy(), out["acc3"].to_numpy(), str(out["acc3"].attrs["units"])


@pytest.mark.parametrize(("table", "expected", "units"), [
    ('sensor = "linear"\nslope = 250.0\noffset = -3.0\nunits = "N"',
     lambda v: 250.0 * v - 3.0, "N"),
    ('sensor = "linear"\nslope = 0.25\nunits = "N"\ninput_units = "mV"',
     lambda v: 0.25 * v * 1e3, "N"),
    ('sensor = "iepe_accelerometer"\nsensitivity = 10.2', lambda v: v / 10.2e-3 * G0, "m s-2"),
    ('sensor = "load_cell"\nsensitivity = 2.0\ncapacity = 5000.0\nexcitation = 10.0',
     lambda v: v / 10.0 / 2.0e-3 * 5000.0, "N"),
], ids=["linear", "linear per mV", "iepe", "load cell"])
def test_scene_sensor_converts_by_its_closed_form(tmp_path: Path, table: str, expected,
                                                  units: str) -> None:
    raw, converted, out_units = _converted_acc3(_scene(tmp_path, table))
    np.testing.assert_allclose(converted, expected(raw.astype(np.float64)), rtol=1e-12,
                               atol=1e-12)
    assert out_units == units


@pytest.mark.parametrize(("table", "key"), [
    ('sensor = "linear"\nslope = 0.0\nunits = "N"', "streams.cdaq.channels.acc3.slope"),
    ('sensor = "linear"\nslope = 1.0', "streams.cdaq.channels.acc3.units"),
    ('sensor = "linear"\nslope = 1.0\nunits = "lbf"', "streams.cdaq.channels.acc3.units"),
    ('sensor = "iepe_accelerometer"\nsensitivity = -5.0',
     "streams.cdaq.channels.acc3.sensitivity"),
    ('sensor = "iepe_accelerometer"', "streams.cdaq.channels.acc3.sensitivity"),
    ('sensor = "load_cell"\nsensitivity = 2.0', "streams.cdaq.channels.acc3.capacity"),
    ('sensor = "load_cell"\nsensitivity = 2.0\ncapacity = 1.0\ngauge_factor = 2.0',
     "streams.cdaq.channels.acc3.gauge_factor"),
], ids=["zero slope", "no units", "unknown unit", "negative sensitivity", "no sensitivity",
        "no capacity", "unknown key"])
def test_bad_sensor_table_names_the_key(tmp_path: Path, table: str, key: str) -> None:
    with pytest.raises(SceneError) as info:
        load_scene(_scene(tmp_path, table), check_mechanism=False)
    assert isinstance(info.value, ConfigError)
    assert info.value.where["key"] == key
    assert key in str(info.value)


@pytest.mark.parametrize(("table", "key"), [
    ('sensor = "linear"\nslope = 1.0\nunits = "N"\ninput_units = "V/V"',
     "streams.cdaq.channels.acc3.input_units"),
    ('sensor = "load_cell"\nsensitivity = 2.0\ncapacity = 1.0',
     "streams.cdaq.channels.acc3.excitation"),
], ids=["linear input unit", "load cell in volts without excitation"])
def test_unit_problems_found_when_converting_name_the_key(tmp_path: Path, table: str,
                                                          key: str) -> None:
    with pytest.raises(SceneError) as info:
        _converted_acc3(_scene(tmp_path, table))
    assert info.value.where["key"] == key
    assert key in str(info.value)
