"""The huge-page switch around large reads is scoped and leaves a user's explicit choice alone."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from rigval.acquisition.hugepages import _switch, plain_pages

switch = _switch()
pytestmark = pytest.mark.skipif(switch is None, reason="this NumPy has no huge-page switch")


def test_switch_is_off_inside_and_restored_after() -> None:
    assert switch is not None
    before = switch(True)
    try:
        with plain_pages():
            assert switch(False) is False  # plain_pages had switched the request off
        assert switch(True) is True  # and put back what was there
    finally:
        switch(before)


def test_an_explicit_numpy_setting_is_kept(monkeypatch: pytest.MonkeyPatch) -> None:
    assert switch is not None
    monkeypatch.setenv("NUMPY_MADVISE_HUGEPAGE", "1")
    before = switch(True)
    try:
        with plain_pages():
            assert switch(True) is True
    finally:
        switch(before)


def test_mapped_arrays_are_plain_writable_arrays_and_populate_keeps_values() -> None:
    from rigval.acquisition.hugepages import MAPPED_BYTES, mapped_empty, populate

    small = mapped_empty(10, "<f8")
    assert small.base is None and small.size == 10  # numpy.empty
    n = MAPPED_BYTES // 4 + 1001
    big = mapped_empty(n, "<i4")
    assert big.shape == (n,) and big.dtype == np.dtype("<i4") and big.flags.writeable
    big[:] = np.arange(n, dtype=np.int32)
    populate(big, 1, n - 7)  # pages already written keep their values
    populate(big, 5, 5)
    np.testing.assert_array_equal(big, np.arange(n, dtype=np.int32))
    part = mapped_empty(n, "<f8")
    populate(part, n // 3, n // 2)
    part[n // 3:n // 2] = 2.5
    assert float(part[n // 3:n // 2].sum()) == 2.5 * (n // 2 - n // 3)


def _resident_kib() -> int:
    """Return this process's resident memory (``VmRSS``), KiB."""
    with open("/proc/self/status") as status:
        return int(next(line for line in status if line.startswith("VmRSS:")).split()[1])


@pytest.mark.skipif(sys.platform != "linux", reason="MADV_POPULATE_WRITE is Linux's")
def test_populate_makes_the_pages_resident_before_they_are_written() -> None:
    from rigval.acquisition import hugepages
    from rigval.acquisition.hugepages import is_mapped, mapped_empty, populate

    n = 64 << 17  # 64 MiB of float64
    array = mapped_empty(n, "<f8")
    assert is_mapped(array) and not is_mapped(np.empty(n, "<f8"))
    before = _resident_kib()
    populate(array, n // 4, n // 4 + (32 << 17))  # 32 MiB in the middle
    if not hugepages._populate_works[0]:
        pytest.skip("this kernel has no MADV_POPULATE_WRITE (before 5.14)")
    grown = _resident_kib() - before
    assert 31 << 10 <= grown <= 40 << 10  # the 32 MiB asked for (KiB), not the whole map
    assert not array[n // 4:n // 4 + (32 << 17)].any()  # new pages read as zeros


# /proc/buddyinfo as Linux prints it: free blocks of 2**k pages for k = 0..10, per zone.
BUDDYINFO = """\
Node 0, zone      DMA      0      0      0      0      0      0      0      0      1      1      3
Node 0, zone    DMA32      1      2      4      2      5      4      3      3      4      2    752
Node 0, zone   Normal    729  10332  14193   7052   3425   1266    432    179     41    120   2069
"""


def test_free_block_bytes_adds_the_blocks_of_huge_page_size_and_more() -> None:
    from rigval.acquisition.hugepages import free_block_bytes

    mib = 1 << 20
    # DMA32 + Normal, order 9 (2 MiB) and 10 (4 MiB); the DMA zone is left out
    expected = (2 + 120) * 2 * mib + (752 + 2069) * 4 * mib
    assert free_block_bytes(BUDDYINFO, 2 * mib, 4096) == expected
    # from order 8 (1 MiB) on: plus those blocks
    assert free_block_bytes(BUDDYINFO, mib, 4096) == expected + (4 + 41) * mib
    # 64 KiB base pages: every order is 16 times larger, so orders 5.. count for 2 MiB
    big = sum(c * (65536 << k) for line in BUDDYINFO.splitlines()[1:]
              for k, c in enumerate(map(int, line.split()[4:])) if k >= 5)
    assert free_block_bytes(BUDDYINFO, 2 * mib, 65536) == big
    assert free_block_bytes("", 2 * mib, 4096) == 0


def test_huge_pages_only_when_free_blocks_cover_margin_reserve_and_nothing_forbids() -> None:
    from rigval.acquisition.hugepages import (
        HUGE_MARGIN,
        HUGE_RESERVE,
        free_block_bytes,
        huge_pages_fit,
    )

    free = free_block_bytes(BUDDYINFO, 2 << 20, 4096)  # 11,528 MiB
    limit = int((free - HUGE_RESERVE) / HUGE_MARGIN)
    assert huge_pages_fit(limit, BUDDYINFO)
    assert not huge_pages_fit(limit + 4096, BUDDYINFO)
    assert huge_pages_fit(1 << 30, BUDDYINFO)
    assert not huge_pages_fit(1 << 30, BUDDYINFO, thp_enabled="always madvise [never]")
    assert huge_pages_fit(1 << 30, BUDDYINFO, thp_enabled="[always] madvise never")
    # blocks of 2 MiB and more handed back to a hypervisor when free: cold memory, no
    assert not huge_pages_fit(1 << 30, BUDDYINFO, reported_order=9)
    assert not huge_pages_fit(1 << 30, BUDDYINFO, reported_order=5)
    assert huge_pages_fit(1 << 30, BUDDYINFO, reported_order=10)  # 2 MiB blocks stay backed
    # a fragmented machine: the same free memory in 1 MiB blocks and smaller
    fragmented = f"Node 0, zone   Normal  0 0 0 0 0 0 0 0 {free >> 20} 0 0\n"
    assert free_block_bytes(fragmented, 1 << 20, 4096) == free
    assert not huge_pages_fit(1 << 20, fragmented)


def test_numpy_setting_decides_huge_pages(monkeypatch: pytest.MonkeyPatch) -> None:
    from rigval.acquisition.hugepages import use_huge_pages

    monkeypatch.setenv("NUMPY_MADVISE_HUGEPAGE", "1")
    assert use_huge_pages(1 << 30)
    monkeypatch.setenv("NUMPY_MADVISE_HUGEPAGE", "0")
    assert not use_huge_pages(1 << 30)


def test_huge_page_arrays_start_on_a_huge_page_and_hold_what_is_written() -> None:
    from rigval.acquisition.hugepages import MAPPED_BYTES, mapped_empty, populate

    n = MAPPED_BYTES // 8 * 3 + 5
    huge = mapped_empty(n, "<f8", huge=True)
    plain = mapped_empty(n, "<f8", huge=False)
    assert huge.shape == plain.shape == (n,) and huge.flags.writeable
    assert huge.ctypes.data % (2 << 20) == 0
    values = np.random.default_rng(1).normal(size=n)
    for array in (huge, plain):
        for lo in range(0, n, 100_003):  # populate each piece right before writing it
            populate(array, lo, min(n, lo + 100_003))
            array[lo:lo + 100_003] = values[lo:lo + 100_003]
    np.testing.assert_array_equal(huge, values)
    np.testing.assert_array_equal(plain, values)
