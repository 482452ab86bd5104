"""Read NI-DAQmx raw TDMS data straight from its rows, hashing the file in the same pass.

A DAQmx segment (ToC flag DAQmx, raw data index ``0x1269``, *format changing scaler*) stores
interleaved rows of ``raw data width`` bytes: every channel's raw value sits at its scaler's byte
offset in each row, and the channel's ``NI_Scale[...]`` properties turn the raw values into
physical ones (docs/formats.md, *DAQmx raw data*). nptdms slices these rows byte column by byte
column per chunk; :func:`read_daqmx` reads blocks of whole segments into a buffer, copies each
raw value column with one strided copy per segment and channel into preallocated arrays, and
scales every channel once at the end with the arithmetic nptdms uses (``data * slope +
intercept``; ``numpy.polynomial.polynomial.polyval`` on float64), so the values are
bit-identical. Every byte of the file goes to the SHA-256 of a second thread, in file order, as in
:mod:`rigval.acquisition.tdms_direct`.

:func:`daqmx_selection` decides whether a read qualifies: every wanted channel is DAQmx raw data
(type ``0xFFFFFFFF``) read by format changing scalers of fixed-size little-endian numbers, in
segments with one raw buffer whose channels all hold the same number of values per chunk, and
scaled by a chain of DAQmx scalers, ``Linear`` and ``Polynomial`` scales. Anything else (digital
line scalers, thermocouple, RTD, strain, table or unknown scales, several raw buffers, types that
change, counts that do not add up) returns None and the caller reads the file with nptdms.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from rigval.acquisition.hashing import BY_REFERENCE_BYTES, ThreadedSha256
from rigval.acquisition.hugepages import mapped_empty, populate, use_huge_pages
from rigval.acquisition.tdms_direct import direct_read, read_exactly, rest_digest, skip_to
from rigval.acquisition.tdms_layout import (
    DAQMX_TYPE,
    TOC_BIG_ENDIAN,
    TOC_DAQMX,
    DataSegment,
    TdmsLayout,
    object_path_parts,
)
from rigval.acquisition.tdms_log import captured_nptdms_messages

__all__ = ["DAQMX_DTYPES", "DaqmxChannel", "DaqmxSelection", "daqmx_selection", "read_daqmx"]

logger = logging.getLogger(__name__)

#: DAQmx scaler type code -> NumPy dtype of its raw values (nptdms ``daqmx.DAQMX_TYPES``).
DAQMX_DTYPES = {0: "<u1", 1: "<i1", 2: "<u2", 3: "<i2", 4: "<u4", 5: "<i4", 6: "<u8", 7: "<i8",
                8: "<f4", 9: "<f8"}
#: Bytes of file read (and hashed) per block; a block holds whole rows.
_BLOCK_BYTES = 1 << 22
#: ``Input_Source`` of a scale that reads the channel's raw data (not DAQmx scaler data).
_RAW_INPUT = 0xFFFFFFFF

#: One scale of a channel's chain: ``("scaler", scale id)``, ``("linear", slope, intercept,
#: input)`` or ``("polynomial", coefficients, input)``.
Scale = tuple[Any, ...]


@dataclass(frozen=True)
class DaqmxChannel:
    """One DAQmx channel to read: its values ``start`` to ``stop - 1``.

    Attributes
    ----------
    path : str
        TDMS object path.
    start, stop : int
        Range of value indexes to keep.
    scalers : dict of int to numpy.dtype
        Scale id -> type of the raw values the scaling reads.
    scales : tuple
        The channel's scales (index = ``NI_Scale[k]``); the last one gives the values.
    widened : int or None
        Scale id of the raw values read straight into the float64 output and scaled there: the
        last scale is linear with float slope and intercept and reads integers of at most 32
        bits, which float64 holds exactly, so ``data * slope + intercept`` gives the same bits.
    """

    path: str
    start: int
    stop: int
    scalers: dict[int, np.dtype]
    scales: tuple[Scale, ...]
    widened: int | None = None


@dataclass(frozen=True)
class DaqmxSelection:
    """What :func:`read_daqmx` reads.

    Attributes
    ----------
    channels : list of DaqmxChannel
        The channels, in the order asked.
    segments : list of tuple
        ``(data start byte, rows, row width in bytes, {path: {scale id: byte offset}})`` of
        every segment holding wanted values, in file order.
    """

    channels: list[DaqmxChannel]
    segments: list[tuple[int, int, int, dict[str, dict[int, int]]]]


def _scales(layout: TdmsLayout, path: str) -> tuple[Scale, ...] | None:
    """Return the channel's scale chain as nptdms resolves it, None if not reproduced here."""
    from nptdms import scaling

    group = object_path_parts(path)[0]
    try:
        with captured_nptdms_messages():  # unsupported scales are warned about by rigval
            found = scaling.get_scaling(layout.channels[path].properties,
                                        layout.group_properties.get(group, {}),
                                        layout.root_properties)
    except Exception as error:  # nptdms raises KeyError, ValueError on damaged properties
        logger.debug("%s: %s: scaling unreadable (%s)", layout.path, path, error)
        return None
    if found is None:  # nptdms cannot read DAQmx raw data without a scaling
        return None
    scales: list[Scale] = []
    for item in found.scalings:
        if isinstance(item, scaling.DaqMxScalerScaling):
            scales.append(("scaler", item.scale_id))
        elif type(item) is scaling.LinearScaling:
            scales.append(("linear", item.slope, item.intercept, item.input_source))
        elif type(item) is scaling.PolynomialScaling:
            scales.append(("polynomial", tuple(item.coefficients), item.input_source))
        else:
            logger.debug("%s: %s: %s scale is left to nptdms", layout.path, path,
                         type(item).__name__)
            return None
    return tuple(scales) if _chain_ok(scales) else None


