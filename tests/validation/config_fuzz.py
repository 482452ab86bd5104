"""Fuzz the configuration: mutated copies of the shipped scenes and mechanisms, loaded and checked.

Each variant is one edit of a parsed scene (``sample_data/runs/*_scene.toml``) or of the
mechanism it uses (``model/mechanisms/*.toml``, written beside the scene and named by it): a
deleted key or list item, a value of the wrong type, a non-finite, zero, negative, huge or tiny
number, an odd string or path, or a reference to a name that does not exist. The variant is
written as TOML (non-finite numbers as TOML's ``nan`` and ``inf``) beside links to the run's data
files and loaded with :func:`rigval.validation.scene.load_scene`, which also loads and checks the
mechanism: no data file is read beyond its first bytes, nothing heavy runs.

Invariants checked for every variant (a failure is a *violation*):

1. only rigval errors (:class:`~rigval.acquisition.errors.RigvalError`) are raised, and no
   warning (a numpy overflow, say) is issued;
2. every error names a key path (``where["key"]``) of the file it is about;
3. that key is the edited one, one of its parents or children, or a key that refers to the
   edited one or is referred to by it: what the error is about, not a bystander;
4. a number that no key can take (not finite, or 1e30 and more in magnitude) is refused.

Usage: ``python tests/validation/config_fuzz.py [--variants N] [--seed S] [--runs R]``; prints
the outcomes and the violations; ``--runs R`` also runs the first R variants that load with
:func:`rigval.validation.pipeline.run_scene` (a result, or a rigval error naming a key).
``tests/validation/test_config_fuzz.py`` runs a few hundred variants.
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import random
import shutil
import sys
import tempfile
import tomllib
import warnings
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rigval.acquisition.errors import RigvalError
from rigval.validation.scene import load_scene

ROOT = Path(__file__).resolve().parents[2]
RUNS = ROOT / "sample_data" / "runs"
MECHANISMS = ROOT / "model" / "mechanisms"

#: Replacement values by kind of edit.
NUMBERS = {"non-finite": [math.nan, math.inf, -math.inf], "zero": [0, 0.0],
           "huge": [1e300, 1e30, 2**62], "tiny": [1e-300, 5e-324, -1e-300]}
WRONG_TYPES = ["x", [1.0], {"a": 1}, True, 7, 0.5]
ODD_STRINGS = ["", " ", "a/b", "x" * 300, "nul\x00byte", "\u00e9\u2713", "../../etc/passwd",
               "nan", "P99", "nosuch.channel", "cdaq.nosuch", "\n", "TODOnot"]
ODD_PATHS = ["missing.tdms", "/dev/null", "/proc/self/status", ".", "nul\x00.tdms",
             "run_0p8_scene.toml", "run_0p8_truth.npz", "/", "x" * 300 + ".csv"]
#: Edits no key can accept: a number of 1e30 or more in magnitude, or not finite.
MUST_REFUSE = ("non-finite", "huge")
#: Keys whose string values are paths.
PATH_KEYS = ("file", "note", "mechanism")


@dataclass(frozen=True)
class Variant:
    """One edit: which file, the key path edited, the kind of edit and the edited document."""

    source: str  # "scene" or "mechanism"
    scene: str  # the scene file it starts from
    key: str
    kind: str
    names: tuple[str, ...]  # the strings of the edited value, before and after the edit
    scene_doc: dict[str, Any]
    mechanism_doc: dict[str, Any] | None


@dataclass(frozen=True)
class Result:
    """What loading one variant gave."""

    variant: Variant
    outcome: str  # "loaded", "refused" or "violation"
    error_key: str | None
    message: str


def toml_text(doc: dict[str, Any]) -> str:
    """Write a document as TOML: every key quoted, tables inline, ``nan``/``inf`` as TOML has.

    Written here, not with :func:`rigval.acquisition.tables.toml_value`, because that refuses
    non-finite numbers (rigval never writes them) and the fuzz needs them.
    """
    def value(item: Any) -> str:
        if isinstance(item, str):
            return json.dumps(item)
        if isinstance(item, bool):
            return "true" if item else "false"
        if isinstance(item, int):
            return str(item)
        if isinstance(item, float):
            if math.isnan(item):
                return "nan"
            return repr(item) if math.isfinite(item) else ("inf" if item > 0 else "-inf")
        if isinstance(item, dict):
            return "{ " + ", ".join(f"{json.dumps(str(k))} = {value(v)}"
                                    for k, v in item.items()) + " }"
        return "[" + ", ".join(value(v) for v in item) + "]"

    return "".join(f"{json.dumps(str(k))} = {value(v)}\n" for k, v in doc.items())


def _leaves(doc: Any, path: tuple[Any, ...] = ()) -> Iterator[tuple[tuple[Any, ...], Any]]:
    """Every (path, value) of a document, tables and arrays included (not the root)."""
    if path:
        yield path, doc
    if isinstance(doc, dict):
        for k, v in doc.items():
            yield from _leaves(v, (*path, k))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            yield from _leaves(v, (*path, i))


def key_text(path: tuple[Any, ...]) -> str:
    """The key path as rigval names it: ``comparisons[0].model.item``."""
    text = ""
    for part in path:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text


def _edit(doc: dict[str, Any], path: tuple[Any, ...], new: Any) -> dict[str, Any]:
    """Return a deep copy of ``doc`` with ``path`` set to ``new`` (deleted when ``new`` is _DEL)."""
    edited = copy.deepcopy(doc)
    parent = edited
    for part in path[:-1]:
        parent = parent[part]
    if new is _DELETE:
        del parent[path[-1]]
    else:
        parent[path[-1]] = new
    return edited


_DELETE = object()


def _same_type(a: Any, b: Any) -> bool:
    """Whether two TOML values have one type (an int and a float are both numbers)."""
    def kind(v: Any) -> str:
        return "bool" if isinstance(v, bool) else (
            "number" if isinstance(v, int | float) else type(v).__name__)
    return kind(a) == kind(b)


def _replacements(path: tuple[Any, ...], value: Any, rng: random.Random) -> list[tuple[str, Any]]:
    """The edits that fit a value: (kind, new value)."""
    other_types = [w for w in WRONG_TYPES if not _same_type(w, value)]
    edits: list[tuple[str, Any]] = [("delete", _DELETE), ("wrong type", rng.choice(other_types))]
    if isinstance(value, int | float) and not isinstance(value, bool):
        edits += [(kind, rng.choice(options)) for kind, options in NUMBERS.items()]
        edits.append(("negative", -abs(value) if value else -1.0))
        edits.append(("scaled", value * rng.choice([1e3, 1e6, 1e-3, -1.0])))
    elif isinstance(value, str):
        is_path = isinstance(path[-1], str) and path[-1] in PATH_KEYS
        edits.append(("odd path" if is_path else "odd string",
                      rng.choice(ODD_PATHS if is_path else ODD_STRINGS)))
        edits.append(("missing reference", value + "_missing"))
    elif isinstance(value, list) and value:
        edits.append(("empty list", []))
    elif isinstance(value, dict) and value:
        edits.append(("empty table", {}))
    return edits


def variants(count: int, seed: int) -> Iterator[Variant]:
    """Yield ``count`` seeded variants, alternating scenes, half of them editing the mechanism."""
    rng = random.Random(seed)
    scenes = sorted(RUNS.glob("*_scene.toml"))
    mechanisms = sorted(MECHANISMS.glob("*.toml"))
    for k in range(count):
        scene = scenes[k % len(scenes)]
        scene_doc = tomllib.loads(scene.read_text(encoding="utf-8"))
        if k % 2:
            mechanism = mechanisms[(k // 2) % len(mechanisms)]
            mechanism_doc = tomllib.loads(mechanism.read_text(encoding="utf-8"))
            if mechanism.stem != "pendulum":  # the scene's names exist in the pendulum only
                scene_doc["model"]["drivers"] = {
                    d["name"]: {"encoder": f"cdaq.enc{i + 1}", "angle_at_reference": 0.0}
                    for i, d in enumerate(mechanism_doc["drivers"])}
                scene_doc.pop("predictions", None)
                scene_doc["comparisons"] = [c for c in scene_doc["comparisons"]
                                            if c["model"]["quantity"] == "driver_torque"][:1]
                scene_doc["comparisons"][0]["model"]["item"] = mechanism_doc["drivers"][0]["name"]
            path, value = rng.choice(list(_leaves(mechanism_doc)))
            kind, new = rng.choice(_replacements(path, value, rng))
            yield Variant("mechanism", scene.name, key_text(path), kind, _strings(value, new),
                          scene_doc, _edit(mechanism_doc, path, new))
        else:
            leaves = list(_leaves(scene_doc))
            if k % 8 == 0:  # paths are a few leaves among hundreds: edit one every 8th variant
                leaves = [(p, v) for p, v in leaves if isinstance(v, str) and p[-1] in PATH_KEYS]
            path, value = rng.choice(leaves)
            kind, new = rng.choice(_replacements(path, value, rng))
            yield Variant("scene", scene.name, key_text(path), kind, _strings(value, new),
                          _edit(scene_doc, path, new), None)


def _strings(*values: Any) -> tuple[str, ...]:
    """The strings (names, references) inside values, for :func:`_related`."""
    found = [v for value in values for _, v in _leaves(value, ("",)) if isinstance(v, str)]
    return tuple(dict.fromkeys(s for s in found if s.strip()))


def _related(named: str, variant: Variant, message: str) -> bool:
    """Whether an error's key is about the edited key (see the module docstring, invariant 3)."""
    def norm(key: str) -> str:
        return key.replace('"', "")

    named, edited = norm(named), norm(variant.key)
    if named.startswith(edited) or edited.startswith(named):
        return True
    structure = ("bodies", "joints", "drivers")
    if "constraints" in message and named.startswith(structure) and edited.startswith(structure):
        return True  # a body, joint or driver less or more: the count of equations is wrong
    # a key referring to the edited table or item, or the edited value naming another key:
    # the reference's text (the edited key's names, or a name in the edited value) appears
    return any(part in message for part in _names(edited)) or any(
        repr(name) in message or (len(name) > 1 and name in message) for name in variant.names)


