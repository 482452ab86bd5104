"""The command line's global options and exit codes."""

from __future__ import annotations

import pytest

from rigval.validation.cli import EXIT_USAGE, main


def test_version_exits_zero(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.startswith("rigval ")


def test_no_command_is_a_usage_error() -> None:
    assert main([]) == EXIT_USAGE


def test_unknown_option_is_a_usage_error() -> None:
    assert main(["--no-such-option"]) == EXIT_USAGE
