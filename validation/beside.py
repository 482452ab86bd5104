"""Run calls in a child forked from this process, beside the work this process goes on with.

A report's figures are independent pieces of work of a second or so in all, and matplotlib's
import takes another third of a second; on a machine with a free core a child draws them while
this process does other work. A :class:`Standby` forks before its work is known, so that the
child imports what the work will need (:class:`Standby` ``modules``: matplotlib and the
plotting modules) while this process does something else (the pipeline); the calls handed to
it later (:meth:`Standby.submit`) travel pickled, arguments and values, so this process never
imports those modules.

A standby forks only where it can help and is safe: the platform has ``fork``, this process
runs one thread (forking a multi-threaded process can deadlock), it may use more than one CPU,
and it is not itself a worker process (a campaign's or ``rigval demo``'s children already keep
the cores busy). Otherwise, and whenever the child fails, ends without sending a value, or an
argument or value does not pickle, the function runs in this process when its value is asked
for, so an error shows here with its traceback and the outcome is the same either way.
"""

from __future__ import annotations

import contextlib
import copyreg
import importlib
import io
import logging
import multiprocessing
import os
import pickle
import queue
import signal
import threading
from collections.abc import Callable, Iterable
from types import MappingProxyType, TracebackType
from typing import TYPE_CHECKING, Any, Generic, TypeVar

if TYPE_CHECKING:
    from multiprocessing.connection import Connection
    from multiprocessing.process import BaseProcess

__all__ = ["Pending", "Standby", "can_fork", "pickled"]

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


def _mapping_proxy(items: dict[Any, Any]) -> MappingProxyType[Any, Any]:
    return MappingProxyType(items)


#: How the calls' arguments and values pickle: as the standard pickler does, and a read-only
#: mapping (the scene's tables) as a read-only mapping of a copy of its items.
_DISPATCH = {**copyreg.dispatch_table,
             MappingProxyType: lambda proxy: (_mapping_proxy, (dict(proxy),))}


def pickled(value: object) -> bytes:
    """Return ``value`` pickled as a standby's calls and values are (:data:`_DISPATCH`)."""
    buffer = io.BytesIO()
    pickler = pickle.Pickler(buffer, protocol=pickle.HIGHEST_PROTOCOL)
    pickler.dispatch_table = _DISPATCH
    pickler.dump(value)
    return buffer.getvalue()


#: The ends of every standby's pipes that this process holds: each child closes its copies
#: (its own pipes' and those of the standbys forked before it), so that a standby sees the end
#: of its calls when this process closes it.
_HELD_HERE: list[Connection] = []


class Pending(Generic[T]):
    """A call handed to a :class:`Standby`; :meth:`result` returns its value."""

    def __init__(self, standby: Standby | None, function: Callable[..., T],
                 args: tuple[Any, ...]) -> None:
        self._standby = standby  # None: not sent, computed here when asked for
        self._function = function
        self._args = args
        self._outcome: tuple[bool, Any] | None = None

    def result(self) -> T:
        """Return the call's value: the child's, or computed here (see the module)."""
        if self._standby is not None:
            self._standby.receive_until(self)
            self._standby = None
        if self._outcome is None or not self._outcome[0]:
            self._outcome = True, self._function(*self._args)
        return self._outcome[1]  # type: ignore[no-any-return]


