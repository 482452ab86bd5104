"""Scene keys of sums and differences of channels and of joint_axial_force; errors name the key."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from rigval.sample_data import runs_dir
from rigval.validation.errors import SceneError
from rigval.validation.scene import load_scene


def _scene(tmp_path: Path, comparison: str) -> Path:
    text = (runs_dir() / "run_0p8_scene.toml").read_text()
    text = re.sub(r'(file|note) = "(run_[^"]+)"',
                  lambda m: f'{m.group(1)} = "{(runs_dir() / m.group(2)).as_posix()}"', text)
    text = text.split("[predictions]")[0] + "[[comparisons]]\nname = \"extra\"\n" + comparison
    path = tmp_path / "scene.toml"
    path.write_text(text)
    return path


def _extra(tmp_path: Path, comparison: str):
    return load_scene(_scene(tmp_path, comparison)).comparisons[-1]


TORQUE = 'model = { quantity = "driver_torque", item = "theta_F" }\n'


@pytest.mark.parametrize(("measured", "terms"), [
    ('"wls1.tor1 + wls1.tor2"', [(1.0, "wls1.tor1"), (1.0, "wls1.tor2")]),
    ('"wls1.tor1 - wls1.tor2"', [(1.0, "wls1.tor1"), (-1.0, "wls1.tor2")]),
    ('["wls1.tor1", "-wls1.tor2"]', [(1.0, "wls1.tor1"), (-1.0, "wls1.tor2")]),
    ('["wls1.tor1", "wls1.tor2"]', [(1.0, "wls1.tor1"), (1.0, "wls1.tor2")]),
    ('"wls1.tor1"', [(1.0, "wls1.tor1")]),
])
def test_sum_and_difference_parse(tmp_path: Path, measured: str, terms: list) -> None:
    spec = _extra(tmp_path, f"measured = {measured}\n{TORQUE}")
    assert [(s, str(r)) for s, r in spec.terms] == terms
    sign = {1.0: "+", -1.0: "-"}
    assert spec.measured_text == " ".join([terms[0][1]] + [f"{sign[s]} {r}"
                                                          for s, r in terms[1:]])


@pytest.mark.parametrize(("comparison", "key", "message"), [
    (f'measured = "wls1.tor1 + wls2.tor3"\n{TORQUE}', "comparisons[7].measured",
     "one stream"),
    (f'measured = ["wls1.tor1", "cdaq.acc1"]\n{TORQUE}', "comparisons[7].measured[1]",
     "one stream"),
    (f'measured = "wls1.tor1 + wls1.tor1"\n{TORQUE}', "comparisons[7].measured", "twice"),
    (f'measured = ["-wls1.tor1", "wls1.tor2"]\n{TORQUE}', "comparisons[7].measured[0]",
     "first channel"),
    (f'measured = "wls1.tor1 + wls1.torX"\n{TORQUE}', "comparisons[7].measured", "torX"),
    ('measured = "cdaq.str1"\nmodel = { quantity = "joint_axial_force", item = "P5", '
     'body = "A" }\nscale = 526.0\nscale_units = "m-2"\n', "comparisons[7].model.body",
     "does not connect"),
    ('measured = "cdaq.str1"\nmodel = { quantity = "joint_axial_force", item = "P2", '
     'body = "A" }\nscale = 526.0\nscale_units = "m-2"\n', "comparisons[7].model.toward",
     "3 points"),
    ('measured = "cdaq.str1"\nmodel = { quantity = "joint_axial_force", item = "P5", '
     'body = "B", axis = "x" }\nscale = 526.0\nscale_units = "m-2"\n',
     "comparisons[7].model.axis", "remove"),
    ('measured = "cdaq.str1"\nmodel = { quantity = "joint_force", item = "P5", '
     'axis = "x", body = "B" }\nscale = 526.0\nscale_units = "m-2"\n',
     "comparisons[7].model.body", "joint_axial_force only"),
    ('measured = "cdaq.str1"\nmodel = { quantity = "joint_axial_force", item = "P5", '
     'body = "B" }\n', "comparisons[7].model", "unit mismatch"),
])
def test_bad_expression_or_axial_force_names_the_key(tmp_path: Path, comparison: str, key: str,
                                                      message: str) -> None:
    path = _scene(tmp_path, comparison)
    index = path.read_text().count("[[comparisons]]") - 1  # the added comparison
    with pytest.raises(SceneError, match=message) as info:
        load_scene(path)
    assert info.value.where["key"] == key.replace("[7]", f"[{index}]")


def test_axial_force_with_toward_point(tmp_path: Path) -> None:
    spec = _extra(tmp_path, 'measured = "cdaq.str1"\nmodel = { quantity = "joint_axial_force", '
                            'item = "P2", body = "A", toward = "P1" }\nscale = 526.0\n'
                            'scale_units = "m-2"\n')
    assert (spec.model.item, spec.model.body, spec.model.toward) == ("P2", "A", "P1")
    assert spec.model.units == "N"
