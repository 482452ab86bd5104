"""``rigval init FILE... --out scene.toml [--mechanism M]``: a scene skeleton from data files.

Reads the files, guesses devices, channel roles and sensor kinds, and writes a commented scene
whose unknown values are marked ``TODO`` (:mod:`rigval.validation.scene_init`); prints the
guesses and the ``angle_at_reference`` estimates. ``rigval validate`` refuses the scene until
every TODO is filled. Exit codes: 0 written, 2 bad option or existing output, 3 unreadable file.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from rigval.validation.commands.common import add_command, input_file, out_file

__all__ = ["add_parser", "run"]


def add_parser(subparsers: Any) -> None:
    """Register the ``init`` subcommand."""
    parser = add_command(
        subparsers, run, "init",
        help="write a commented scene skeleton from data files (unknowns as TODO)",
        description="Read TDMS, CSV or LVM files and write a scene skeleton: streams, channels "
                    "with units and rates, guessed device profiles and sensor kinds, the "
                    "alignment and comparison blocks. What the files cannot tell is marked "
                    "TODO; rigval validate refuses the scene until each TODO is filled.",
        exit_codes="0 written, 2 bad option, missing FILE or existing --out (use --force), "
                   "3 a file cannot be read.")
    parser.add_argument("files", nargs="+", type=input_file, metavar="FILE", help="data files")
    parser.add_argument("--out", type=out_file, required=True, help="scene file to write (TOML)")
    parser.add_argument("--mechanism", metavar="M", default=None,
                        help="builtin:NAME or a mechanism file (default: TODO in the scene)")
    parser.add_argument("--force", action="store_true", help="overwrite --out")


def run(args: argparse.Namespace) -> int:
    """Write the skeleton; return 0."""
    from rigval.acquisition.errors import ConfigError
    from rigval.acquisition.outputs import write_text_atomic
    from rigval.acquisition.survey import guess_streams
    from rigval.validation.scene_init import skeleton_text

    if args.out.exists() and not args.force:
        raise ConfigError(f"{args.out} exists", where={"file": str(args.out)},
                          hint="choose another --out or pass --force")
    streams = guess_streams(args.files)
    text, notes = skeleton_text(streams, args.out, args.mechanism)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(args.out, text)
    for line in notes:
        print(line)
    todo = sum(1 for line in text.splitlines() if '= "TODO' in line)
    print(f"wrote {args.out}: {todo} value(s) marked TODO (rigval validate lists them)",
          file=sys.stdout)
    return 0
