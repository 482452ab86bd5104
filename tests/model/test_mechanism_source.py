"""``builtin:NAME`` or a path, parsed in one place (model/mechanism.py) for scene, CLI, predict."""

from __future__ import annotations

from pathlib import Path

import pytest

from rigval.model.errors import MechanismError
from rigval.model.mechanism import builtin_mechanism, load_mechanism, mechanism_file
from rigval.model.predict import resolve_mechanism


def test_builtin_prefix_and_paths(tmp_path: Path) -> None:
    assert mechanism_file("builtin:fourbar") == builtin_mechanism("fourbar")
    assert mechanism_file("mine.toml", tmp_path) == tmp_path / "mine.toml"
    assert mechanism_file(tmp_path / "abs.toml", Path("elsewhere")) == tmp_path / "abs.toml"
    with pytest.raises(MechanismError, match="no built-in mechanism named 'fourbars'"):
        mechanism_file("builtin:fourbars")
    # predict resolves through the same function: same bodies as loading the file directly
    direct = load_mechanism(builtin_mechanism("pendulum"))
    assert resolve_mechanism("builtin:pendulum").body_names == direct.body_names