class Standby:
    """A child forked now that imports ``modules``, then runs the calls handed to it in order.

    Use it as a context manager: leaving it tells the child that no call will come and waits
    for it to end. Where :func:`can_fork` says no, nothing is forked and every call runs in
    this process when its value is asked for.

    Parameters
    ----------
    modules : iterable of str
        Modules the child imports as soon as it starts (an import that fails is left to the
        calls, which then fail and run here).
    """

    def __init__(self, modules: Iterable[str] = ()) -> None:
        self._unanswered: list[Pending[Any]] = []
        self._child = _fork_children(tuple(modules), 1)[0] if can_fork() else None
        self._followers: tuple[Standby, ...] = ()

    @classmethod
    def group(cls, count: int, modules: Iterable[str] = ()) -> list[Standby]:
        """Return ``count`` standbys whose children import ``modules`` once between them.

        One child is forked now and imports ``modules``; it then forks the others from itself,
        so that they start with the modules imported (one import's CPU instead of ``count``).
        Closing the first standby closes the others too (its child waits for theirs to end).
        Where :func:`can_fork` says no, every call of every standby runs in this process.
        The children run at this process's priority: lowered (nice 5), their work waited
        behind other programs' on a busy machine (a page waited 0.5 s longer for its figures
        at load 3-4), for 0.04 s gained on an idle one (docs/performance.md).
        """
        children: list[_Child | None] = [None] * count
        if can_fork():
            children[:] = _fork_children(tuple(modules), count)
        standbys = [cls._holding(child) for child in children]
        standbys[0]._followers = tuple(standbys[1:])
        return standbys

    @classmethod
    def _holding(cls, child: _Child | None) -> Standby:
        """Return a standby serving its calls by ``child`` (none: here)."""
        standby = cls.__new__(cls)
        standby._unanswered = []
        standby._child = child
        standby._followers = ()
        return standby

    def submit(self, function: Callable[..., T], *args: Any) -> Pending[T]:
        """Hand ``function(*args)`` to the child; the value comes with :meth:`Pending.result`.

        ``function`` must pickle (a module-level function); it may run twice (in the child,
        then here if the child fails), so it must not depend on running once.
        """
        if self._child is not None:
            try:
                self._child[0].send_bytes(pickled((function, args)))
            except (pickle.PicklingError, TypeError, AttributeError, EOFError, OSError):
                # a lambda or a lock does not pickle; a child that ended takes no call
                logger.debug("the call runs here", exc_info=True)
            else:
                pending: Pending[T] = Pending(self, function, args)
                self._unanswered.append(pending)
                return pending
        return Pending(None, function, args)

    def receive_until(self, pending: Pending[Any]) -> None:
        """Take the child's outcomes up to that of ``pending`` (the calls' order)."""
        while pending in self._unanswered:
            first = self._unanswered.pop(0)
            first._outcome = False, None
            if self._child is not None:
                try:
                    first._outcome = pickle.loads(self._child[1].recv_bytes())
                except (EOFError, OSError):  # the child ended: the call runs here
                    logger.debug("the standby child is gone", exc_info=True)

    def close(self, *, stop: bool = False) -> None:
        """Tell the child that no more calls come; wait for it to end.

        With ``stop``, end it at once instead (its unanswered calls are not needed: an error
        or Ctrl-C ends the work that handed them).
        """
        for follower in self._followers:  # their children end before this one's
            follower.close(stop=stop)
        self._unanswered.clear()  # their values are computed here when asked for
        if self._child is not None:
            call_in, value_out, process = self._child
            self._child = None
            for end in (call_in, value_out):
                end.close()
                _HELD_HERE.remove(end)
            if process is not None:  # a child forked by another child ends with that one
                if stop:
                    process.terminate()
                process.join()

    def __enter__(self) -> Standby:
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 trace: TracebackType | None) -> None:
        self.close(stop=kind is not None)


#: A standby child as this process holds it: the end its calls are sent on, the end its values
#: come from, and its process (none for a child forked by another standby child).
_Child = tuple["Connection", "Connection", "BaseProcess | None"]


def _fork_children(modules: tuple[str, ...], count: int) -> list[_Child]:
    """Fork a child serving the first of ``count`` pipe pairs; it forks the others' children.

    See :meth:`Standby.group`; ``count`` 1 is a plain :class:`Standby`'s child.
    """
    context = multiprocessing.get_context("fork")
    calls = [context.Pipe(duplex=False) for _ in range(count)]
    values = [context.Pipe(duplex=False) for _ in range(count)]
    ends = [(call_out, value_in) for (call_out, _), (_, value_in) in zip(calls, values,
                                                                          strict=True)]
    held = [(call_in, value_out) for (_, call_in), (value_out, _) in zip(calls, values,
                                                                         strict=True)]
    _HELD_HERE.extend(end for pair in held for end in pair)  # the children close their copies
    process = context.Process(target=_serve_group, args=(ends, modules),
                              name="rigval standby", daemon=True)
    process.start()
    for pair in ends:  # the children hold the only other ends
        for end in pair:
            end.close()
    return [(call_in, value_out, process if k == 0 else None)
            for k, (call_in, value_out) in enumerate(held)]


