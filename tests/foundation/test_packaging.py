"""The wheel contains every subpackage, and the folders import only under the rigval namespace."""

from __future__ import annotations

import os
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def _declared() -> tuple[list[str], dict[str, str]]:
    config = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]
    return config["packages"], config["package-dir"]


def _on_disk(package_dir: dict[str, str]) -> set[str]:
    found = set()
    for name, folder in package_dir.items():
        for init in (REPO / folder).rglob("__init__.py"):
            rel = init.parent.relative_to(REPO / folder)
            found.add(".".join([name, *rel.parts]))
    return found


def test_packages_list_matches_folders_on_disk() -> None:
    packages, package_dir = _declared()
    assert set(packages) == _on_disk(package_dir)


def test_every_package_folder_has_py_typed() -> None:
    _, package_dir = _declared()
    for folder in package_dir.values():
        assert (REPO / folder / "py.typed").is_file(), folder


def test_bare_folder_names_do_not_import_from_outside(tmp_path: Path) -> None:
    code = "import importlib.util as u; print(u.find_spec('model') is None)"
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                         text=True, check=True)
    assert out.stdout.strip() == "True"
    code = "import rigval.model, rigval.validation.cli; print('ok')"
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                         text=True, check=True)
    assert out.stdout.strip() == "ok"


def test_report_style_sheet_is_package_data() -> None:
    from fnmatch import fnmatch

    from rigval.validation.report.page import STYLE_SHEET, Page

    config = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]
    patterns = config["package-data"]["rigval.validation.report"]
    assert any(fnmatch(STYLE_SHEET, pattern) for pattern in patterns)
    css = (REPO / "validation" / "report" / STYLE_SHEET).read_text(encoding="utf-8")
    assert f"<style>{css}</style>" in Page("t").render()


@pytest.mark.slow
def test_built_wheel_contains_every_package(tmp_path: Path) -> None:
    pytest.importorskip("setuptools")
    result = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-w",
         str(tmp_path), str(REPO)],
        capture_output=True, text=True,
    )
    assert result.returncode == 0, result.stderr[-2000:]
    wheel = next(tmp_path.glob("rigval-*.whl"))
    names = zipfile.ZipFile(wheel).namelist()
    packages, _ = _declared()
    for package in packages:
        path = package.replace(".", "/") + "/__init__.py"
        assert path in names, f"{path} missing from {wheel.name}"
        assert package.replace(".", "/") + "/py.typed" in names
    # the documentation pages travel with the package: `rigval docs TOPIC` works when installed
    pages = sorted(p.name for p in (REPO / "docs").glob("*.md"))
    assert pages and all(f"rigval/docs/{page}" in names for page in pages)
    assert "rigval/validation/report/page.css" in names  # the report pages' style
    unpacked = tmp_path / "unpacked"
    zipfile.ZipFile(wheel).extractall(unpacked)
    code = ("import sys; from rigval.validation.commands.docs import pages; "
            "page = pages()['scene']; print(page); sys.stdout.write(page.read_text())")
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                         text=True, check=True, env={**os.environ, "PYTHONPATH": str(unpacked)})
    where, _, text = out.stdout.partition("\n")
    assert Path(where).is_relative_to(unpacked)  # read from the wheel, not the source tree
    assert text == (REPO / "docs" / "scene.md").read_text(encoding="utf-8")
