"""Walk a TDMS file's segment metadata without reading its data.

nptdms reads and scales the data; it keeps only the *last* value of each property, so a task
restart written as a new segment with a new ``wf_start_time`` is invisible through it, and it says
little about how much of a truncated file was recovered. This module reads the lead-ins and the
metadata of every segment (seeking over raw data) and returns, per channel, how many values each
segment holds, the time properties each segment sets, and where the readable part of the file ends.

Format: NI "TDMS File Format Internal Structure": a file is a sequence of segments, each a 28-byte
lead-in (``TDSm``, ToC mask, version, next-segment offset, raw-data offset), optional metadata
(objects with raw-data indexes and properties) and raw data made of equal chunks.

Any damage (bad tag, impossible sizes, unreadable metadata) ends the walk at the last whole
segment; the damage is described in :attr:`TdmsLayout.problem` and never raised as
``struct.error`` or ``IndexError``.
"""

from __future__ import annotations

import logging
import os
import re
import struct
from array import array
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from rigval.acquisition.errors import DataFileError

__all__ = ["ChannelLayout", "DataSegment", "TdmsLayout", "TdmsStamp", "kept_layouts",
           "object_path_parts", "scan_tdms"]

logger = logging.getLogger(__name__)

LEAD_IN_BYTES = 28
TOC_META_DATA = 1 << 1
TOC_NEW_OBJ_LIST = 1 << 2
TOC_RAW_DATA = 1 << 3
TOC_INTERLEAVED = 1 << 5
TOC_BIG_ENDIAN = 1 << 6
TOC_DAQMX = 1 << 7
NO_DATA = 0xFFFFFFFF
SAME_AS_PREVIOUS = 0x00000000
DAQMX_FORMAT_CHANGING = 0x00001269
DAQMX_DIGITAL_LINE = 0x0000126A
STRING_TYPE = 0x20
DAQMX_TYPE = 0xFFFFFFFF
UNKNOWN_SIZE = 0xFFFFFFFFFFFFFFFF
#: Seconds from 1904-01-01 (TDMS epoch) to 1970-01-01 (Unix epoch).
EPOCH_1904_TO_1970_S = 2_082_844_800
TIME_PROPERTIES = ("wf_start_time", "wf_start_offset", "wf_increment")

#: Size in bytes of each TDMS data type with a fixed size (type code -> bytes).
TYPE_SIZES = {0: 0, 1: 1, 2: 2, 3: 4, 4: 8, 5: 1, 6: 2, 7: 4, 8: 8, 9: 4, 10: 8, 11: 16,
              0x19: 4, 0x1A: 8, 0x1B: 16, 0x21: 1, 0x44: 16, 0x08000C: 8, 0x10000D: 16}
_PROPERTY_FORMATS = {1: "b", 2: "h", 3: "i", 4: "q", 5: "B", 6: "H", 7: "I", 8: "Q", 9: "f",
                     10: "d", 0x19: "f", 0x1A: "d", 0x21: "?"}
_PATH_PART = re.compile(r"'((?:[^']|'')*)'")


class _Damaged(Exception):
    """Internal: the metadata cannot be parsed; carries the reason."""


@dataclass(frozen=True)
class TdmsStamp:
    """A TDMS time stamp: seconds since 1904-01-01 UTC plus fractions of 2**-64 s."""

    seconds: int
    fraction: int

    def is_zero(self) -> bool:
        """Return True for 1904-01-01 00:00:00, LabVIEW's mark of a relative time axis."""
        return self.seconds == 0 and self.fraction == 0

    def in_range(self) -> bool:
        """Return True if the stamp fits ``datetime64[ns]`` (years 1678 to 2261)."""
        return -9_200_000_000 < self.seconds - EPOCH_1904_TO_1970_S < 9_200_000_000

    def to_datetime64(self) -> np.datetime64:
        """Return the stamp as naive UTC ``datetime64[ns]`` (sub-ns fraction rounded)."""
        ns = (self.seconds - EPOCH_1904_TO_1970_S) * 1_000_000_000
        ns += (self.fraction * 1_000_000_000 + (1 << 63)) >> 64
        return np.datetime64(ns, "ns")

    def seconds_since(self, other: TdmsStamp) -> float:
        """Return ``self - other`` in s, exact to about 1e-16 s before rounding to float."""
        whole = self.seconds - other.seconds
        return whole + (self.fraction - other.fraction) / 2.0**64