def _chain_ok(scales: Sequence[Scale]) -> bool:
    """Return True if the last scale reaches DAQmx scalers only, without a loop."""
    def reaches(k: int, seen: frozenset[int]) -> bool:
        if not 0 <= k < len(scales) or k in seen:
            return False  # raw data (absent for DAQmx raw data), out of range or a loop
        scale = scales[k]
        return scale[0] == "scaler" or reaches(int(scale[-1]), seen | {k})

    return bool(scales) and reaches(len(scales) - 1, frozenset())


def _needed_scalers(scales: Sequence[Scale]) -> set[int]:
    """Return the scale ids of the DAQmx scalers the last scale reads."""
    needed, todo = set(), [len(scales) - 1]
    while todo:
        scale = scales[todo.pop()]
        if scale[0] == "scaler":
            needed.add(int(scale[1]))
        else:
            todo.append(int(scale[-1]))
    return needed


def _scaler_types(layout: TdmsLayout, path: str) -> dict[int, int] | None:
    """Return scale id -> DAQmx type of the channel, None if its segments disagree."""
    types: dict[int, int] | None = None
    for segment in layout.data_segments:
        for obj_path, index in segment.objects:
            if obj_path != path or index is None:
                continue
            if index.data_type != DAQMX_TYPE or index.digital or not index.widths:
                return None
            these = {scale_id: kind for kind, _, _, scale_id in index.scalers}
            if len(these) != len(index.scalers) or (types is not None and these != types):
                return None
            types = these
    return types


def _channel(layout: TdmsLayout, path: str, start: int, stop: int) -> DaqmxChannel | None:
    """Return how to read one channel, None if nptdms must read it."""
    if layout.channels[path].data_type != DAQMX_TYPE or stop <= start:
        return None
    scales = _scales(layout, path)
    types = _scaler_types(layout, path)
    if scales is None or types is None:
        return None
    needed = _needed_scalers(scales)
    if not needed <= types.keys() or any(types[k] not in DAQMX_DTYPES for k in needed):
        return None
    dtypes = {k: np.dtype(DAQMX_DTYPES[types[k]]) for k in needed}
    last = scales[-1]
    widened = None
    if last[0] == "linear" and type(last[1]) is float and type(last[2]) is float \
            and scales[last[3]][0] == "scaler":
        dtype = dtypes[scales[last[3]][1]]
        if dtype.kind in "iu" and dtype.itemsize <= 4:
            widened = int(scales[last[3]][1])
    return DaqmxChannel(path, start, stop, dtypes, scales, widened)


def _rows(segment: DataSegment,
          wanted: Mapping[str, DaqmxChannel]) -> tuple[int, dict[str, dict[int, int]]] | None:
    """Return ``(row width, {path: {scale id: byte offset}})`` of a segment, None if unsupported.

    A segment without wanted values gives ``(0, {})``.
    """
    holders = [(p, i) for p, i in segment.objects if i is not None and i.n_values]
    if not any(p in wanted for p, _ in holders):
        return 0, {}
    if segment.toc & TOC_BIG_ENDIAN or not segment.toc & TOC_DAQMX:
        return None
    widths = holders[0][1].widths
    if len(widths) != 1 or not 0 < widths[0] <= _BLOCK_BYTES:
        return None  # several raw buffers (one per card), or rows beyond a block: nptdms
    n_values = holders[0][1].n_values
    offsets: dict[str, dict[int, int]] = {}
    for path, index in holders:
        if index.widths != widths or index.n_values != n_values or index.digital:
            return None
        if path not in wanted:
            continue
        where = {scale_id: offset for kind, _, offset, scale_id in index.scalers
                 if scale_id in wanted[path].scalers}
        if where.keys() != wanted[path].scalers.keys() or any(
                where[k] + wanted[path].scalers[k].itemsize > widths[0] for k in where):
            return None
        offsets[path] = where
    return widths[0], offsets


