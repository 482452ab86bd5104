"""The README starts with the two commands, and CI runs them verbatim."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

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


def test_readme_python_example_runs(capsys: pytest.CaptureFixture[str]) -> None:
    text = (REPO / "README.md").read_text()
    (snippet,) = re.findall(r"```python\n(.+?)\n```", text, flags=re.S)
    exec(compile(snippet, "README.md", "exec"), {})
    value, unit = capsys.readouterr().out.strip().split(" ", 1)
    # the pendulum's main-drive torque peaks at a few kN m (docs/predict.md: 3289 N m)
    assert unit == "N m" and 1000.0 < float(value) < 10000.0
