"""Paths on the command line, checked while the options are parsed, before any work.

``--out`` of every command: an existing file (a folder for ``init``) is refused with exit code 2
and left as it was. A missing input file exits 2 from every command, and a data file given as a
scene is named as one, with the command that writes a scene for it.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path

import pytest

from rigval.sample_data import shipped_runs
from rigval.validation.cli import EXIT_USAGE, build_parser, main
from rigval.validation.commands.common import out_file, out_folder


def _commands_with_out() -> dict[str, argparse.ArgumentParser]:
    """Return every subcommand's parser that has an ``--out`` option, by name."""
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return {name: p for name, p in sub.choices.items()
            if any("--out" in a.option_strings for a in p._actions)}


def _argv(name: str, parser: argparse.ArgumentParser, out: Path) -> list[str]:
    """Return a command line of ``name`` with its positional arguments filled and ``--out``."""
    scene = str(shipped_runs()[0])
    positional = [scene for a in parser._actions
                  if not a.option_strings and a.dest not in ("help", "func")]
    return [name, *positional, "--out", str(out)]


def test_every_command_that_writes_takes_out_through_the_shared_check() -> None:
    commands = _commands_with_out()
    assert {"validate", "demo", "campaign", "predict", "identify", "simulate-rig", "bench",
            "init"} <= set(commands)
    for name, parser in commands.items():
        action = next(a for a in parser._actions if "--out" in a.option_strings)
        assert action.type is (out_file if name == "init" else out_folder), name


@pytest.mark.parametrize("name", sorted(_commands_with_out()))
def test_out_of_the_wrong_kind_exits_2_before_any_work(
        name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    parser = _commands_with_out()[name]

    def no_work(args: argparse.Namespace) -> int:
        raise AssertionError(f"{name} started its work")

    if name == "init":
        out = tmp_path / "a_folder"
        out.mkdir()
    else:
        out = tmp_path / "afile"
        out.write_text("x\n", encoding="utf-8")
    argv = _argv(name, parser, out)
    # whatever the command would run must not start: the check is in the options
    monkeypatch.setattr("rigval.validation.cli.build_parser", _parser_without_work(no_work))
    assert main(argv) == EXIT_USAGE
    err = capsys.readouterr().err
    if name == "init":
        assert "is a folder, and --out must be the file to write" in err
        assert out.is_dir() and not any(out.iterdir())
    else:
        assert "is a file, and --out must be a folder" in err
        assert out.read_text(encoding="utf-8") == "x\n"


def _parser_without_work(no_work: Callable[[argparse.Namespace], int]
                         ) -> Callable[[], argparse.ArgumentParser]:
    """Return a ``build_parser`` whose commands all run ``no_work`` instead of their work."""
    def build() -> argparse.ArgumentParser:
        parser = build_parser()
        sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        for command in sub.choices.values():
            command.set_defaults(func=no_work)
        return parser
    return build


#: A command line per command that reads input files; ``{}`` stands for the input.
READERS = {"validate": ["validate", "{}", "--out", "OUT"], "identify": ["identify", "{}", "--out",
                                                                        "OUT"],
           "campaign": ["campaign", "{}", "--out", "OUT"], "info": ["info", "{}"],
           "init": ["init", "{}", "--out", "OUT/scene.toml"]}


@pytest.mark.parametrize("name", sorted(READERS))
def test_a_missing_input_exits_2_from_every_command(
        name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    missing = tmp_path / "nope.tdms"
    argv = [word.replace("{}", str(missing)).replace("OUT", str(tmp_path / "out"))
            for word in READERS[name]]
    assert main(argv) == EXIT_USAGE
    err = capsys.readouterr().err
    assert f"{missing} does not exist: check the path" in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("name", ["validate", "identify", "campaign"])
@pytest.mark.parametrize("data", ["run_0p8_cdaq.tdms", "run_0p8_wls2.csv"])
def test_a_data_file_given_as_a_scene_points_to_init(
        name: str, data: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = shipped_runs()[0].parent / data
    argv = [word.replace("{}", str(path)).replace("OUT", str(tmp_path / "out"))
            for word in READERS[name]]
    assert main(argv) == EXIT_USAGE
    err = capsys.readouterr().err
    assert "is a data file, not a scene" in err and f"rigval init {path} --out" in err
    assert "codec" not in err and "decode" not in err