def daqmx_selection(layout: TdmsLayout,
                    ranges: Mapping[str, tuple[int, int]]) -> DaqmxSelection | None:
    """Return what to read directly from DAQmx rows, or None if nptdms must read it.

    Parameters
    ----------
    layout, ranges
        As for :func:`~rigval.acquisition.tdms_direct.plain_selection`: the scanned file and
        object path -> range of value indexes ``(start, stop)`` wanted.

    Returns
    -------
    DaqmxSelection or None
        None unless every wanted channel qualifies (module docstring) and the segment rows
        account for exactly the values the scan counted.
    """
    if not layout.daqmx or not ranges:
        return None
    channels = []
    for path, (start, stop) in ranges.items():
        channel = _channel(layout, path, start, stop)
        if channel is None:
            logger.debug("%s: %s needs nptdms", layout.path, path)
            return None
        channels.append(channel)
    wanted = {c.path: c for c in channels}
    counted = dict.fromkeys(wanted, 0)
    checked: dict[tuple[int, int], tuple[int, dict[str, dict[int, int]]] | None] = {}
    segments = []
    for segment in layout.data_segments:
        key = (id(segment.objects), segment.toc)  # the tuples live as long as the layout
        if key not in checked:
            checked[key] = _rows(segment, wanted)
        found = checked[key]
        if found is None:
            logger.debug("%s: segment at byte %d needs nptdms", layout.path, segment.data_start)
            return None
        width, offsets = found
        if offsets:
            rows = (segment.data_end - segment.data_start) // width
            for path in offsets:
                counted[path] += rows
            segments.append((segment.data_start, rows, width, offsets))
    if any(counted[p] != layout.channels[p].length for p in wanted):
        logger.debug("%s: DAQmx rows count %s values, the scan %s", layout.path, counted,
                     {p: layout.channels[p].length for p in wanted})
        return None
    return DaqmxSelection(channels, segments)


