"""Read plain TDMS raw data straight into the output arrays, hashing the file in the same pass.

Most TDMS files written by LabVIEW or ``nptdms`` store each channel's values of a segment as one
contiguous run of little-endian numbers. For such files :func:`read_plain` needs no parser of
the raw data: the segment records of :func:`~rigval.acquisition.tdms_layout.scan_tdms` say
where every value lies, so the selected values are read with ``readinto`` into a view of the
preallocated output array (no chunk objects, no second copy), and every byte of the file
(lead-ins, metadata, unselected data and the selected values themselves, in file order) goes to a
SHA-256 running in a second thread (:class:`~rigval.acquisition.hashing.ThreadedSha256`).
The file is read once; the digest equals that of ``sha256sum``.

:func:`plain_selection` decides whether a read qualifies; DAQmx raw data is then tried by
:mod:`rigval.acquisition.tdms_daqmx`, and everything else (interleaved segments, big-endian
segments, channels nptdms scales, a channel whose type changes between segments) is left to
nptdms by the caller.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

import numpy as np

from rigval.acquisition.errors import DataFileError
from rigval.acquisition.hashing import ThreadedSha256
from rigval.acquisition.hugepages import mapped_empty, populate, use_huge_pages
from rigval.acquisition.tdms_layout import (
    TOC_BIG_ENDIAN,
    TOC_DAQMX,
    TOC_INTERLEAVED,
    TYPE_SIZES,
    DataSegment,
    TdmsLayout,
    object_path_parts,
)
from rigval.acquisition.tdms_log import captured_nptdms_messages

__all__ = ["PlainChannel", "direct_read", "plain_selection", "raise_short", "read_exactly",
           "read_plain", "rest_digest", "skip_to"]

logger = logging.getLogger(__name__)

#: TDMS type code -> little-endian NumPy dtype of the values nptdms returns unscaled.
PLAIN_DTYPES = {1: "<i1", 2: "<i2", 3: "<i4", 4: "<i8", 5: "<u1", 6: "<u2", 7: "<u4", 8: "<u8",
                9: "<f4", 10: "<f8", 0x19: "<f4", 0x1A: "<f8"}
#: Size of the reading buffer: small pieces (lead-ins, short runs) are served from it.
_BUFFER_BYTES = 1 << 18


@dataclass(frozen=True)
class PlainChannel:
    """One channel to read: its values ``start`` to ``stop - 1`` go to a new array.

    Attributes
    ----------
    path : str
        TDMS object path.
    dtype : numpy.dtype
        Type of the stored (and returned) values.
    start, stop : int
        Range of value indexes to keep.
    """

    path: str
    dtype: np.dtype
    start: int
    stop: int


def _unscaled(layout: TdmsLayout, path: str) -> bool:
    """Return True if nptdms returns the channel's stored values as they are (no scaling)."""
    from nptdms.scaling import get_scaling

    group = object_path_parts(path)[0]
    with captured_nptdms_messages():  # an unsupported scale is warned about by rigval itself
        scaling = get_scaling(layout.channels[path].properties,
                              layout.group_properties.get(group, {}), layout.root_properties)
    return scaling is None


