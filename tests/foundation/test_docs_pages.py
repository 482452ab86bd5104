"""The documentation pages: no temporary paths, and the performance page cites only what exists.

docs/performance.md holds the current figures, each with the command that measures it; the dated
history is kept in docs/bench/. A page that names a script or a command that is not in the
repository cannot be reproduced by a reader, and a path of a temporary folder was never theirs.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from rigval.validation.cli import build_parser

ROOT = Path(__file__).resolve().parents[2]
PAGES = [*sorted((ROOT / "docs").rglob("*.md")), ROOT / "README.md"]


def _subcommands() -> set[str]:
    """Return the names of rigval's subcommands, as the parser registers them."""
    parser = build_parser()
    action = next(a for a in parser._actions if a.choices and isinstance(a.choices, dict))
    return set(action.choices)


def test_no_page_names_a_temporary_folder() -> None:
    offenders = [f"{page.relative_to(ROOT)}:{number}: {line.strip()[:80]}"
                 for page in PAGES
                 for number, line in enumerate(page.read_text(encoding="utf-8").splitlines(), 1)
                 if re.search(r"/tmp\b|\btmp/", line)]
    assert not offenders, "\n".join(offenders)


def test_performance_page_cites_only_scripts_and_commands_that_exist() -> None:
    text = (ROOT / "docs" / "performance.md").read_text(encoding="utf-8")
    paths = set(re.findall(r"\b((?:benchmarks|tests)/[\w/]+\.py)\b", text))
    assert "benchmarks/bench_read.py" in paths  # the pattern finds the scripts it must check
    missing = sorted(path for path in paths if not (ROOT / path).is_file())
    assert not missing, f"docs/performance.md cites scripts that do not exist: {missing}"
    code = re.findall(r"`([^`\n]+)`", text) + re.findall(r"```\n(.*?)```", text, re.S)
    named = {name for span in code
             for name in re.findall(r"(?:^|\s)rigval (?:-v )?([a-z][a-z-]+)", span, re.M)}
    assert {"bench", "validate", "demo"} <= named
    unknown = sorted(named - _subcommands())
    assert not unknown, f"docs/performance.md runs rigval commands that do not exist: {unknown}"


def test_performance_page_is_one_page_and_its_history_is_kept() -> None:
    text = (ROOT / "docs" / "performance.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) < 400
    links = re.findall(r"\]\((bench/[\w.-]+\.md)(?:#[\w-]+)?\)", text)
    assert any("history" in link for link in links)
    for link in links:
        assert (ROOT / "docs" / link).is_file(), link


def test_relative_links_between_pages_resolve() -> None:
    broken = []
    for page in sorted((ROOT / "docs").rglob("*.md")):
        for target in re.findall(r"\]\(([\w./-]+\.md)(?:#[\w-]+)?\)", page.read_text("utf-8")):
            if not (page.parent / target).resolve().is_file():
                broken.append(f"{page.relative_to(ROOT)} -> {target}")
    assert not broken, broken


def test_readme_says_how_long_the_tests_take_and_git_ignores_the_demo_report() -> None:
    import subprocess

    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert re.search(r"\d+\s+tests in \d+ s", readme) and "minutes" in readme
    demo = re.findall(r"rigval demo --out (\S+)", readme)[0]  # the first command's folder
    ignored = subprocess.run(["git", "check-ignore", "-q", f"{demo}/index.html"], cwd=ROOT,
                             check=False)
    if ignored.returncode == 128:
        pytest.skip("not a git checkout")
    assert ignored.returncode == 0, f"{demo}/ is not in .gitignore"