@dataclass
class ChannelLayout:
    """What the metadata says about one channel.

    Attributes
    ----------
    path : str
        TDMS object path ``/'group'/'channel'``.
    properties : dict
        Properties after the last segment (later segments override earlier ones).
    data_type : int or None
        TDMS type code of the stored values (``0xFFFFFFFF`` for DAQmx raw data).
    counts : array.array of int
        Values per segment holding data of this channel, in file order (8 bytes a segment,
        where a list holds an int object: a 1-hour DAQmx file has 35,000 segments).
    expected : array.array of int
        Values per segment the lead-ins announce (differs from ``counts`` when truncated).
    time_marks : list of tuple
        ``(value_index, {name: value})`` for every segment that sets ``wf_start_time``,
        ``wf_start_offset`` or ``wf_increment``; ``value_index`` is the number of values before
        that segment's data.
    """

    path: str
    properties: dict[str, Any] = field(default_factory=dict)
    data_type: int | None = None
    counts: array[int] = field(default_factory=lambda: array("q"))
    expected: array[int] = field(default_factory=lambda: array("q"))
    time_marks: list[tuple[int, dict[str, Any]]] = field(default_factory=list)

    @property
    def length(self) -> int:
        """Number of values readable from the file."""
        return sum(self.counts)

    @property
    def expected_length(self) -> int:
        """Number of values the segment lead-ins announce."""
        return sum(self.expected)


@dataclass
class TdmsLayout:
    """The segment structure of a TDMS file.

    Attributes
    ----------
    path : pathlib.Path
        The file.
    file_size : int
        Bytes.
    version : int
        TDMS version of the first segment (4712 or 4713).
    big_endian : bool
        True if the first segment is big-endian.
    segments : int
        Number of segments read.
    daqmx : bool
        True if any segment holds DAQmx raw data.
    good_end : int
        Byte offset up to which the file is readable (``file_size`` for a sound file).
    problem : str or None
        What is wrong with the file (truncated or damaged), None for a sound file.
    notes : list of str
        Damage that does not end the walk (a property string that is not UTF-8, a ToC that
        denies raw data the segment holds); each is read as nptdms reads it and warned about.
    root_properties : dict
        Properties of the root object ``/``.
    group_properties : dict
        Group name -> properties.
    channels : dict
        Object path -> :class:`ChannelLayout`, in file order.
    data_segments : list of DataSegment
        Every segment whose raw data was counted, in file order (where each value lies).
    """

    path: Path
    file_size: int
    version: int = 0
    big_endian: bool = False
    segments: int = 0
    daqmx: bool = False
    good_end: int = 0
    problem: str | None = None
    notes: list[str] = field(default_factory=list)
    root_properties: dict[str, Any] = field(default_factory=dict)
    group_properties: dict[str, dict[str, Any]] = field(default_factory=dict)
    channels: dict[str, ChannelLayout] = field(default_factory=dict)
    data_segments: list[DataSegment] = field(default_factory=list)
    #: object list of the last metadata read, shared by the data segments that reuse it
    _objects: tuple[tuple[str, _Index | None], ...] | None = field(default=None, repr=False)


@dataclass(frozen=True)
class _Index:
    """Raw-data index of one object in one segment (shared by the segments that repeat it)."""

    data_type: int
    n_values: int
    byte_size: int  # bytes per chunk for this object (0 for DAQmx: see widths)
    widths: tuple[int, ...] = ()
    buffers: tuple[int, ...] = ()
    #: DAQmx scalers: ``(DAQmx type code, raw buffer index, byte offset in the row, scale id)``
    #: (the offset is in bits for digital line scalers).
    scalers: tuple[tuple[int, int, int, int], ...] = ()
    digital: bool = False  # digital line scalers (0x126A)


@dataclass(frozen=True, slots=True)
class DataSegment:
    """Where one segment's raw data lies and how it is laid out.

    Attributes
    ----------
    data_start, data_end : int
        Byte offsets of the raw data read (``data_end`` is cut to the file for a truncated
        last segment).
    toc : int
        The segment's ToC mask (interleaved, big-endian, DAQmx flags).
    objects : tuple
        ``(object path, raw-data index or None)`` in the order of the data in each chunk; the
        same tuple object for consecutive segments that reuse one metadata list.
    """

    data_start: int
    data_end: int
    toc: int
    objects: tuple[tuple[str, _Index | None], ...]


