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
4
    Internal error: an unexpected exception, i.e. a bug in rigval. One line names the file the
    full traceback was written to; ``-v`` also prints the traceback.
130
    Interrupted (Ctrl-C).

``-v``/``-vv``/``-q`` work before and after the subcommand (``rigval info -v FILE``); ``-q``
prints only errors (results go to the output files).

This module imports only the standard library at its top: rigval's own modules are imported
inside :func:`main`, so that a Ctrl-C while they load still ends with one line.
"""

from __future__ import annotations

import argparse
import atexit
import contextlib
import datetime
import gc
import importlib
import logging
import os
import re
import sys
import tempfile
import traceback
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # imported where used, inside main()'s Ctrl-C handling (module docstring)
    from rigval.acquisition.errors import RigvalError

__all__ = ["EXIT_BUG", "EXIT_DATA", "EXIT_FAILED", "EXIT_INTERRUPTED", "EXIT_OK", "EXIT_USAGE",
           "build_parser", "main"]

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_USAGE = 2
EXIT_DATA = 3
EXIT_BUG = 4
EXIT_INTERRUPTED = 130

#: Subcommand modules in :mod:`rigval.validation.commands`, in the order ``--help`` lists them.
COMMANDS: tuple[str, ...] = ("validate", "init", "demo", "campaign", "predict", "identify",
                             "info", "simulate_rig", "bench", "docs")

#: The exit codes every subcommand can return besides its own (appended to each ``--help``).
COMMON_EXIT_CODES = (f"{EXIT_BUG} internal error (a bug: the traceback is written to a file "
                     f"named on the console; -v prints it), {EXIT_INTERRUPTED} interrupted.")

logger = logging.getLogger(__name__)


class HelpFormatter(argparse.HelpFormatter):
    """Help text that shows each option's default unless the help already states it."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        default = action.default
        if (not action.option_strings or "default" in text or default is None
                or default is False or default == [] or default is argparse.SUPPRESS):
            return text
        return f"{text} (default: %(default)s)"


def _verbosity_options(parser: argparse.ArgumentParser, *, sub: bool) -> None:
    """Add ``-v``/``-q``; a subcommand's own copies count into separate destinations."""
    prefix = "sub_" if sub else ""
    parser.add_argument("-v", "--verbose", dest=f"{prefix}verbose", action="count",
                        default=argparse.SUPPRESS if sub else 0,
                        help="more log output (-v info, -vv debug); -v also prints the "
                             "traceback of an internal error")
    parser.add_argument("-q", "--quiet", dest=f"{prefix}quiet", action="store_true",
                        default=argparse.SUPPRESS if sub else False,
                        help="print only errors")


class _Subcommands:
    """Wraps argparse's subparsers: every subcommand gets -v/-q, defaults and exit codes."""

    def __init__(self, action: Any) -> None:
        self._action = action
        self._common = argparse.ArgumentParser(add_help=False)
        _verbosity_options(self._common, sub=True)

    def add_parser(self, name: str, **kwargs: Any) -> argparse.ArgumentParser:
        """Register a subcommand (same arguments as argparse's ``add_parser``)."""
        epilog = (kwargs.get("epilog") or "").rstrip()
        if "Exit codes" not in epilog:
            epilog += (" " if epilog else "") + (f"Exit codes: {EXIT_OK} ok, {EXIT_USAGE} usage "
                                                 f"or configuration error, {EXIT_DATA} data "
                                                 "error.")
        kwargs["epilog"] = f"{epilog} Also {COMMON_EXIT_CODES}"
        kwargs.setdefault("formatter_class", HelpFormatter)
        kwargs["parents"] = [*kwargs.get("parents", []), self._common]
        return self._action.add_parser(name, **kwargs)


class _VersionAction(argparse.Action):
    """``--version``: print the installed version and exit (looked up only when asked for)."""

    def __init__(self, option_strings: Sequence[str], dest: str = argparse.SUPPRESS,
                 default: str = argparse.SUPPRESS) -> None:
        super().__init__(option_strings, dest=dest, default=default, nargs=0,
                         help="show the installed rigval version and exit")

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: object, option_string: str | None = None) -> None:
        from rigval.validation.version import rigval_version

        print(f"rigval {rigval_version()}")  # on standard output, as argparse's own action
        parser.exit()


def build_parser() -> argparse.ArgumentParser:
    """Return the argument parser with every subcommand registered."""
    parser = argparse.ArgumentParser(
        prog="rigval",
        description="Check a planar rigid-body model of a machine against measurements.",
        epilog=f"Exit codes: {EXIT_OK} ok, {EXIT_FAILED} validation failed its thresholds, "
               f"{EXIT_USAGE} usage or configuration error, {EXIT_DATA} data error, "
               f"{COMMON_EXIT_CODES} 'rigval COMMAND --help' describes each command.",
        formatter_class=HelpFormatter,
    )
    parser.add_argument("--version", action=_VersionAction)
    _verbosity_options(parser, sub=False)
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    wrapped = _Subcommands(subparsers)
    for name in COMMANDS:
        importlib.import_module(f"rigval.validation.commands.{name}").add_parser(wrapped)
    return parser


