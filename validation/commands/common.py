"""What every subcommand module shares: registering its parser.

:func:`add_command` is the one way a module of :mod:`rigval.validation.commands` registers its
subcommand: help line, description, exit codes (the last sentence of ``--help``) and the
function that runs it. The command line (:mod:`rigval.validation.cli`) adds ``-v``/``-q`` and
the exit codes common to all commands.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = ["add_command", "add_out_option", "add_scene_argument", "out_file", "out_folder"]


def add_command(subparsers: Any, func: Callable[[argparse.Namespace], int], name: str, *,
                help: str, description: str, exit_codes: str | None = None,
                epilog: str | None = None) -> argparse.ArgumentParser:
    """Register a subcommand and return its parser, for the command's own arguments.

    Parameters
    ----------
    subparsers : object
        What ``add_parser(subparsers)`` receives (argparse's subparsers, wrapped by the CLI).
    func : callable
        ``func(args) -> int``: runs the command and returns its exit code.
    name : str
        The subcommand, as typed (``"simulate-rig"``).
    help : str
        One line for ``rigval --help``.
    description : str
        What the command does, for ``rigval NAME --help``.
    exit_codes : str, optional
        The command's exit codes, e.g. ``"0 ok, 2 unknown topic."``; without, the CLI's
        default sentence.
    epilog : str, optional
        Further text shown before the exit codes.
    """
    parts = [epilog] if epilog else []
    if exit_codes:
        parts.append(f"Exit codes: {exit_codes}")
    parser = subparsers.add_parser(name, help=help, description=description,
                                   epilog=" ".join(parts) or None)
    parser.set_defaults(func=func)
    return parser


def add_scene_argument(parser: argparse.ArgumentParser) -> None:
    """Add the positional ``scene`` argument (a scene file) to a command's parser."""
    parser.add_argument("scene", type=Path, help="scene file (TOML, docs/scene.md)")


def out_folder(text: str) -> Path:
    """Return ``--out DIR`` as a path; refuse an existing file while the options are parsed.

    Every command that writes a folder takes its ``--out`` through this type, so a file given
    there ends the command with exit code 2 before any work, not with an internal error after
    it (argparse turns the :class:`argparse.ArgumentTypeError` into a usage error).
    """
    path = Path(text)
    if path.exists() and not path.is_dir():
        raise argparse.ArgumentTypeError(
            f"{text} is a file, and --out must be a folder: give a new folder (it is created) "
            "or an existing one")
    return path


def out_file(text: str) -> Path:
    """Return ``--out FILE`` as a path; refuse an existing folder.

    The counterpart of :func:`out_folder` for a command that writes one file (``init``).
    """
    path = Path(text)
    if path.is_dir():
        raise argparse.ArgumentTypeError(
            f"{text} is a folder, and --out must be the file to write: give a file name, e.g. "
            f"{path / 'scene.toml'}")
    return path


def add_out_option(parser: argparse.ArgumentParser, help: str = "output folder (created)",
                   ) -> None:
    """Add the required ``--out DIR`` option (:func:`out_folder`) to a command's parser."""
    parser.add_argument("--out", type=out_folder, required=True, metavar="DIR", help=help)
