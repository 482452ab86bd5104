"""Configuration that can never be right is refused when it is loaded, naming its key (issue 26).

The fuzz engine ``config_fuzz.py`` beside this file mutates the shipped scenes and mechanisms
(deleted keys, wrong types, non-finite, zero, negative, huge and tiny numbers, odd strings and
paths, missing references) and loads each variant: only rigval errors, each naming the key it is
about, and no number that no key can take accepted. The defects the issue lists are tests of
their own below, each with the key its error must name.
"""

from __future__ import annotations

import math
import sys
import tomllib
from collections import Counter
from pathlib import Path
from typing import Any

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))  # the engine beside this file
import config_fuzz as fuzz


def _base(scene: str = "run_0p8_scene.toml", mechanism: str | None = "pendulum"
          ) -> tuple[dict[str, Any], dict[str, Any] | None]:
    scene_doc = tomllib.loads((fuzz.RUNS / scene).read_text(encoding="utf-8"))
    mechanism_doc = None if mechanism is None else tomllib.loads(
        (fuzz.MECHANISMS / f"{mechanism}.toml").read_text(encoding="utf-8"))
    return scene_doc, mechanism_doc


def _load(tmp_path: Path, scene_doc: dict[str, Any], mechanism_doc: dict[str, Any] | None,
          key: str = "", scene: str = "run_0p8_scene.toml"):
    variant = fuzz.Variant("scene" if mechanism_doc is None else "mechanism", scene, key,
                           "targeted", (), scene_doc, mechanism_doc)
    folder = tmp_path / "case"
    folder.mkdir(exist_ok=True)
    return fuzz.run_variant(variant, folder)


@pytest.mark.parametrize("scene", ["run_0p8_scene.toml", "run_1p2_scene.toml"])
@pytest.mark.parametrize("mechanism", [None, "pendulum"])
def test_shipped_configurations_load_as_written(tmp_path: Path, scene: str,
                                                mechanism: str | None) -> None:
    """The fuzz starts from configurations that load: every refusal is the edit's doing."""
    scene_doc, mechanism_doc = _base(scene, mechanism)
    result = _load(tmp_path, scene_doc, mechanism_doc, scene=scene)
    assert result.outcome == "loaded", result.message


def test_fuzz_variants_give_a_load_or_an_error_naming_the_key() -> None:
    results = fuzz.fuzz(300, seed=26)
    outcomes = Counter(r.outcome for r in results)
    violations = [f"{r.variant.source} {r.variant.key} ({r.variant.kind}): {r.message}"
                  for r in results if r.outcome == "violation"]
    assert not violations, "\n".join(violations[:10])
    assert len(results) == 300 and outcomes["refused"] > 100 and outcomes["loaded"] > 30
    kinds = Counter(r.variant.kind for r in results)
    for kind in ("delete", "wrong type", "non-finite", "zero", "negative", "huge", "tiny",
                 "odd string", "odd path", "missing reference"):
        assert kinds[kind] >= 3, kinds  # every kind of edit is tried, on both files
    assert {r.variant.source for r in results} == {"scene", "mechanism"}


def test_fuzz_finds_an_internal_error_it_is_shown() -> None:
    """The engine's own check: a load that raises a plain exception is a violation."""
    variant = next(fuzz.variants(1, seed=0))
    folder = Path(fuzz.tempfile.mkdtemp())
    original = fuzz.load_scene
    try:
        fuzz.load_scene = lambda path: (_ for _ in ()).throw(TypeError("boom"))
        result = fuzz.run_variant(variant, folder)
    finally:
        fuzz.load_scene = original
        fuzz.shutil.rmtree(folder, ignore_errors=True)
    assert result.outcome == "violation" and "internal TypeError: boom" in result.message


def _set(which: int, path: tuple[Any, ...], value: Any):
    """An edit setting ``path`` of the scene (``which`` 0) or the mechanism (1) to ``value``."""
    def edit(scene_doc: dict[str, Any], mechanism_doc: dict[str, Any]) -> None:
        parent = (scene_doc, mechanism_doc)[which]
        for part in path[:-1]:
            parent = parent[part]
        parent[path[-1]] = value
    return edit


def _scene_edit(path: tuple[Any, ...], value: Any):
    return _set(0, path, value)


def _mechanism_edit(path: tuple[Any, ...], value: Any):
    return _set(1, path, value)