def _configure_logging(verbose: int, quiet: bool) -> None:
    levels = (logging.WARNING, logging.INFO, logging.DEBUG)
    level = logging.ERROR if quiet else levels[min(verbose, 2)]
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("rigval: %(levelname)s: %(message)s"))
    root = logging.getLogger()
    root.handlers[:] = [handler]
    root.setLevel(level)
    from rigval.validation.console import install_warning_display, silence

    install_warning_display()
    if quiet:
        silence()


def _docs_hint(error: BaseException) -> str | None:
    """Return how to read the doc pages an error message names (``docs/scene.md``)."""
    topics = list(dict.fromkeys(re.findall(r"docs/(\w+)\.md", str(error))))
    if not topics:
        return None
    return "rigval: the page is shipped with rigval: " + "; ".join(
        f"rigval docs {topic}" for topic in topics)


def _print_error(kind: str, error: RigvalError) -> None:
    """Print a rigval error, and how to read the doc pages it names."""
    print(f"rigval: {kind}: {error}", file=sys.stderr)
    hint = _docs_hint(error)
    if hint:
        print(hint, file=sys.stderr)


def _report_bug(error: BaseException, verbose: int) -> None:
    """Write the traceback to a file and say where (and print it with -v)."""
    from rigval.validation.version import rigval_version

    text = "".join(traceback.format_exception(error))
    stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
    fd, name = tempfile.mkstemp(prefix=f"rigval-traceback-{stamp}-", suffix=".txt")
    with os.fdopen(fd, "w", encoding="utf-8") as file:
        file.write(f"rigval {rigval_version()}, Python {sys.version.split()[0]}\n")
        file.write("command: rigval " + " ".join(sys.argv[1:]) + "\n\n" + text)
    if verbose:
        print(text, end="", file=sys.stderr)
    first = " ".join(str(error).split())[:200]
    print(f"rigval: internal error (a bug), {type(error).__name__}: {first}; full traceback in "
          f"{name}" + ("" if verbose else " (-v prints it)"), file=sys.stderr)


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
    # The interpreter's exit would walk the objects of every imported module (numpy, scipy,
    # xarray, matplotlib, rigval) looking for garbage: 0.2-0.5 s of every command. Frozen at
    # exit, they are skipped (once per process, however often main runs in it).
    atexit.unregister(gc.freeze)
    atexit.register(gc.freeze)
    try:
        from rigval.validation.console import quiet_interrupts
        from rigval.validation.scipy_docstrings import docstrings_as_written

        # one line on Ctrl-C from here on (docs/campaign.md); SciPy imported without its
        # docstrings' array API notes, which a command never shows (0.3 s of its start)
        with quiet_interrupts(), docstrings_as_written():
            return _main(argv)
    except KeyboardInterrupt:  # also while the subcommands' modules are imported
        print("rigval: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


def _main(argv: Sequence[str] | None) -> int:
    """Parse ``argv``, run the subcommand and turn its exceptions into exit codes."""
    from rigval.acquisition.errors import ConfigError, RigvalError

    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as stop:  # argparse: --help / --version (0) or a usage error (2)
        return int(stop.code or 0)
    if args.command is None:
        parser.print_help(sys.stderr)
        return EXIT_USAGE
    verbose = args.verbose + getattr(args, "sub_verbose", 0)
    args.quiet = quiet = bool(args.quiet or getattr(args, "sub_quiet", False))
    args.verbose = verbose
    _configure_logging(verbose, quiet)
    try:
        with contextlib.ExitStack() as stack:
            if quiet:  # results are in the output files; print only errors
                stack.enter_context(contextlib.redirect_stdout(open(os.devnull, "w")))  # noqa: SIM115
            return int(args.func(args))
    except ConfigError as error:
        _print_error("configuration error", error)
        return EXIT_USAGE
    except RigvalError as error:
        _print_error("data error", error)
        return EXIT_DATA
    except BrokenPipeError:  # the reader went away (``rigval info ... | head``): not an error
        with contextlib.suppress(OSError):
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_OK
    except Exception as error:  # a bug: its own exit code, the traceback in a file
        from rigval.validation.console import was_interrupted

        if was_interrupted():  # a consequence of Ctrl-C (its one line is printed already)
            return EXIT_INTERRUPTED
        _report_bug(error, verbose)
        return EXIT_BUG


if __name__ == "__main__":
    sys.exit(main())
