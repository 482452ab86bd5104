"""Run a function in a child forked from this process, beside the work this process goes on with.

A report's figures and the identification's two report folders are independent pieces of work
of a second or so each; on a machine with a free core a forked child does one while this
process does another. A fork starts in milliseconds with everything imported and every array
in memory (copied only where written), and sends back its return value pickled.

:func:`beside` forks only where it can help and is safe: the platform has ``fork``, this
process runs one thread (forking a multi-threaded process can deadlock), it may use more than
one CPU, and it is not itself a worker process (a campaign's or ``rigval demo``'s children
already keep the cores busy). Otherwise, and whenever the child fails or ends without sending
its value, the function runs in this process when its value is asked for, so an error shows
here with its traceback and the outcome is the same either way.
"""

from __future__ import annotations

import logging
import multiprocessing
import os
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Generic, TypeVar

if TYPE_CHECKING:
    from multiprocessing.connection import Connection
    from multiprocessing.process import BaseProcess

__all__ = ["Beside", "beside", "can_fork"]

logger = logging.getLogger(__name__)

T = TypeVar("T")


def can_fork() -> bool:
    """Return whether a forked child may work beside this process (see the module)."""
    if "fork" not in multiprocessing.get_all_start_methods():
        return False
    if threading.active_count() != 1 or multiprocessing.parent_process() is not None:
        return False
    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return (cpus or 1) > 1


class Beside(Generic[T]):
    """A function started by :func:`beside`; :meth:`result` returns its value."""

    def __init__(self, function: Callable[[], T]) -> None:
        self._function = function
        self._child: tuple[Connection, BaseProcess] | None = None
        if can_fork():
            context = multiprocessing.get_context("fork")
            receiver, sender = context.Pipe(duplex=False)
            process = context.Process(target=_child, args=(sender, function),
                                      name="rigval beside", daemon=True)
            process.start()
            sender.close()  # the child holds the only sending end: its exit means EOF
            self._child = receiver, process

    def result(self) -> T:
        """Return the function's value: the child's, or computed here (see the module)."""
        if self._child is not None:
            receiver, process = self._child
            self._child = None
            with receiver:
                try:
                    done, value = receiver.recv()
                except (EOFError, OSError):
                    done, value = False, None
            process.join()
            if done:
                return value  # type: ignore[no-any-return]
            logger.debug("the child ended with code %s without a value; running it here",
                         process.exitcode)
        return self._function()


def beside(function: Callable[[], T]) -> Beside[T]:
    """Start ``function`` in a forked child where that helps (see the module).

    Parameters
    ----------
    function : callable
        Called without arguments; its value must pickle. It may run twice (in the child,
        then here if the child fails), so it must not depend on running once.

    Returns
    -------
    Beside
        Ask :meth:`Beside.result` for the value.
    """
    return Beside(function)


def _child(sender: Connection, function: Callable[[], T]) -> None:
    """Call the function and send ``(True, value)``, or ``(False, None)`` when it failed."""
    with sender:
        try:
            outcome: tuple[bool, T | None] = True, function()
        except Exception:  # run again by the parent, which shows the error
            logger.debug("the function failed in the child", exc_info=True)
            outcome = False, None
        sender.send(outcome)
