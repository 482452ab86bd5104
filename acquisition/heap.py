"""Give the memory a finished step freed back to the system (glibc's ``malloc_trim``).

Arrays below glibc's mmap threshold (which grows up to 32 MiB as large arrays are freed) live
on the C heap; when they are freed, their pages mostly stay with the process. A long run's next
step then allocates its large arrays anew beside those idle pages, so they add to the peak: on
an hour of data about 160 MiB at the end of the pipeline (docs/performance.md, *Memory of a
long record*). :func:`release_free_heap` asks glibc to hand free heap pages back
(``malloc_trim(0)``, which also releases free pages inside the heap); it changes no value and
costs milliseconds. Off glibc (macOS, Windows, musl) it does nothing.
"""

from __future__ import annotations

import ctypes
import logging

from rigval.acquisition.libc import libc_function

__all__ = ["release_free_heap"]

logger = logging.getLogger(__name__)


def release_free_heap() -> bool:
    """Return free C-heap pages to the system; True when some were released.

    Returns
    -------
    bool
        glibc's answer (False also where there is no ``malloc_trim``).
    """
    trim = libc_function("malloc_trim", (ctypes.c_size_t,), ctypes.c_int)
    if trim is None:
        return False
    released = bool(trim(0))
    logger.debug("malloc_trim: %s", "memory released" if released else "nothing to release")
    return released
