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

:func:`mapped_empty` and :func:`populate` go one step further for arrays a reader fills
piece by piece: each piece's pages are provided by the kernel in one call
(``MADV_POPULATE_WRITE``, Linux 5.14 and later) right before the piece is read into them, instead
of one page fault per 4 KiB during the copy, which on this machine (a virtual machine, where each
fault is costly) cut the CPU time of reading a gigabyte into new memory by about a third
(docs/performance.md, *Reading as installed*); pages provided piece by piece rather than all at
once let a hash running in another thread start on the first pieces at once.

Huge pages when they cost nothing. Backing the arrays with 2 MiB transparent huge pages
(``MADV_HUGEPAGE``) makes the kernel provide a gigabyte of new memory about 2.5 times faster than
4 KiB pages do (512 times fewer pages to clear and map), but only while it has free 2 MiB blocks
at hand: without them, ``defrag = madvise`` makes the first touch compact memory synchronously,
which once stalled a 1 GiB read for 3.5 s. Linux lists its free blocks per size ("order": block
of ``2**order`` pages) and memory zone in ``/proc/buddyinfo``; a free block of order >= 9 (2 MiB
with 4 KiB pages) is a huge page ready to hand out without compaction. :func:`use_huge_pages`
therefore asks for huge pages only when the free blocks of at least huge-page size hold
:data:`HUGE_MARGIN` times the bytes to read plus :data:`HUGE_RESERVE` (room for other processes,
or parallel reads, taking blocks meanwhile), and the kernel's
``/sys/kernel/mm/transparent_hugepage/enabled`` is not ``never``; otherwise, and outside Linux, the
arrays get 4 KiB pages as above. A user's ``NUMPY_MADVISE_HUGEPAGE`` (``0`` or ``1``) decides
instead when set. The decision is logged at DEBUG level.

