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


def _smoke_module():
    import importlib.util

    spec = importlib.util.spec_from_file_location("ci_smoke", REPO / ".ci" / "smoke.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_every_readme_command_has_a_smoke_run_on_the_plain_install() -> None:
    smoke = _smoke_module()
    commands = smoke.readme_commands()
    table = re.findall(r"^\| `rigval ([a-z-]+)[ `]", (REPO / "README.md").read_text(), re.M)
    assert commands == table and {"demo", "validate", "predict", "campaign"} <= set(commands)
    assert set(commands) <= set(smoke.SMOKE) | set(smoke.MAIN_JOB)


def test_ci_clears_each_venv_and_runs_main_job_smoke_tests_lint_in_order() -> None:
    ci = (REPO / ".ci" / "run").read_text().splitlines()
    demo, tests = _readme_commands()
    main_job, test_job = ci.index(demo), ci.index(tests)
    # each README command makes its venv anew, so the plain install never keeps the test extras
    assert demo.startswith("python3 -m venv --clear .venv && ")
    assert tests.startswith("python3 -m venv --clear .venv && ")
    smoke = next(i for i, line in enumerate(ci) if line.startswith(".venv/bin/python .ci/smoke.py"))
    lint = next(i for i, line in enumerate(ci) if line.startswith(".venv/bin/ruff check"))
    assert main_job < smoke < test_job < lint
