"""What the ``rigval`` command line shows on the console besides its results.

Warnings become one line each, ``rigval: warning: [run NAME] DataWarning: what (file: ..., channel:
...)``, instead of Python's two-line ``file.py:337: DataWarning: ...`` form; a progress display
that is on screen is cleared before the line and redrawn after it, so the two never interleave.
The run a warning belongs to is set with :func:`run_context` around each run's work.

Ctrl-C: inside :func:`interrupt_quietly` (the whole command: :func:`quiet_interrupts`) the
first SIGINT prints one line, ``rigval: interrupted``, and sends everything the shutdown still
writes to stderr (Dask's cancelled tasks, a half-started cluster's exit handlers, warnings of
runs cut off) to the null device.

Only the command line installs this (:func:`install_warning_display`); library code never does.
"""

from __future__ import annotations

import contextlib
import contextvars
import logging
import os
import signal
import sys
import warnings
from collections.abc import Callable, Iterator
from typing import Any, Protocol, TextIO

__all__ = ["INTERRUPTED_LINE", "Progress", "format_warning", "install_warning_display",
           "interrupt_quietly", "progress_display", "quiet_interrupts", "run_context", "silence",
           "was_interrupted"]

#: The one line a Ctrl-C prints.
INTERRUPTED_LINE = "rigval: interrupted"

_RUN: contextvars.ContextVar[str | None] = contextvars.ContextVar("rigval_run", default=None)


class Progress(Protocol):
    """A progress display drawn on one terminal line."""

    def clear(self) -> None:
        """Erase the line."""

    def redraw(self) -> None:
        """Draw the line again."""


_state: dict[str, Any] = {"progress": None, "silent": False, "stream": None, "interrupted": False}


def format_warning(message: Warning | str, category: type[Warning]) -> str:
    """Return a warning as one console line (no file name, no source line).

    Parameters
    ----------
    message : Warning or str
        The warning.
    category : type
        Its class; its name is shown (``DataWarning``, ``NumericsWarning``, ...).

    Returns
    -------
    str
        ``rigval: warning: [run NAME] Category: text``, newlines folded into spaces.
    """
    text = " ".join(str(message).split())
    run = _RUN.get()
    place = f"[run {run}] " if run else ""
    return f"rigval: warning: {place}{category.__name__}: {text}"


def _show(message: Warning | str, category: type[Warning], filename: str, lineno: int,
          file: TextIO | None = None, line: str | None = None) -> None:
    """``warnings.showwarning`` replacement: one line through the progress display."""
    if _state["silent"]:
        return
    stream = file or _state["stream"] or sys.stderr
    progress = _state["progress"]
    if progress is not None:
        progress.clear()
    stream.write(format_warning(message, category) + "\n")
    stream.flush()
    if progress is not None:
        progress.redraw()


def install_warning_display(stream: TextIO | None = None) -> None:
    """Show every warning of this process as one line on ``stream`` (default ``sys.stderr``).

    Parameters
    ----------
    stream : file, optional
        Where the lines go; default the current ``sys.stderr`` at the time of each warning.
    """
    _state["stream"] = stream
    _state["silent"] = False
    warnings.showwarning = _show


def silence() -> None:
    """Show no more warnings in this process (after Ctrl-C: the shutdown's noise is dropped)."""
    _state["silent"] = True


@contextlib.contextmanager
def progress_display(progress: Progress | None) -> Iterator[None]:
    """Clear and redraw ``progress`` around every warning line while the block runs."""
    before = _state["progress"]
    _state["progress"] = progress
    try:
        yield
    finally:
        _state["progress"] = before


@contextlib.contextmanager
def run_context(name: str) -> Iterator[None]:
    """Name the run that warnings raised inside the block belong to.

    Inside the block warnings are shown as one line with ``[run NAME]`` also in processes where
    the command line did not install its display (Dask workers).

    Parameters
    ----------
    name : str
        The run's name.
    """
    token = _RUN.set(name)
    try:
        with warnings.catch_warnings():
            if warnings.showwarning is not _show:
                warnings.showwarning = _show
            yield
    finally:
        _RUN.reset(token)


def was_interrupted() -> bool:
    """Return whether Ctrl-C hit the command (:func:`quiet_interrupts`) in this process.

    What fails after that (a worker process killed while it started, say Dask's "Nanny failed
    to start") is the interrupt's consequence, not a bug: the command line exits as interrupted.
    """
    return bool(_state["interrupted"])


@contextlib.contextmanager
def interrupt_quietly(on_interrupt: Callable[[], None] | None = None) -> Iterator[None]:
    """Make the first Ctrl-C inside the block print one line and nothing after it.

    On SIGINT: the progress display is cleared, :data:`INTERRUPTED_LINE` is written to stderr,
    warnings and the loggers of the shutdown (``distributed``, ``tornado``, ``asyncio``,
    ``rigval``) are silenced, ``on_interrupt`` runs (e.g. killing worker processes), stderr (the
    Python object and file descriptor 2) is pointed at the null device, and
    :class:`KeyboardInterrupt` is raised in the main thread. The caller's handler of
    KeyboardInterrupt may print its own line: it goes to the null device.

    A Ctrl-C that came before the block, inside :func:`quiet_interrupts`, and whose
    KeyboardInterrupt was lost (raised inside a callback that swallows it, such as one of the
    import machinery's) stops the block as it starts.

    Parameters
    ----------
    on_interrupt : callable, optional
        Called once, without arguments, before KeyboardInterrupt is raised.
    """
    if _state["interrupted"]:
        raise KeyboardInterrupt

    def interrupted(signum: int, frame: Any) -> None:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # a second Ctrl-C changes nothing
        _state["interrupted"] = True
        progress = _state["progress"]
        with contextlib.suppress(Exception):
            if progress is not None:
                progress.clear()
            sys.stderr.write(INTERRUPTED_LINE + "\n")
            sys.stderr.flush()
        silence()
        for name in ("distributed", "tornado", "asyncio", "rigval"):
            logging.getLogger(name).setLevel(logging.CRITICAL + 1)
        if on_interrupt is not None:
            on_interrupt()
        _stderr_to_null()
        raise KeyboardInterrupt

    try:
        previous = signal.signal(signal.SIGINT, interrupted)
    except ValueError:  # not the main thread: leave Ctrl-C alone
        yield
        return
    try:
        yield
    finally:
        with contextlib.suppress(ValueError):
            signal.signal(signal.SIGINT, previous)


@contextlib.contextmanager
def quiet_interrupts() -> Iterator[None]:
    """Run a whole command as a block of :func:`interrupt_quietly`, from its first moment.

    A Ctrl-C while the command's modules are still imported then prints the one line too, and
    what it breaks after is its consequence (:func:`was_interrupted`), whatever swallowed its
    KeyboardInterrupt. Forgets an interrupt of an earlier command in this process.
    """
    _state["interrupted"] = False
    with interrupt_quietly():
        yield


def _stderr_to_null() -> None:
    """Point ``sys.stderr`` and file descriptor 2 at the null device (after the one line)."""
    null = open(os.devnull, "w")  # noqa: SIM115 - stays open until the process ends
    with contextlib.suppress(OSError, ValueError):
        os.dup2(null.fileno(), 2)
    sys.stderr = null