class _Buffer:
    """Bounds-checked reading of metadata bytes."""

    def __init__(self, data: bytes, endian: str, notes: list[str] | None = None) -> None:
        self.data = data
        self.pos = 0
        self.endian = endian
        self.notes = notes if notes is not None else []

    def take(self, fmt: str) -> tuple[Any, ...]:
        size = struct.calcsize(self.endian + fmt)
        if self.pos + size > len(self.data):
            raise _Damaged(f"metadata ends {self.pos + size - len(self.data)} bytes early")
        values = struct.unpack_from(self.endian + fmt, self.data, self.pos)
        self.pos += size
        return values

    def u32(self) -> int:
        return int(self.take("I")[0])

    def string(self) -> str:
        length = self.u32()
        if self.pos + length > len(self.data):
            raise _Damaged(f"string of {length} bytes runs past the metadata")
        raw = self.data[self.pos:self.pos + length]
        self.pos += length
        try:
            return raw.decode("utf-8")
        except UnicodeDecodeError as error:
            # nptdms decodes with replacement characters too: one bad byte loses no samples
            text = raw.decode("utf-8", errors="replace")
            self.notes.append(f"metadata string {text[:60]!r} is not UTF-8 ({error.reason} "
                              f"at its byte {error.start}): read with replacement characters")
            return text

    def value(self, type_code: int) -> Any:
        fmt = _PROPERTY_FORMATS.get(type_code)
        if fmt is not None:
            return self.take(fmt)[0]
        if type_code == STRING_TYPE:
            return self.string()
        if type_code == 0x44:
            if self.endian == "<":
                fraction, seconds = self.take("Qq")
            else:
                seconds, fraction = self.take("qQ")
            return TdmsStamp(int(seconds), int(fraction))
        if type_code == 0x08000C:
            real, imag = self.take("ff")
            return complex(real, imag)
        if type_code == 0x10000D:
            real, imag = self.take("dd")
            return complex(real, imag)
        if type_code in (11, 0x1B):
            self.take("16s")
            return None  # extended precision: not representable, kept as absent
        raise _Damaged(f"unknown property type 0x{type_code:X}")


def object_path_parts(path: str) -> tuple[str, ...]:
    """Split a TDMS object path into its names: ``"/'g'/'c'"`` -> ``("g", "c")``."""
    return tuple(part.replace("''", "'") for part in _PATH_PART.findall(path))


def _read_index(buf: _Buffer, header: int) -> _Index:
    """Read one raw-data index (after its header word)."""
    data_type = buf.u32()
    if header in (DAQMX_FORMAT_CHANGING, DAQMX_DIGITAL_LINE):
        dimension, n_values, n_scalers = buf.take("IQI")
        if dimension != 1 or n_scalers > 4096:
            raise _Damaged(f"DAQmx index with dimension {dimension}, {n_scalers} scalers")
        scaler_fmt = "IIIII" if header == DAQMX_FORMAT_CHANGING else "IIIBI"
        scalers = tuple((int(kind), int(buffer), int(offset), int(scale_id))
                        for kind, buffer, offset, _, scale_id in
                        (buf.take(scaler_fmt) for _ in range(n_scalers)))
        buffers = tuple(s[1] for s in scalers)
        n_widths = buf.u32()
        if n_widths > 4096:
            raise _Damaged(f"DAQmx index with {n_widths} raw data widths")
        widths = tuple(int(buf.u32()) for _ in range(n_widths))
        if any(b >= len(widths) for b in buffers):
            raise _Damaged("DAQmx scaler refers to a raw buffer that does not exist")
        return _Index(data_type, int(n_values), 0, widths, buffers, scalers,
                      header == DAQMX_DIGITAL_LINE)
    dimension, n_values = buf.take("IQ")
    if dimension != 1:
        raise _Damaged(f"raw data index with dimension {dimension}")
    if data_type == STRING_TYPE:
        (total,) = buf.take("Q")
        return _Index(data_type, int(n_values), int(total))
    size = TYPE_SIZES.get(data_type)
    if size is None:
        raise _Damaged(f"unknown data type 0x{data_type:X}")
    return _Index(data_type, int(n_values), int(n_values) * size)


