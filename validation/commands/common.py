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

__all__ = ["add_command", "add_out_option", "add_scene_argument", "input_file", "out_file",
           "out_folder", "scene_file"]

#: File name endings of data files (docs/formats.md): given as a scene, they get a pointer to
#: ``rigval init`` instead of a TOML or text decoding error.
DATA_FILE_SUFFIXES = (".tdms", ".tdms_index", ".lvm", ".csv", ".txt")


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


def input_file(text: str) -> Path:
    """Return an input file given on the command line; refuse a missing one (exit code 2).

    Every command checks its input files this way while the options are parsed, so a missing
    file gives the same exit code (2, a usage error) from every command.
    """
    path = Path(text)
    if not path.is_file():
        what = "is a folder, not a file" if path.is_dir() else "does not exist"
        raise argparse.ArgumentTypeError(f"{text} {what}: check the path")
    return path


def scene_file(text: str) -> Path:
    """Return a scene file given on the command line (:func:`input_file`); refuse a data file.

    A TDMS, LVM or CSV file given where a scene belongs is named as such, with the command
    that writes a scene for it, instead of failing to decode as TOML.
    """
    path = input_file(text)
    with path.open("rb") as handle:
        head = handle.read(4)
    if path.suffix.lower() in DATA_FILE_SUFFIXES or head in (b"TDSm", b"TDSh"):
        raise argparse.ArgumentTypeError(
            f"{text} is a data file, not a scene: write a scene for it with 'rigval init "
            f"{text} --out scene.toml' (see 'rigval docs scene')")
    return path


def add_scene_argument(parser: argparse.ArgumentParser) -> None:
    """Add the positional ``scene`` argument (:func:`scene_file`) to a command's parser."""
    parser.add_argument("scene", type=scene_file, help="scene file (TOML, docs/scene.md)")


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
