"""Mechanism files: shipped copies, parsing into frozen dataclasses, every error's key path."""

from __future__ import annotations

import dataclasses
import pickle
from pathlib import Path
from typing import Any

import pytest

import rigval.model as rm
from rigval.model.errors import MechanismError


@pytest.mark.parametrize("name", rm.BUILTIN_MECHANISMS)
def test_builtin_copies_match_shared_files(name: str, mechanisms_dir: Path) -> None:
    assert rm.builtin_mechanism(name).read_bytes() == (mechanisms_dir / f"{name}.toml").read_bytes()


def test_pendulum_structure(pendulum: rm.Mechanism) -> None:
    assert pendulum.body_names == ("A", "B", "C", "D", "E", "F", "G", "H")
    assert len(pendulum.joints) == 11 and pendulum.driver_names == ("theta_F", "theta_H")
    assert pendulum.joints[0] == rm.Joint("P2", "revolute", ("A", "B"))
    assert pendulum.joints[7].at == (-1.75, -0.802558409089)
    assert set(pendulum.point_names) == {f"P{i}" for i in range(1, 13)}
    assert pendulum.bodies[0].points["P1"] == (0.0, -1.4)
    assert pendulum.redundant_constraints == 0


def test_mechanism_is_frozen_and_dict_input_equals_file(pendulum: rm.Mechanism,
                                                        pendulum_dict: dict[str, Any]) -> None:
    with pytest.raises(dataclasses.FrozenInstanceError):
        pendulum.name = "x"  # type: ignore[misc]
    from_dict = rm.load_mechanism(pendulum_dict)
    assert from_dict.bodies == pendulum.bodies and from_dict.drivers == pendulum.drivers
    assert from_dict.source == "<dict>"


def _edit(data: dict[str, Any], path: str, value: Any) -> None:
    *parents, last = path.split("/")
    node: Any = data
    for part in parents:
        node = node[int(part)] if part.isdigit() else node[part]
    if value is _DELETE:
        del node[int(last) if last.isdigit() else last]
    elif last.isdigit():
        node[int(last)] = value
    else:
        node[last] = value


_DELETE = object()

CASES = [
    ("joints/2/bodies/1", "Q", "joints[2].bodies[1]", "unknown body 'Q'; bodies are crank, "
                                                      "coupler, rocker"),
    ("joints/1/point", "Z", "joints[1].point", "has no point 'Z'"),
    ("bodies/1/name", "crank", "bodies[1].name", "duplicate body name"),
    ("joints/2/point", "A", "joints[2].point", "duplicate joint"),
    ("drivers", [], "drivers", "too few constraints"),
    ("schema", "rigval-mechanism/0", "schema", "unsupported schema"),
    ("bodies/0/mas", 1.0, "bodies[0].mas", "unknown key 'mas'"),
    ("bodies/0/mass", -1.0, "bodies[0].mass", "expected a value >= 0"),
    ("bodies/0/mass", "heavy", "bodies[0].mass", "expected a number"),
    ("bodies/0/guess", [0.0, 1.0], "bodies[0].guess", "list of 3 numbers"),
    ("drivers/0/law", "table", "drivers[0].law", "unknown drive law"),
    ("drivers/0/body", "nobody", "drivers[0].body", "unknown body 'nobody'"),
    ("joints/0/type", "prismatic", "joints[0].type", "unknown joint type"),
    ("joints", [{"point": "A", "type": "revolute", "bodies": ["crank", "coupler"]},
                {"point": "B", "type": "revolute", "bodies": ["coupler", "rocker"]}],
     "joints", "not connected to the ground"),
    ("bodies/0/inertia", _DELETE, "bodies[0].inertia", "missing key 'inertia'"),
]


@pytest.mark.parametrize(("path", "value", "key", "text"), CASES)
def test_errors_name_the_key_path(fourbar_dict: dict[str, Any], path: str, value: Any, key: str,
                                  text: str) -> None:
    _edit(fourbar_dict, path, value)
    with pytest.raises(MechanismError) as info:
        rm.load_mechanism(fourbar_dict)
    assert info.value.where["key"] == key
    assert text in str(info.value)
    assert info.value.hint
    assert isinstance(info.value, ValueError)
    again = pickle.loads(pickle.dumps(info.value))
    assert str(again) == str(info.value)


def test_second_driver_on_a_body_is_rejected(fourbar_dict: dict[str, Any]) -> None:
    extra = dict(fourbar_dict["drivers"][0], name="again")
    fourbar_dict["drivers"].append(extra)
    with pytest.raises(MechanismError, match="already has a driver"):
        rm.load_mechanism(fourbar_dict)


def test_inconsistent_surplus_driver_is_too_many(fourbar_dict: dict[str, Any]) -> None:
    fourbar_dict["drivers"].append({"name": "rocker_too", "body": "rocker", "law": "harmonic",
                                    "theta0": 0.3, "omega": 1.0})
    with pytest.raises(MechanismError, match="too many constraints") as info:
        rm.load_mechanism(fourbar_dict)
    assert info.value.where["key"] == "drivers"


def test_file_errors(tmp_path: Path) -> None:
    with pytest.raises(MechanismError, match="not found"):
        rm.load_mechanism(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("schema = [\n")
    with pytest.raises(MechanismError, match="not valid TOML") as info:
        rm.load_mechanism(bad)
    assert info.value.where["file"] == str(bad)
    with pytest.raises(MechanismError, match="no built-in mechanism"):
        rm.builtin_mechanism("crane")


def test_shared_point_name_must_be_a_joint(fourbar_dict: dict[str, Any]) -> None:
    fourbar_dict["bodies"][2]["points"]["A"] = [0.0, 0.1]
    with pytest.raises(MechanismError, match="point 'A' is named on bodies"):
        rm.load_mechanism(fourbar_dict)


def test_mechanism_pickles_and_hashes(pendulum: rm.Mechanism) -> None:
    again = pickle.loads(pickle.dumps(pendulum))
    assert again == pendulum and hash(again) == hash(pendulum)
    with pytest.raises(TypeError):
        pendulum.bodies[0].points["P1"] = (0.0, 0.0)  # type: ignore[index]
