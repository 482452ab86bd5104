"""Wall time per stage of a run, each stage's end logged with the process's CPU and memory.

:class:`Stopwatch` times the pipeline's stages (:mod:`rigval.validation.pipeline`); a stage
inside another pauses it, and what a stage freed is handed back to the system as it ends.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Iterator
from contextlib import contextmanager

from rigval.acquisition.heap import release_free_heap

__all__ = ["Stopwatch", "peak_memory"]

logger = logging.getLogger(__name__)


class Stopwatch:
    """Wall time per named stage, in the order the stages ran; a stage inside another pauses it.

    Each stage's end is logged, unless ``quiet`` (the work of a child beside this process).
    """

    def __init__(self, *, quiet: bool = False) -> None:
        self.quiet = quiet
        self.seconds: dict[str, float] = {}
        self._running: list[str] = []
        self._since = time.perf_counter()

    def _book(self) -> None:
        now = time.perf_counter()
        if self._running:
            name = self._running[-1]
            self.seconds[name] = self.seconds.get(name, 0.0) + now - self._since
        self._since = now

    @contextmanager
    def stage(self, name: str) -> Iterator[None]:
        """Time the ``with`` block as stage ``name`` (added to its earlier time, if any)."""
        self._book()
        self._running.append(name)
        self.seconds.setdefault(name, 0.0)
        try:
            yield
        finally:
            self._book()
            self._running.pop()
            release_free_heap()  # what the stage freed is not left idle beside the next one
            if not self.quiet:
                logger.info("stage %s: %.3f s (process CPU %.1f s, peak memory %s)", name,
                            self.seconds[name], time.process_time(), peak_memory())


def peak_memory() -> str:
    """Return the process's peak resident memory so far as text (``"n/a"`` off Unix)."""
    try:
        import resource
    except ImportError:
        return "n/a"
    kib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB on Linux
    return f"{kib / 1024:.0f} MiB"