def _serve_group(ends: list[tuple[Connection, Connection]], modules: tuple[str, ...]
                 ) -> None:
    """Be the first standby child of a group: import ``modules``, fork the others, serve.

    Each child serves its own pair of ``ends`` and closes the others'. The first child waits
    for the others before it ends; ended at once (SIGTERM: an error or Ctrl-C in the parent),
    it ends them first, so that none outlives it.
    """
    # Ctrl-C is the parent's to handle (it then ends this child): no traceback from here
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    # The parent ends this child with SIGTERM (Standby.close(stop=True)). A signal that
    # whoever started the parent blocked or ignored (a test runner, a job system) stays so in
    # its children, and the stop would wait for the child's imports and calls to end: until the
    # handler below, SIGTERM ends this child as it does by default.
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGTERM})
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    for end in _HELD_HERE:  # the parent's ends, of this group's pipes and the earlier ones'
        end.close()
    for name in modules:
        try:
            importlib.import_module(name)
        except Exception:  # the calls that need it fail and run in the parent
            logger.debug("the standby child cannot import %s", name, exc_info=True)
    others: list[int] = []
    for k in range(1, len(ends)):
        pid = os.fork()  # before any thread of this child starts
        if pid == 0:
            try:
                _close_all_but(ends, k)
                _serve(*ends[k])
            finally:
                os._exit(0)
        others.append(pid)
    _close_all_but(ends, 0)
    signal.signal(signal.SIGTERM, lambda *_: _end_now(others))
    _serve(*ends[0])
    for pid in others:
        os.waitpid(pid, 0)


def _close_all_but(ends: list[tuple[Connection, Connection]], keep: int) -> None:
    for k, pair in enumerate(ends):
        if k != keep:
            for end in pair:
                end.close()


def _end_now(others: list[int]) -> None:
    """End the other children of a group at once, wait for them, and end this one."""
    for pid in others:
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGKILL)
    for pid in others:
        with contextlib.suppress(ChildProcessError):
            os.waitpid(pid, 0)
    os._exit(1)


def _serve(calls: Connection, values: Connection) -> None:
    """Be a standby child: answer each call until there are no more.

    The calls are read by a thread as they come, so that this process's parent never waits
    to hand one over while the child works on another; the values are sent by another, so
    that the child goes on with the next call while the parent has not yet asked for the value
    before (a pipe holds 64 KiB: one figure group's text fills it).
    """
    inbox: queue.SimpleQueue[bytes | None] = queue.SimpleQueue()
    outbox: queue.SimpleQueue[bytes | None] = queue.SimpleQueue()
    # SIGTERM (the parent's stop) is left to this thread: the threads inherit it blocked. Taken
    # by one of them, it would only mark its Python handler as due, and this thread, blocked in
    # a wait for the group's other children, would never run it (a stop once hung a check for
    # its 120 s on a loaded machine); blocked here meanwhile, it waits until unblocked.
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGTERM})
    threading.Thread(target=_read_calls, args=(calls, inbox), daemon=True).start()
    sender = threading.Thread(target=_send_values, args=(values, outbox), daemon=True)
    sender.start()
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGTERM})
    while (call := inbox.get()) is not None:
        outbox.put(_answer(call))
    outbox.put(None)
    sender.join()


def _read_calls(calls: Connection, inbox: queue.SimpleQueue[bytes | None]) -> None:
    with calls:
        while True:
            try:
                inbox.put(calls.recv_bytes())
            except (EOFError, OSError):
                inbox.put(None)
                return


def _send_values(values: Connection, outbox: queue.SimpleQueue[bytes | None]) -> None:
    with values:
        while (value := outbox.get()) is not None:
            try:
                values.send_bytes(value)
            except OSError:  # the parent has gone: nobody waits for the values
                return


def _answer(call: bytes) -> bytes:
    """Return the pickled ``(True, value)`` of a pickled call, or ``(False, None)``."""
    try:
        function, args = pickle.loads(call)
        return pickled((True, function(*args)))
    except Exception:  # run again by the parent, which shows the error
        logger.debug("the call failed in the standby child", exc_info=True)
        return pickled((False, None))
