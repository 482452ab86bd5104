"""Functions of the C library that rigval calls directly (Linux only), each looked up once.

``malloc_trim`` hands freed heap pages back (:mod:`rigval.acquisition.heap`); ``madvise`` has
the kernel provide a mapped range's pages in one call, without holding the GIL as
``mmap.madvise`` does (:mod:`rigval.acquisition.hugepages`). They come from the C library this
process has loaded; off Linux, or where it lacks the function (musl has no ``malloc_trim``), the
caller gets None and goes without.
"""

from __future__ import annotations

import ctypes
import sys
from collections.abc import Callable
from functools import cache
from typing import Any

__all__ = ["libc_function"]


@cache
def libc_function(name: str, argtypes: tuple[Any, ...], restype: Any
                  ) -> Callable[..., Any] | None:
    """Return the C library's function ``name`` with its ctypes signature, or None.

    Parameters
    ----------
    name : str
        The function, e.g. ``"madvise"``.
    argtypes : tuple of ctypes types
        Its arguments' types.
    restype : ctypes type
        Its result's type.

    Returns
    -------
    callable or None
        The function (``ctypes.get_errno()`` holds its errno after a call), or None off Linux
        or where the C library has no such function.
    """
    if sys.platform != "linux":
        return None
    try:
        function = getattr(ctypes.CDLL(None, use_errno=True), name)
    except (OSError, AttributeError):
        return None
    function.argtypes, function.restype = list(argtypes), restype
    return function
