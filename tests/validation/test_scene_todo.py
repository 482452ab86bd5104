"""A scene with values still marked TODO is refused, naming every such key (exit code 2)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from rigval.acquisition.errors import ConfigError
from rigval.sample_data import runs_dir
from rigval.validation.cli import EXIT_USAGE, main
from rigval.validation.errors import SceneError
from rigval.validation.scene import load_scene, todo_keys, todo_label


def _shipped(tmp_path: Path) -> str:
    text = (runs_dir() / "run_0p8_scene.toml").read_text()
    return re.sub(r'(file|note) = "(run_[^"]+)"',
                  lambda m: f'{m.group(1)} = "{(runs_dir() / m.group(2)).as_posix()}"', text)


def test_todo_keys_in_document_order() -> None:
    doc = {"a": "TODO", "b": {"c": 1, "d": "TODO: gauge factor"},
           "e": [{"f": "x"}, {"g": "TODO"}], "h": "not a TODO"}
    assert todo_keys(doc) == ["a", "b.d", "e[1].g"]


def test_todo_label_names_the_comparison() -> None:
    doc = {"comparisons": [{"name": "acc1"}, {"name": "tor1", "scale": "TODO"}, {"x": 1}]}
    assert todo_label(doc, "comparisons[1].scale") == "comparisons[1] (tor1).scale"
    assert todo_label(doc, "comparisons[1].model.item") == "comparisons[1] (tor1).model.item"
    assert todo_label(doc, "comparisons[2].scale") == "comparisons[2].scale"  # no name yet
    assert todo_label(doc, "streams.a.channels.b.gain") == "streams.a.channels.b.gain"


def test_validate_refuses_todo_naming_each_key(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    text = _shipped(tmp_path)
    text = text.replace("gauge_factor = 2.02", 'gauge_factor = "TODO"  # from the gauge pack')
    text, count = re.subn(r"angle_at_reference = 4\.5728\d*", 'angle_at_reference = "TODO"', text)
    assert count == 1  # the shipped runs' last digits change when they are rewritten
    text, count = re.subn(r'(wls2 = \{[^}\n]*angle = )[-0-9.e]+', r'\1"TODO"', text)
    assert count == 1
    path = tmp_path / "scene.toml"
    path.write_text(text)
    keys = ["streams.cdaq.channels.str1.gauge_factor", "alignment.pulses.wls2.angle",
            "model.drivers.theta_H.angle_at_reference"]
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert isinstance(info.value, ConfigError)
    assert info.value.extra["keys"] == keys
    assert info.value.where["key"] == keys[0]
    code = main(["validate", str(path), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == EXIT_USAGE
    for key in keys:
        assert key in err
    assert not (tmp_path / "out").exists()