def _chunk_bytes(objects: list[tuple[str, _Index | None]]) -> int:
    """Return the bytes of one raw-data chunk of a segment."""
    with_data = [index for _, index in objects if index is not None and index.n_values]
    daqmx = [index for index in with_data if index.widths]
    if daqmx:
        widths = daqmx[0].widths
        values = [0] * len(widths)
        for index in daqmx:
            for b in index.buffers:
                values[b] = max(values[b], index.n_values)
        total = sum(v * w for v, w in zip(values, widths, strict=True))
        return total + sum(index.byte_size for index in with_data if not index.widths)
    return sum(index.byte_size for index in with_data)


def _values_in_data(objects: list[tuple[str, _Index | None]], data_bytes: int,
                    interleaved: bool) -> dict[str, int]:
    """Return values per object held by ``data_bytes`` of raw data (whole values only)."""
    with_data = [(p, i) for p, i in objects if i is not None and i.n_values]
    chunk = _chunk_bytes(objects)
    if chunk <= 0:
        return {}
    n_chunks, rest = divmod(data_bytes, chunk)
    counts = {p: n_chunks * i.n_values for p, i in with_data}
    if not rest:
        return counts
    if any(i.widths for _, i in with_data):  # DAQmx: one interleaved buffer per width
        row = sum(with_data[0][1].widths)
        rows = rest // row if row else 0
        for p, i in with_data:
            counts[p] += min(i.n_values, rows)
    elif interleaved:
        row = sum(TYPE_SIZES.get(i.data_type, 0) for _, i in with_data)
        rows = rest // row if row else 0
        for p, i in with_data:
            counts[p] += min(i.n_values, rows)
    else:
        for p, i in with_data:
            size = TYPE_SIZES.get(i.data_type, 0)
            if i.data_type == STRING_TYPE or size == 0:
                break
            take = min(i.n_values, rest // size)
            counts[p] += take
            rest -= take * size
            if take < i.n_values:
                break
    return counts


#: Within :func:`kept_layouts`: the layouts scanned so far, by file identity (device, inode,
#: size, modification time) and path.
_KEPT: ContextVar[dict[tuple[Any, ...], TdmsLayout] | None] = ContextVar("_KEPT", default=None)


@contextmanager
def kept_layouts() -> Iterator[None]:
    """Keep each TDMS file's layout for the reads within: each file's segments walked once.

    A validation reads one file's channels in several reads (the alignment's, then each
    comparison's); without this each read walks the file's every segment again (1.5 s for a
    1-hour record). The files must not change meanwhile (a file rewritten within is known by
    its new size or modification time).
    """
    token = _KEPT.set({})
    try:
        yield
    finally:
        _KEPT.reset(token)


def scan_tdms(path: str | Path, file: BinaryIO | None = None) -> TdmsLayout:
    """Read the segment structure of a TDMS file, stopping at the first damage.

    Within :func:`kept_layouts`, a file scanned before returns the layout found then (the
    same object: callers only read it).

    Parameters
    ----------
    path : str or pathlib.Path
        The ``.tdms`` file.
    file : binary file, optional
        An open handle on ``path`` (default: opened and closed here).

    Returns
    -------
    TdmsLayout
        Channels with per-segment counts and time marks; ``problem`` says what is damaged.

    Raises
    ------
    DataFileError
        If the file does not start with a readable TDMS segment.
    """
    path = Path(path)
    if file is None:
        with open(path, "rb") as handle:
            return scan_tdms(path, handle)
    status = os.fstat(file.fileno())
    kept = _KEPT.get()
    key = (status.st_dev, status.st_ino, status.st_size, status.st_mtime_ns, str(path))
    if kept is not None and key in kept:
        return kept[key]
    layout = _scan(path, file, status.st_size)
    if kept is not None:
        kept[key] = layout
    return layout


def _scan(path: Path, file: BinaryIO, file_size: int) -> TdmsLayout:
    """Walk the segments of an open TDMS file of ``file_size`` bytes (see :func:`scan_tdms`)."""
    layout = TdmsLayout(path=path, file_size=file_size)
    current: list[tuple[str, _Index | None]] = []
    last_index: dict[str, _Index] = {}
    position = 0
    while position < file_size:
        try:
            position = _read_segment(file, position, layout, current, last_index)
        except _Damaged as damage:
            if layout.segments == 0:
                raise DataFileError(f"not a readable TDMS file: {damage}",
                                    where={"file": str(path), "byte": position},
                                    hint="check that the file is a complete .tdms file") from None
            layout.problem = f"damaged at byte {position}: {damage}"
            break
    layout.good_end = min(position, file_size)
    return layout


def _read_segment(file: BinaryIO, position: int, layout: TdmsLayout,
                  current: list[tuple[str, _Index | None]], last_index: dict[str, _Index]) -> int:
    """Read one segment's lead-in and metadata; update ``layout``; return the next position."""
    file.seek(position)
    lead = file.read(LEAD_IN_BYTES)
    if len(lead) < LEAD_IN_BYTES:
        raise _Damaged(f"{len(lead)} stray bytes where a segment lead-in should start")
    if lead[:4] != b"TDSm":
        raise _Damaged(f"segment starts with {lead[:4]!r} instead of b'TDSm'")
    (toc,) = struct.unpack_from("<i", lead, 4)
    endian = ">" if toc & TOC_BIG_ENDIAN else "<"
    version, next_offset, raw_offset = struct.unpack_from(endian + "iQQ", lead, 8)
    if layout.segments == 0:
        layout.version, layout.big_endian = version, endian == ">"
    data_start = position + LEAD_IN_BYTES + raw_offset
    declared_end = (None if next_offset == UNKNOWN_SIZE
                    else position + LEAD_IN_BYTES + next_offset)
    if declared_end is not None and raw_offset > next_offset:
        raise _Damaged(f"raw data offset {raw_offset} beyond the segment size {next_offset}")
    if data_start > layout.file_size:
        raise _Damaged("segment metadata cut off by the end of the file")
    end = layout.file_size if declared_end is None else min(declared_end, layout.file_size)
    if toc & TOC_META_DATA:
        layout._objects = None
        notes = _read_metadata(file.read(raw_offset), endian, toc, layout, current, last_index)
        layout.notes.extend(f"segment at byte {position}: {note}" for note in notes)
    declared_data = (layout.file_size if declared_end is None else declared_end) - data_start
    chunk = _chunk_bytes(current)
    if chunk > declared_data and (toc & TOC_RAW_DATA or declared_data > 0):
        # checked before anything is allocated: a corrupted value count never reaches numpy
        biggest = max(((p, i.n_values) for p, i in current if i is not None),
                      key=lambda item: item[1], default=("?", 0))
        raise _Damaged(f"its metadata claims chunks of {chunk} bytes ({biggest[1]} values of "
                       f"{biggest[0]}) but the segment holds {declared_data} data bytes")
    if chunk == 0 and declared_data > 0:
        raise _Damaged(f"{declared_data} data bytes but no channel with values")
    layout.segments += 1
    if not toc & TOC_RAW_DATA and declared_data > 0 and chunk > 0:
        # nptdms reads these bytes as raw data whatever the ToC says; so does rigval, saying so
        layout.notes.append(f"segment at byte {position}: its ToC says it has no raw data but "
                            f"{declared_data} bytes follow its metadata, laid out as its data "
                            "index describes: read as raw data (as nptdms does)")
    elif not toc & TOC_RAW_DATA:
        if declared_end is None or declared_end > layout.file_size:
            layout.problem = "last segment incomplete"
        return end
    layout.daqmx = layout.daqmx or bool(toc & TOC_DAQMX)
    interleaved = bool(toc & TOC_INTERLEAVED)
    counts = _values_in_data(current, end - data_start, interleaved)
    if declared_end is None or declared_end > layout.file_size:
        layout.problem = (f"last segment incomplete: {end - data_start} of "
                          f"{'unknown' if declared_end is None else declared_end - data_start} "
                          "data bytes present")
        expected = {p: (c if declared_end is None else 0) for p, c in counts.items()}
        if declared_end is not None:
            expected = _values_in_data(current, declared_end - data_start, interleaved)
    else:
        expected = counts
    _note_zero_counts(current, counts, end - data_start, position, layout)
    if layout._objects is None:
        objects = tuple(current)
        last = layout.data_segments[-1].objects if layout.data_segments else None
        layout._objects = last if objects == last else objects  # shared when repeated
    layout.data_segments.append(DataSegment(data_start, end, toc, layout._objects))
    for obj_path, n in counts.items():
        channel = layout.channels[obj_path]
        channel.counts.append(n)
        channel.expected.append(expected.get(obj_path, n))
    return end


def _note_zero_counts(objects: list[tuple[str, _Index | None]], counts: dict[str, int],
                      data_bytes: int, position: int, layout: TdmsLayout) -> None:
    """Note a channel whose data index announces 0 values in a segment that holds data.

    Writers mark a channel without data in a segment by leaving its index out; an index that
    announces 0 values beside raw data contradicts the bytes (a damaged value count): the data
    are read as the index says, as nptdms reads them, and the note gives the counts.
    """
    zero = ["/".join(object_path_parts(p)) for p, index in objects
            if index is not None and index.n_values == 0]
    if not zero or data_bytes <= 0:
        return
    read = ", ".join(f"{'/'.join(object_path_parts(p))}: {n} values" for p, n in counts.items())
    layout.notes.append(
        f"segment at byte {position}: the data index of {', '.join(zero)} announces 0 values "
        f"but the segment holds {data_bytes} data bytes; read as the indexes say (as nptdms "
        f"does): {read or 'no values'}; values of {', '.join(zero)} in this segment, if any, "
        "are not recovered and may have been read as another channel's")


def _read_metadata(raw: bytes, endian: str, toc: int, layout: TdmsLayout,
                   current: list[tuple[str, _Index | None]],
                   last_index: dict[str, _Index]) -> list[str]:
    """Parse a segment's metadata block and update the object list ``current`` in place.

    Returns the notes about damage read around (strings that are not UTF-8).
    """
    notes: list[str] = []
    buf = _Buffer(raw, endian, notes)
    n_objects = buf.u32()
    if n_objects * 12 > len(raw):
        raise _Damaged(f"{n_objects} objects cannot fit in {len(raw)} metadata bytes")
    if toc & TOC_NEW_OBJ_LIST:
        current.clear()
    positions = {p: k for k, (p, _) in enumerate(current)}
    for _ in range(n_objects):
        obj_path = buf.string()
        header = buf.u32()
        index: _Index | None
        if header == NO_DATA:
            index = None
        elif header == SAME_AS_PREVIOUS:
            index = last_index.get(obj_path)
            if index is None:
                raise _Damaged(f"{obj_path} reuses a raw data index it never had")
        elif header in (DAQMX_FORMAT_CHANGING, DAQMX_DIGITAL_LINE) or 8 <= header <= 64:
            index = _read_index(buf, header)
            if index == last_index.get(obj_path):
                # a writer that repeats each segment's metadata (DAQmx): one index object for
                # all of them, not one per segment (memory of a long record's layout)
                index = last_index[obj_path]
        else:
            raise _Damaged(f"{obj_path} has a raw data index header 0x{header:X}")
        n_props = buf.u32()
        if n_props * 8 > len(raw):
            raise _Damaged(f"{obj_path} claims {n_props} properties")
        props: dict[str, Any] = {}
        for _ in range(n_props):
            name = buf.string()
            props[name] = buf.value(buf.u32())
        parts = object_path_parts(obj_path)
        if len(parts) == 0:
            layout.root_properties.update(props)
            continue
        if len(parts) == 1:
            layout.group_properties.setdefault(parts[0], {}).update(props)
            continue
        channel = layout.channels.get(obj_path)
        if channel is None:
            channel = layout.channels[obj_path] = ChannelLayout(obj_path)
        obj_path = channel.path  # the one string of the path, not one per segment
        channel.properties.update(props)
        marks = {k: v for k, v in props.items() if k in TIME_PROPERTIES}
        if marks:
            channel.time_marks.append((channel.length, marks))
        if index is not None:
            last_index[obj_path] = index
            channel.data_type = index.data_type
        if obj_path in positions:
            current[positions[obj_path]] = (obj_path, index)
        else:
            positions[obj_path] = len(current)
            current.append((obj_path, index))
    return notes
