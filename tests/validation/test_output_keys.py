"""The scene's ``[output]`` table: defaults, values and errors naming the key path."""

from __future__ import annotations

import pytest

from rigval.acquisition.errors import ConfigError
from rigval.sample_data import shipped_runs
from rigval.validation.scene import parse_scene
from rigval.validation.scene_types import OutputSpec, Scene


def _scene_with(extra: str) -> Scene:
    path = shipped_runs()[0]
    return parse_scene(path.read_text(encoding="utf-8") + extra, path)


def test_defaults_keep_neither_raw_nor_aligned() -> None:
    assert _scene_with("").output == OutputSpec(raw=False, aligned=False)


@pytest.mark.parametrize(("raw", "aligned"), [(True, False), (False, True), (True, True)])
def test_values_are_read(raw: bool, aligned: bool) -> None:
    text = f"\n[output]\nraw = {str(raw).lower()}\naligned = {str(aligned).lower()}\n"
    assert _scene_with(text).output == OutputSpec(raw=raw, aligned=aligned)


@pytest.mark.parametrize(("extra", "key"), [
    ('\n[output]\nraw = "yes"\n', "output.raw"),
    ("\n[output]\naligned = 1\n", "output.aligned"),
    ("\n[output]\nangle = false\n", "output.angle"),
])
def test_bad_values_name_the_key(extra: str, key: str) -> None:
    with pytest.raises(ConfigError) as info:
        _scene_with(extra)
    assert type(info.value).__name__ == "SceneError" and info.value.where["key"] == key