def _analytic_still(scene_doc: dict[str, Any], mechanism_doc: dict[str, Any]) -> None:
    scene_doc["model"] = {"drives": "analytic"}
    mechanism_doc["drivers"][0]["omega"] = 0.0
    mechanism_doc["drivers"][0]["harmonics"] = []


CH = ("streams", "cdaq", "channels")
DEFECTS = {
    "name with a slash": (_scene_edit(("comparisons", 0, "name"), "acc/1"),
                          "comparisons[0].name"),
    "name of 300 characters": (_scene_edit(("comparisons", 0, "name"), "a" * 300),
                               "comparisons[0].name"),
    "NUL in the note path": (_scene_edit(("note",), "run_0p8\x00note.txt"), "note"),
    "NUL in a data file path": (_scene_edit(("streams", "cdaq", "file"), "a\x00.tdms"),
                                "streams.cdaq.file"),
    "file name too long": (_scene_edit(("streams", "cdaq", "file"), "x" * 300 + ".tdms"),
                           "streams.cdaq.file"),
    "omega 1e300": (_mechanism_edit(("drivers", 0, "omega"), 1e300), "drivers[0].omega"),
    "harmonic omega 1e300": (_mechanism_edit(("drivers", 0, "harmonics", 0, "omega"), 1e300),
                             "drivers[0].harmonics[0].omega"),
    "analytic main drive standing still": (_analytic_still, "drivers.theta_F.omega"),
    "gauge_factor 1e300": (_scene_edit((*CH, "str1", "gauge_factor"), 1e300),
                           "streams.cdaq.channels.str1.gauge_factor"),
    "gauge_factor 1e-300": (_scene_edit((*CH, "str1", "gauge_factor"), 1e-300),
                            "streams.cdaq.channels.str1.gauge_factor"),
    "poisson 1e300": (_scene_edit((*CH, "str1", "poisson"), 1e300),
                      "streams.cdaq.channels.str1.poisson"),
    "shear_modulus 1e300": (_scene_edit(("streams", "wls1", "channels", "tor1", "shear_modulus"),
                                        1e300), "streams.wls1.channels.tor1.shear_modulus"),
    "scale 1e300": (_scene_edit(("comparisons", 0, "scale"), 1e300), "comparisons[0].scale"),
    "scale 1e-300": (_scene_edit(("comparisons", 0, "scale"), 1e-300), "comparisons[0].scale"),
    "mass 1e300": (_mechanism_edit(("bodies", 0, "mass"), 1e300), "bodies[0].mass"),
    "gravity 1e300": (_mechanism_edit(("gravity",), [0.0, -1e300]), "gravity[1]"),
    "point at 1e300": (_mechanism_edit(("bodies", 0, "points", "O"), [1e300, 0.0]),
                       "bodies[0].points.O[0]"),
    "reader option no reader has": (_scene_edit(("streams", "cdaq", "reader"), {"grop": "x"}),
                                    "streams.cdaq.reader.grop"),
    "TDMS file as a CSV stream's file": (
        _scene_edit(("streams", "wls2", "file"), "run_0p8_wls1.tdms"), "streams.wls2.file"),
    "channel absent from its TDMS file": (_scene_edit((*CH, "enc2", "source"), "enc9"),
                                          "streams.cdaq.channels.enc2.source"),
    "reader group absent from the TDMS file": (
        _scene_edit(("streams", "cdaq", "reader", "group"), "cDAQ9 task"),
        "streams.cdaq.reader.group"),
    "min_cycles 2**62": (_scene_edit(("angle", "min_cycles"), 2**62), "angle.min_cycles"),
    "angle_at_reference inf": (_scene_edit(("model", "drivers", "theta_F", "angle_at_reference"),
                                           math.inf),
                               "model.drivers.theta_F.angle_at_reference"),
}


@pytest.mark.parametrize("defect", list(DEFECTS))
def test_defect_is_refused_at_load_naming_its_key(tmp_path: Path, defect: str) -> None:
    edit, key = DEFECTS[defect]
    scene_doc, mechanism_doc = _base()
    assert mechanism_doc is not None
    edit(scene_doc, mechanism_doc)
    result = _load(tmp_path, scene_doc, mechanism_doc, key)
    assert result.outcome == "refused", result.message
    assert result.error_key == key, result.message
    assert "has this option" not in result.message
