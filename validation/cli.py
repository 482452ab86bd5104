"""The ``rigval`` command line.

Exit codes
----------
0
    Success.
1
    A validation ran but failed one of its pass/fail thresholds.
2
    Usage or configuration error (bad option, bad scene or mechanism file).
3
    Data error (unreadable file, missing channel, alignment impossible, model failure).
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys
from collections.abc import Sequence
from importlib.metadata import PackageNotFoundError, version

from rigval.acquisition.errors import ConfigError, RigvalError

__all__ = ["EXIT_DATA", "EXIT_FAILED", "EXIT_OK", "EXIT_USAGE", "build_parser", "main"]

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_USAGE = 2
EXIT_DATA = 3

#: Subcommand modules in :mod:`rigval.validation.commands`, in the order ``--help`` lists them.
COMMANDS: tuple[str, ...] = ("validate", "demo", "campaign", "predict", "info", "simulate_rig",
                             "bench")

logger = logging.getLogger(__name__)


def _version() -> str:
    try:
        return version("rigval")
    except PackageNotFoundError:  # running from a source tree that was never installed
        return "unknown"


def build_parser() -> argparse.ArgumentParser:
    """Return the argument parser with every subcommand registered."""
    parser = argparse.ArgumentParser(
        prog="rigval",
        description="Check a planar rigid-body model of a machine against measurements.",
        epilog="Exit codes: 0 ok, 1 validation failed its thresholds, 2 usage or configuration "
               "error, 3 data error.",
    )
    parser.add_argument("--version", action="version", version=f"rigval {_version()}")
    parser.add_argument("-v", "--verbose", action="count", default=0,
                        help="more log output (-v info, -vv debug)")
    parser.add_argument("-q", "--quiet", action="store_true", help="only errors")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        importlib.import_module(f"rigval.validation.commands.{name}").add_parser(subparsers)
    return parser


def _configure_logging(verbose: int, quiet: bool) -> None:
    levels = (logging.WARNING, logging.INFO, logging.DEBUG)
    level = logging.ERROR if quiet else levels[min(verbose, 2)]
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("rigval: %(levelname)s: %(message)s"))
    root = logging.getLogger()
    root.handlers[:] = [handler]
    root.setLevel(level)
    logging.captureWarnings(True)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``rigval`` command line and return its exit code.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name; default ``sys.argv[1:]``.

    Returns
    -------
    int
        The exit code (see the module docstring).
    """
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as stop:  # argparse: --help / --version (0) or a usage error (2)
        return int(stop.code or 0)
    if args.command is None:
        parser.print_help(sys.stderr)
        return EXIT_USAGE
    _configure_logging(args.verbose, args.quiet)
    try:
        return int(args.func(args))
    except ConfigError as error:
        print(f"rigval: configuration error: {error}", file=sys.stderr)
        return EXIT_USAGE
    except RigvalError as error:
        print(f"rigval: data error: {error}", file=sys.stderr)
        return EXIT_DATA
    except KeyboardInterrupt:
        print("rigval: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