def _pieces(selection: DaqmxSelection) -> Iterator[tuple[int, int, int, list[tuple[Any, ...]]]]:
    """Yield ``(first byte, rows, width, copies)`` of every run of rows to read, in file order.

    Each copy is ``(scale id, path, first output index, first row in the run, rows, byte offset
    in the row, dtype)``; segments longer than a block are split into runs of whole rows.
    """
    ranges = {c.path: (c.start, c.stop) for c in selection.channels}
    scalers = {c.path: c.scalers for c in selection.channels}
    seen = dict.fromkeys(ranges, 0)
    for data_start, rows, width, offsets in selection.segments:
        per_block = max(1, _BLOCK_BYTES // width)
        for first_row in range(0, rows, per_block):
            n = min(per_block, rows - first_row)
            copies = []
            for path, where in offsets.items():
                start, stop = ranges[path]
                first = seen[path] + first_row
                lo, hi = max(first, start), min(first + n, stop)
                if lo < hi:
                    copies.extend((scale_id, path, lo - start, lo - first, hi - lo, offset,
                                   scalers[path][scale_id]) for scale_id, offset in where.items())
            if copies:
                yield data_start + first_row * width, n, width, copies
        for path in offsets:
            seen[path] += rows


def read_daqmx(file: Path, layout: TdmsLayout, selection: DaqmxSelection,
               checksum: bool) -> tuple[dict[str, np.ndarray], str | None]:
    """Read and scale the selected DAQmx values in one pass, hashing the file on the way.

    Parameters
    ----------
    file, layout, checksum
        As for :func:`~rigval.acquisition.tdms_direct.read_plain`: the ``.tdms`` file, its
        scanned structure, and whether to hash all of it.
    selection : DaqmxSelection
        From :func:`daqmx_selection`.

    Returns
    -------
    values, sha256
        As :func:`~rigval.acquisition.tdms_direct.read_plain` returns them, the values scaled
        (physical units of each channel's last scale, e.g. V or m/s^2).

    Raises
    ------
    DataFileError
        As :func:`~rigval.acquisition.tdms_direct.read_plain` does.
    """
    huge = use_huge_pages(sum(8 * (c.stop - c.start) for c in selection.channels))
    raw = {(sid, c.path): _raw_array(c, sid, huge) for c in selection.channels for sid in c.scalers}
    scratch = np.empty(2 * _BLOCK_BYTES, np.uint8)  # a gap of at most a block, then a run
    with direct_read(file, layout.file_size, checksum, 0) as (handle, hasher):
        position = 0
        block: list[tuple[int, int, int, list[tuple[Any, ...]]]] = []
        for piece in _pieces(selection):
            start = piece[0]
            end = start + piece[1] * piece[2]
            if block and end - position > _BLOCK_BYTES:
                position = _flush(handle, block, position, raw, hasher, scratch, file)
                block = []
            if not block and start - position > _BLOCK_BYTES:
                position = skip_to(handle, hasher, position, start, file)
            block.append(piece)
        if block:
            position = _flush(handle, block, position, raw, hasher, scratch, file)
        values = {c.path: _scaled(c, raw) for c in selection.channels}
        logger.debug("%s: read %d DAQmx values directly", file,
                     sum(a.size for a in values.values()))
        return values, rest_digest(handle, hasher)


def _flush(handle: Any, block: list[tuple[int, int, int, list[tuple[Any, ...]]]],
           position: int, raw: Mapping[tuple[int, str], np.ndarray],
           hasher: ThreadedSha256 | None, scratch: np.ndarray, file: Path) -> int:
    """Read the file from ``position`` to the end of the block's last run, copy its values.

    Returns the new file position. The bytes go to the hasher in pieces shorter than
    :data:`~rigval.acquisition.hashing.BY_REFERENCE_BYTES`, so it copies them to its staging
    buffers and ``scratch`` can be refilled at once (memory stays bounded).
    """
    last = block[-1]
    size = last[0] + last[1] * last[2] - position
    buffer = scratch[:size]
    view = memoryview(buffer)
    read_exactly(handle, view, file, position)
    if hasher is not None:
        step = BY_REFERENCE_BYTES - 1
        for at in range(0, size, step):
            hasher.feed(view[at:at + step])
    for start, _, width, copies in block:
        base = start - position
        for scale_id, path, out, row, n, offset, dtype in copies:
            source = np.ndarray((n,), dtype, buffer, base + row * width + offset, (width,))
            raw[scale_id, path][out:out + n] = source
    return position + size


def _raw_array(channel: DaqmxChannel, scale_id: int, huge: bool) -> np.ndarray:
    """Return the array the raw values of one scaler are copied to.

    The widened scaler gets the float64 output itself (its pages provided at once, huge pages
    when ``huge``); other scalers get an array of their own type.
    """
    count = channel.stop - channel.start
    if scale_id != channel.widened:
        return np.empty(count, channel.scalers[scale_id])
    out = mapped_empty(count, np.float64, huge)
    populate(out, 0, count)
    return out


def _scaled(channel: DaqmxChannel, raw: Mapping[tuple[int, str], np.ndarray]) -> np.ndarray:
    """Apply the channel's last scale (and those it reads) as nptdms's ``scaling`` module does."""
    return _scale_value(channel, raw, len(channel.scales) - 1)


def _scale_value(channel: DaqmxChannel, raw: Mapping[tuple[int, str], np.ndarray], k: int
                 ) -> np.ndarray:
    """Return the values of scale ``k`` of a channel, the scales it reads applied first.

    A module function, not a closure calling itself: such a closure is a reference cycle that
    would keep ``raw`` (whose float64 array is the channel's output) alive until the garbage
    collector runs, 137 MiB of an hour's channel after its reader let it go (memory).
    """
    scale = channel.scales[k]
    if scale[0] == "scaler":
        return raw[scale[1], channel.path]
    if scale[0] == "linear":  # LinearScaling.scale: data * slope + intercept
        data, slope, intercept = _scale_value(channel, raw, scale[3]), scale[1], scale[2]
        if k != len(channel.scales) - 1 or channel.widened is None:
            return data * slope + intercept
        # the raw integers already lie in the float64 output, as numpy casts them for
        # ``data * slope``: the same two float64 operations per value, in place
        np.multiply(data, slope, out=data)
        return np.add(data, intercept, out=data)
    coefficients = scale[1]  # PolynomialScaling.scale
    data = _scale_value(channel, raw, scale[2])
    if len(coefficients) == 0:
        return np.zeros(len(data), dtype=np.dtype("float64"))
    return np.polynomial.polynomial.polyval(data.astype(np.dtype("float64"), copy=False),
                                            list(coefficients))