def plain_selection(layout: TdmsLayout,
                    ranges: Mapping[str, tuple[int, int]]) -> list[PlainChannel] | None:
    """Return the channels to read directly, or None if nptdms must read them.

    Parameters
    ----------
    layout : TdmsLayout
        From :func:`~rigval.acquisition.tdms_layout.scan_tdms`.
    ranges : mapping of str to (int, int)
        Object path -> range of value indexes ``(start, stop)`` wanted.

    Returns
    -------
    list of PlainChannel or None
        None when a wanted channel lies in an interleaved, big-endian or DAQmx segment, has a
        type other than a fixed-size number, changes type, or is scaled by nptdms; also when the
        segment records do not account for exactly the values the scan counted.
    """
    wanted = set(ranges)
    for path in wanted:
        channel = layout.channels[path]
        if channel.data_type not in PLAIN_DTYPES or not _unscaled(layout, path):
            logger.debug("%s: %s needs nptdms (type %s or scaled)", layout.path, path,
                         channel.data_type)
            return None
    counted = dict.fromkeys(wanted, 0)
    checked: set[tuple[int, int]] = set()
    for segment in layout.data_segments:
        key = (id(segment.objects), segment.toc)  # the tuples live as long as the layout
        if key not in checked:
            if not _plain_segment(segment, layout, wanted):
                logger.debug("%s: segment at byte %d needs nptdms", layout.path,
                             segment.data_start)
                return None
            checked.add(key)
        for path, count, _ in _runs(segment):
            if path in counted:
                counted[path] += count
    if any(counted[p] != layout.channels[p].length for p in wanted):
        logger.debug("%s: segment records count %s values, the scan %s", layout.path, counted,
                     {p: layout.channels[p].length for p in wanted})
        return None
    return [PlainChannel(p, np.dtype(PLAIN_DTYPES[layout.channels[p].data_type]), *ranges[p])
            for p in ranges]


def _plain_segment(segment: DataSegment, layout: TdmsLayout, wanted: set[str]) -> bool:
    """Return True if the segment's runs can be located without nptdms."""
    holders = [(p, i) for p, i in segment.objects if i is not None and i.n_values]
    if not any(p in wanted for p, _ in holders):
        return True  # its bytes are only hashed (or skipped)
    if segment.toc & (TOC_INTERLEAVED | TOC_BIG_ENDIAN | TOC_DAQMX):
        return False
    for path, index in holders:
        if index.widths or index.data_type not in PLAIN_DTYPES:
            return False  # strings, timestamps, DAQmx: sizes nptdms alone knows
        if path in wanted and index.data_type != layout.channels[path].data_type:
            return False
    return True


