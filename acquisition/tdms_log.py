"""Capture nptdms's log messages during rigval's reads, leaving nptdms's loggers as they are.

nptdms gives each of its modules a logger with its own console handler and level
(``nptdms.log.log_manager``). Its warnings about a damaged or cut file ("Last segment metadata
is incomplete", "Cropping data ...") repeat what rigval reports itself as a DataWarning with
sample counts, so during rigval's own calls into nptdms they are captured: a filter, present only
for the duration of the call and acting only on records of the calling thread, passes them on to
this module's logger at DEBUG level and drops them from nptdms's handlers. Messages of other
threads, and of nptdms calls made outside rigval, reach nptdms's loggers unchanged.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["captured_nptdms_messages"]

logger = logging.getLogger(__name__)


class _ThreadCapture(logging.Filter):
    """Drop the records of one thread, logging them at DEBUG level through rigval instead."""

    def __init__(self, thread: int) -> None:
        super().__init__()
        self.thread = thread

    def filter(self, record: logging.LogRecord) -> bool:
        """Return False (drop) for records of the capturing thread, after logging them."""
        if record.thread != self.thread:
            return True
        logger.debug("nptdms %s: %s", record.levelname, record.getMessage())
        return False


def _nptdms_loggers() -> list[logging.Logger]:
    """Return nptdms's loggers (the package logger and one per module)."""
    manager = logging.Logger.manager
    names = [name for name in list(manager.loggerDict)
             if name == "nptdms" or name.startswith("nptdms.")]
    return [logging.getLogger(name) for name in names]


@contextmanager
def captured_nptdms_messages() -> Iterator[None]:
    """Capture nptdms's log records of the calling thread for the duration of the block.

    Yields
    ------
    None
        Inside the block, nptdms records emitted by this thread are logged by
        ``rigval.acquisition.tdms_log`` at DEBUG level and not shown by nptdms's handlers.
    """
    capture = _ThreadCapture(threading.get_ident())
    loggers = _nptdms_loggers()
    for each in loggers:
        each.addFilter(capture)
    try:
        yield
    finally:
        for each in loggers:
            each.removeFilter(capture)
