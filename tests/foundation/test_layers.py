"""The house's layering: which folder may import which, and no import cycle between folders.

Every ``import rigval.…`` and ``from rigval.… import …`` is counted, also inside functions (a lazy
import is still a dependency). See docs/architecture.md for the layers and what each owns.
"""

from __future__ import annotations

import ast
from graphlib import CycleError, TopologicalSorter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("acquisition", "processing", "model", "sample_data", "validation")
#: What each top-level package may import besides itself (the layer order of docs/architecture.md).
ALLOWED = {
    "acquisition": set(),
    "processing": {"acquisition"},
    "model": {"acquisition", "processing"},
    "sample_data": {"acquisition", "processing", "model"},
    "validation": {"acquisition", "processing", "model", "sample_data"},
}


def _imports(path: Path) -> set[str]:
    """The rigval modules one file imports, as dotted names without the ``rigval.`` prefix."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module] + [f"{node.module}.{alias.name}" for alias in node.names]
        else:
            continue
        found.update(name.removeprefix("rigval.") for name in names if name.startswith("rigval."))
    return found


def _folder(dotted: str) -> str:
    """The folder (package directory, relative to the root) holding a dotted module or name."""
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        if (ROOT.joinpath(*parts[:cut]) / "__init__.py").is_file():
            return "/".join(parts[:cut])
    return parts[0]


def _edges() -> dict[str, set[str]]:
    """Folder -> folders it imports from (other than itself)."""
    edges: dict[str, set[str]] = {}
    for package in PACKAGES:
        for path in (ROOT / package).rglob("*.py"):
            rel = path.relative_to(ROOT)
            if any(part.startswith(".") or part == "runs" for part in rel.parts):
                continue
            source = "/".join(rel.parts[:-1])
            targets = {_folder(name) for name in _imports(path)}
            edges.setdefault(source, set()).update(t for t in targets if t != source)
    return edges


def test_top_level_packages_import_only_lower_layers() -> None:
    wrong = sorted(
        f"{source} imports {target}"
        for source, targets in _edges().items()
        for target in targets
        if target.split("/")[0] != source.split("/")[0]
        and target.split("/")[0] not in ALLOWED[source.split("/")[0]]
    )
    assert not wrong, wrong


def test_no_import_cycle_between_folders() -> None:
    try:
        order = list(TopologicalSorter(_edges()).static_order())
    except CycleError as error:
        raise AssertionError(f"folders import each other: {' -> '.join(error.args[1])}") from None
    assert {"acquisition", "validation/metrics", "validation/report"} <= set(order)


def test_an_upward_import_would_be_seen(tmp_path: Path) -> None:
    # The checker itself: a lazy import inside a function is found; other imports are not rigval's.
    source = tmp_path / "x.py"
    source.write_text("def f():\n    from rigval.validation.scene import load_scene\n    import os\n")  # noqa: E501
    assert _imports(source) == {"validation.scene", "validation.scene.load_scene"}
    assert _folder("validation.scene.load_scene") == "validation"
    assert _folder("validation.metrics.vv20") == "validation/metrics"