def _runs(segment: DataSegment) -> Iterator[tuple[str, int, int]]:
    """Yield ``(object path, values, byte offset)`` of each contiguous run of values, in order.

    A segment's raw data is a sequence of equal chunks; in each, every object with data holds
    ``n_values`` consecutive values. The last chunk of a truncated segment holds whole values
    only, object after object (as the scan counts them).
    """
    holders = [(p, i) for p, i in segment.objects if i is not None and i.n_values]
    if not holders:
        return
    if segment.toc & (TOC_INTERLEAVED | TOC_DAQMX) or any(
            i.widths or i.data_type not in PLAIN_DTYPES for _, i in holders):
        return  # not located here: plain_selection sends such files to nptdms
    position = segment.data_start
    while position < segment.data_end:
        for path, index in holders:
            size = TYPE_SIZES[index.data_type]
            take = min(index.n_values, (segment.data_end - position) // size)
            if take:
                yield path, take, position
            position += take * size
            if take < index.n_values:
                return


def _targets(layout: TdmsLayout, channels: Sequence[PlainChannel],
             out: Mapping[str, np.ndarray]) -> Iterator[tuple[int, memoryview]]:
    """Yield ``(byte offset, destination)`` for every wanted piece of a run, in file order."""
    ranges = {c.path: (c.start, c.stop, c.dtype.itemsize) for c in channels}
    seen = dict.fromkeys(ranges, 0)
    for segment in layout.data_segments:
        for path, count, offset in _runs(segment):
            if path not in ranges:
                continue
            first = seen[path]
            seen[path] = first + count
            start, stop, size = ranges[path]
            lo, hi = max(first, start), min(first + count, stop)
            if lo < hi:
                populate(out[path], lo - start, hi - start)
                destination = out[path][lo - start:hi - start]
                yield offset + (lo - first) * size, memoryview(destination).cast("B")


def read_plain(file: Path, layout: TdmsLayout, channels: Sequence[PlainChannel],
               checksum: bool) -> tuple[dict[str, np.ndarray], str | None]:
    """Read the selected values of plain segments in one pass, hashing the file on the way.

    Parameters
    ----------
    file : pathlib.Path
        The ``.tdms`` file.
    layout : TdmsLayout
        Its structure (from :func:`~rigval.acquisition.tdms_layout.scan_tdms`).
    channels : sequence of PlainChannel
        From :func:`plain_selection`.
    checksum : bool
        Hash every byte of the file (to its end, damaged tail included).

    Returns
    -------
    values : dict of str to numpy.ndarray
        Object path -> the values ``start`` to ``stop - 1``.
    sha256 : str or None
        Hex digest of the whole file, None without ``checksum``.

    Raises
    ------
    DataFileError
        If the file cannot be read or ends before the values the scan found (it changed).
    """
    huge = use_huge_pages(sum((c.stop - c.start) * c.dtype.itemsize for c in channels))
    out = {c.path: mapped_empty(c.stop - c.start, c.dtype, huge) for c in channels}
    with direct_read(file, layout.file_size, checksum, _BUFFER_BYTES) as (handle, hasher):
        position = 0
        for offset, destination in _targets(layout, channels, out):
            if offset > position:
                position = skip_to(handle, hasher, position, offset, file)
            read_exactly(handle, destination, file, offset)
            if hasher is not None:
                hasher.feed(destination)
            position += len(destination)
        logger.debug("%s: read %d values directly", file, sum(a.size for a in out.values()))
        return out, rest_digest(handle, hasher)


@contextmanager
def direct_read(file: Path, file_size: int, checksum: bool, buffering: int
                ) -> Iterator[tuple[BinaryIO, ThreadedSha256 | None]]:
    """Open ``file`` for a direct read, with the SHA-256 thread of its bytes when ``checksum``.

    Errors reading the file become a DataFileError; the thread ends with the block.

    Parameters
    ----------
    file : pathlib.Path
        The file.
    file_size : int
        Its size in bytes as scanned (the hasher's total).
    checksum : bool
        Start the SHA-256 thread (None in its place otherwise).
    buffering : int
        ``open``'s buffer size in bytes (0: unbuffered).
    """
    hasher = ThreadedSha256(file_size) if checksum else None
    try:
        with open(file, "rb", buffering=buffering) as handle:
            yield handle, hasher
    except OSError as error:
        raise DataFileError(f"cannot read the file: {error}", where={"file": str(file)},
                            hint="check that the file is readable and not being replaced"
                            ) from error
    finally:
        if hasher is not None:
            hasher.close()


def skip_to(handle: BinaryIO, hasher: ThreadedSha256 | None, position: int, offset: int,
            file: Path) -> int:
    """Move a direct read on from byte ``position`` to ``offset``, hashing the bytes between.

    Returns ``offset``; raises the DataFileError of :func:`raise_short` if the file ends first.
    """
    if hasher is None:
        handle.seek(offset)
    elif hasher.read_from(handle, offset - position) < offset - position:
        raise_short(file, offset)
    return offset


def rest_digest(handle: BinaryIO, hasher: ThreadedSha256 | None) -> str | None:
    """Hash the file from the read's position to its end; return the digest (None: no hasher)."""
    if hasher is None:
        return None
    hasher.read_from(handle, None)
    logger.debug("hashed %d bytes", hasher.fed)
    return hasher.hexdigest()


def read_exactly(handle: BinaryIO, destination: memoryview, file: Path, offset: int) -> None:
    """Fill ``destination`` from ``handle``; a short read means the file shrank."""
    done = 0
    while done < len(destination):
        got = handle.readinto(destination[done:]) or 0
        if got == 0:
            raise_short(file, offset + done)
        done += got


def raise_short(file: Path, offset: int) -> None:
    """Raise the error for a file that ends before bytes its scan found."""
    raise DataFileError(f"the file ends at byte {offset}, before data its metadata located "
                        f"(size now {os.stat(file).st_size} bytes)", where={"file": str(file)},
                        hint="the file changed while it was read; read it again once complete")