Free blocks are not always ready memory, though. In a virtual machine whose balloon device
reports free pages to the host (``VIRTIO_BALLOON_F_REPORTING``; Linux's ``page_reporting``), free
blocks of ``page_reporting_order`` (9 by default) and above are handed back to the host, and the
first touch of such a block makes the host provide its memory again: on the machine of
docs/performance.md a 1 GiB read into huge pages then took about 3 s of system time (no
compaction: ``compact_stall`` stayed 0) against 0.7 s with 4 KiB pages, which come partly from
small free blocks the host still backs. :func:`use_huge_pages` therefore also says no when free
blocks of huge-page size are reported to a host.
"""

from __future__ import annotations

import ctypes
import glob
import logging
import mmap
import os
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import numpy as np

from rigval.acquisition.libc import libc_function

__all__ = ["HUGE_MARGIN", "HUGE_RESERVE", "MAPPED_BYTES", "free_block_bytes", "huge_pages_fit",
           "is_mapped", "mapped_empty", "plain_pages", "populate", "use_huge_pages"]

logger = logging.getLogger(__name__)

#: Arrays at least this large get their own memory map (smaller ones: ``numpy.empty``).
MAPPED_BYTES = 1 << 22
#: ``MADV_POPULATE_WRITE`` of Linux's ``asm-generic/mman-common.h`` (no constant in Python 3.11).
_MADV_POPULATE_WRITE = 23
_populate_works = [sys.platform == "linux"]
#: Free blocks of huge-page size or more must hold this multiple of the bytes to read ...
HUGE_MARGIN = 2.0
#: ... plus this many bytes (MiB 512), else the read gets 4 KiB pages.
HUGE_RESERVE = 512 << 20
#: Alignment of huge-page arrays (the x86-64 and arm64 huge page; larger ones are aligned less).
_HUGE_BYTES = 2 << 20
_BUDDYINFO = "/proc/buddyinfo"
_THP = "/sys/kernel/mm/transparent_hugepage"


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


def free_block_bytes(buddyinfo: str, block_bytes: int, page_bytes: int) -> int:
    """Return the bytes free in blocks of at least ``block_bytes``, from ``/proc/buddyinfo`` text.

    Each line reads ``Node <n>, zone <name> <c0> <c1> ...``: ``c_k`` free blocks of ``2**k``
    pages. The ``DMA`` zone (the first 16 MiB, kept for old devices) is left out.

    Parameters
    ----------
    buddyinfo : str
        The text of ``/proc/buddyinfo``.
    block_bytes : int
        Smallest block counted (the huge-page size), bytes.
    page_bytes : int
        The base page size, bytes.

    Returns
    -------
    int
        Sum over zones and orders ``k`` with ``2**k * page_bytes >= block_bytes`` of
        ``c_k * 2**k * page_bytes``, bytes.
    """
    total = 0
    for line in buddyinfo.splitlines():
        words = line.replace(",", " ").split()
        if len(words) < 5 or words[0] != "Node" or words[2] != "zone" or words[3] == "DMA":
            continue
        for order, count in enumerate(words[4:]):
            size = page_bytes << order
            if size >= block_bytes:
                total += int(count) * size
    return total


def huge_pages_fit(nbytes: int, buddyinfo: str, *, block_bytes: int = 2 << 20,
                   page_bytes: int = 4096, thp_enabled: str = "always [madvise] never",
                   reported_order: int | None = None) -> bool:
    """Decide whether ``nbytes`` of new arrays can get huge pages without memory compaction.

    Parameters
    ----------
    nbytes : int
        Bytes of the arrays.
    buddyinfo : str
        The text of ``/proc/buddyinfo``.
    block_bytes : int
        The huge-page size, bytes.
    page_bytes : int
        The base page size, bytes.
    thp_enabled : str
        The text of ``/sys/kernel/mm/transparent_hugepage/enabled`` (chosen value in brackets).
    reported_order : int, optional
        Free blocks of this order and above are reported to a hypervisor (None: no reporting).

    Returns
    -------
    bool
        True if huge pages are enabled, free blocks of huge-page size are not reported to a
        hypervisor, and the free blocks of at least ``block_bytes`` hold
        :data:`HUGE_MARGIN` x ``nbytes`` + :data:`HUGE_RESERVE`.
    """
    if "[never]" in thp_enabled:
        return False
    if reported_order is not None and page_bytes << reported_order <= block_bytes:
        return False
    return free_block_bytes(buddyinfo, block_bytes, page_bytes) >= \
        HUGE_MARGIN * nbytes + HUGE_RESERVE


def _read_text(path: str) -> str | None:
    """Return a small system file's text, None if it cannot be read."""
    try:
        with open(path, encoding="ascii") as handle:
            return handle.read()
    except (OSError, UnicodeDecodeError):
        return None


def _reported_order() -> int | None:
    """Return the order from which free blocks go back to a hypervisor, None if they do not.

    Reporting happens when a virtio balloon (device id 5) negotiated feature bit 5
    (``VIRTIO_BALLOON_F_REPORTING``); the order is Linux's ``page_reporting_order`` (9 if the
    parameter is not readable).
    """
    for device in glob.glob("/sys/bus/virtio/devices/*"):
        kind, features = _read_text(f"{device}/device"), _read_text(f"{device}/features")
        if kind is not None and kind.strip() == "0x0005" and features is not None \
                and features[5:6] == "1":
            order = _read_text("/sys/module/page_reporting/parameters/page_reporting_order")
            return int(order) if order is not None and order.strip().isdigit() else 9
    return None


def use_huge_pages(nbytes: int) -> bool:
    """Decide whether a read of ``nbytes`` into new arrays should ask for huge pages.

    ``NUMPY_MADVISE_HUGEPAGE`` decides when set (an integer, non-zero: yes); otherwise
    :func:`huge_pages_fit` on this system's free memory; False outside Linux or where the
    kernel's files cannot be read. Logs the decision and its reason at DEBUG level.

    Parameters
    ----------
    nbytes : int
        Bytes of the arrays the read fills, bytes.
    """
    choice = os.environ.get("NUMPY_MADVISE_HUGEPAGE")
    if choice is not None:
        try:
            huge = int(choice) != 0
        except ValueError:
            huge = False
        logger.debug("huge pages %s: NUMPY_MADVISE_HUGEPAGE=%r", "on" if huge else "off", choice)
        return huge
    if sys.platform != "linux" or nbytes < MAPPED_BYTES:
        return False
    buddyinfo = _read_text(_BUDDYINFO)
    enabled = _read_text(f"{_THP}/enabled")
    block = _read_text(f"{_THP}/hpage_pmd_size")
    if buddyinfo is None or enabled is None or block is None or not block.strip().isdigit():
        logger.debug("huge pages off: %s or %s not readable", _BUDDYINFO, _THP)
        return False
    block_bytes = int(block)
    reported = _reported_order()
    huge = huge_pages_fit(nbytes, buddyinfo, block_bytes=block_bytes,
                          page_bytes=mmap.PAGESIZE, thp_enabled=enabled, reported_order=reported)
    logger.debug("huge pages %s for %d bytes: %d bytes free in blocks of >= %d bytes, "
                 "enabled: %s, free blocks from order %s reported to a hypervisor",
                 "on" if huge else "off", nbytes,
                 free_block_bytes(buddyinfo, block_bytes, mmap.PAGESIZE), block_bytes,
                 enabled.strip(), reported)
    return huge


def mapped_empty(count: int, dtype: np.dtype | str, huge: bool = False) -> np.ndarray:
    """Return a new, writable 1-D array of ``count`` values, for :func:`populate`.

    Large arrays live in an anonymous private memory map (freed with the last array referring
    to it); small ones, and systems without anonymous maps, get ``numpy.empty``. The values are
    undefined, as with ``numpy.empty``.

    Parameters
    ----------
    count : int
        Number of values.
    dtype : numpy.dtype or str
        Their type.
    huge : bool
        Ask for transparent huge pages (``MADV_HUGEPAGE``; see :func:`use_huge_pages`): the map
        then starts one huge page early so that the array can begin on a huge-page boundary.
    """
    dtype = np.dtype(dtype)
    nbytes = count * dtype.itemsize
    if nbytes < MAPPED_BYTES or not hasattr(mmap, "MAP_ANONYMOUS"):
        return np.empty(count, dtype=dtype)
    block = _HUGE_BYTES if huge and hasattr(mmap, "MADV_HUGEPAGE") else 0
    area = mmap.mmap(-1, nbytes + block, flags=mmap.MAP_PRIVATE | mmap.MAP_ANONYMOUS)
    offset = 0
    if block:
        try:
            area.madvise(mmap.MADV_HUGEPAGE)
        except OSError as error:  # kernel without transparent huge pages
            logger.debug("MADV_HUGEPAGE refused (%s): 4 KiB pages", error)
        address = np.frombuffer(area, dtype=np.uint8, count=1).ctypes.data
        offset = -address % block
    return np.frombuffer(area, dtype=dtype, count=count, offset=offset)


def is_mapped(array: np.ndarray) -> bool:
    """Return True if ``array`` lives in a memory map of :func:`mapped_empty`."""
    base = array.base
    if isinstance(base, memoryview):  # NumPy 2 keeps the buffer's memoryview as the base
        base = base.obj
    return isinstance(base, mmap.mmap)


def populate(array: np.ndarray, start: int, stop: int) -> None:
    """Have the kernel provide the pages of values ``start`` to ``stop - 1`` now, in one call.

    Does nothing for arrays not made by :func:`mapped_empty` with a memory map, and where the
    kernel lacks ``MADV_POPULATE_WRITE`` (the pages then come one fault at a time, as usual).
    The call releases the GIL.

    Parameters
    ----------
    array : numpy.ndarray
        From :func:`mapped_empty`.
    start, stop : int
        Range of values about to be written.
    """
    call = (libc_function("madvise", (ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int),
                          ctypes.c_int) if _populate_works[0] else None)
    if call is None or stop <= start or not is_mapped(array):
        return
    page = mmap.PAGESIZE
    # the map starts on a page and its last page is whole, so the rounded range stays inside it
    first = (array.ctypes.data + start * array.itemsize) // page * page
    end = -(-(array.ctypes.data + stop * array.itemsize) // page) * page
    if call(first, end - first, _MADV_POPULATE_WRITE) != 0:  # kernels before 5.14: EINVAL
        _populate_works[0] = False
        logger.debug("MADV_POPULATE_WRITE not available (%s): pages come on first touch",
                     os.strerror(ctypes.get_errno()))
