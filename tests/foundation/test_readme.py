"""The README starts with the two commands, and CI runs them verbatim."""

from __future__ import annotations

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def _readme_commands() -> list[str]:
    text = (REPO / "README.md").read_text()
    return re.findall(r"```bash\n(.+?)\n```", text)[:2]


def test_readme_has_demo_and_test_commands() -> None:
    demo, tests = _readme_commands()
    assert "pip install ." in demo and ".venv/bin/rigval" in demo
    assert '".[test]"' in tests and "pytest" in tests


def test_ci_runs_the_readme_commands_verbatim() -> None:
    ci = (REPO / ".ci" / "run").read_text().splitlines()
    for command in _readme_commands():
        assert command in ci, f"{command!r} is not a line of .ci/run"