def _names(key: str) -> list[str]:
    """The plain names in a key path (``streams.cdaq.channels.acc1`` -> cdaq, acc1, ...)."""
    return [p for p in key.replace("[", ".").replace("]", "").split(".")[1:] if p]


def run_variant(variant: Variant, folder: Path, run: bool = False) -> Result:
    """Write one variant beside links to its run's data files and load it (``run``: and run it).

    A loaded variant that is run must give a result or a rigval error naming a key.
    """
    for item in folder.iterdir():
        item.unlink()
    stem = variant.scene.removesuffix("_scene.toml")
    for data in RUNS.glob(f"{stem}_*"):
        (folder / data.name).symlink_to(data)
    scene_doc = dict(variant.scene_doc)
    if variant.mechanism_doc is not None:
        (folder / "mechanism.toml").write_text(toml_text(variant.mechanism_doc), encoding="utf-8")
        scene_doc["mechanism"] = "mechanism.toml"
    path = folder / "scene.toml"
    path.unlink(missing_ok=True)  # the link to the shipped scene: written anew
    path.write_text(toml_text(scene_doc), encoding="utf-8")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            load_scene(path)
    except RigvalError as error:
        key = error.where.get("key")
        text = str(error)
        if not key:
            return Result(variant, "violation", None, f"no key named: {text}")
        if not _related(str(key), variant, text):
            return Result(variant, "violation", str(key), f"names another key: {text}")
        return Result(variant, "refused", str(key), text)
    except Exception as error:  # anything else is the defect this fuzz looks for
        return Result(variant, "violation", None, f"internal {type(error).__name__}: {error}")
    if variant.kind in MUST_REFUSE:
        return Result(variant, "violation", None, f"a {variant.kind} value was accepted")
    if run:
        from rigval.validation.pipeline import run_scene

        try:
            run_scene(path)
        except RigvalError as error:
            key = error.where.get("key")
            return Result(variant, "failed run" if key else "violation", key,
                          f"run: {error}" if key else f"run error naming no key: {error}")
        except Exception as error:
            return Result(variant, "violation", None, f"run: internal {type(error).__name__}: "
                          f"{error}")
        return Result(variant, "ran", None, "")
    return Result(variant, "loaded", None, "")


