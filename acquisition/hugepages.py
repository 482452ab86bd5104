"""Allocate a large read's arrays without numpy's transparent-huge-page request.

NumPy asks Linux for transparent huge pages (``madvise(MADV_HUGEPAGE)``) on every array of 4 MiB
or more. With the kernel's default ``/sys/kernel/mm/transparent_hugepage/defrag = madvise`` such
regions may compact memory synchronously on their first touch, which made filling 1 GiB of new
float64 arrays several times slower on a loaded machine (measured in docs/performance.md,
*Reading as installed*). A reader that fills a gigabyte of fresh arrays once
gains nothing from huge pages, so :func:`plain_pages` switches the request off around the read.

The switch is NumPy's own (the one behind its documented ``NUMPY_MADVISE_HUGEPAGE`` environment
variable); when the user set that variable, their choice is kept. The setting is process-wide:
arrays other threads allocate during the read get plain pages too, which only changes their speed.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator
from contextlib import contextmanager

__all__ = ["plain_pages"]


def _switch() -> Callable[[bool], bool] | None:
    """Return NumPy's ``_set_madvise_hugepage`` (None where this NumPy has none)."""
    try:
        from numpy._core.multiarray import _set_madvise_hugepage
    except ImportError:  # numpy < 2
        try:
            from numpy.core.multiarray import _set_madvise_hugepage
        except ImportError:
            return None
    return _set_madvise_hugepage


@contextmanager
def plain_pages() -> Iterator[None]:
    """Within the block, new NumPy arrays do not request transparent huge pages."""
    switch = None if "NUMPY_MADVISE_HUGEPAGE" in os.environ else _switch()
    if switch is None:
        yield
        return
    previous = switch(False)
    try:
        yield
    finally:
        switch(previous)