def fuzz(count: int, seed: int, runs: int = 0) -> list[Result]:
    """Load ``count`` variants in a temporary folder, running the first ``runs`` that load."""
    folder = Path(tempfile.mkdtemp(prefix="rigval_config_fuzz_"))
    results: list[Result] = []
    try:
        for variant in variants(count, seed):
            result = run_variant(variant, folder)
            if result.outcome == "loaded" and runs > 0:
                runs -= 1
                result = run_variant(variant, folder, run=True)
            results.append(result)
        return results
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def main(argv: list[str] | None = None) -> int:
    """Command line: run a campaign and print its counts and violations."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--variants", type=int, default=300)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--runs", type=int, default=0,
                        help="run the first N variants that load (about 20 s each)")
    args = parser.parse_args(argv)
    results = fuzz(args.variants, args.seed, args.runs)
    print(Counter(r.outcome for r in results))
    print(Counter((r.variant.source, r.variant.kind, r.outcome) for r in results))
    for r in results:
        if r.outcome in ("violation", "ran", "failed run"):
            print(f"{r.outcome}: {r.variant.source} {r.variant.key} ({r.variant.kind}): "
                  f"{r.message[:300]}")
    return 1 if any(r.outcome == "violation" for r in results) else 0


if __name__ == "__main__":
    sys.exit(main())
