"""A writer of NI-DAQmx-style raw TDMS files (format-changing scalers, interleaved integers).

NI-DAQmx logging stores raw ADC codes and counter values (int16, int32, uint32) in "DAQmx raw
data" segments (TDMS data type 0xFFFFFFFF, raw data index 0x00001269) with one format-changing
scaler per channel, and puts the linear scaling in ``NI_Scale[1]_*`` properties with
``NI_Scaling_Status = "unscaled"``; nptdms applies that scaling when it reads. This module writes
the same structure (checked byte by byte against ``realdata/nidaqmx-python/data_ai.tdms``), so the
virtual rig's files carry the quirks of real ones, and writes nothing that depends on the wall
clock, so the same input gives the same bytes.

Layout of one *acquisition* (a task start): a segment with the full object list, every property
(scaling, ``NI_ChannelName``, ``unit_string``, ``NI_UnitDescription``, ``wf_start_time``,
``wf_increment``, ``wf_start_offset``, ``wf_samples``) and the first block of data, then data-only
segments. A restarted task appends a new acquisition to the same group: its first segment carries
the new ``wf_start_time`` (nptdms then reports the last one and concatenates the data; a reader
that keeps gaps walks the segments).
"""

from __future__ import annotations

import logging
import struct
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from rigval.acquisition.errors import ConfigError
from rigval.acquisition.tdms_layout import (
    DAQMX_FORMAT_CHANGING,
    DAQMX_TYPE,
    NO_DATA,
    TOC_DAQMX,
    TOC_INTERLEAVED,
    TOC_META_DATA,
    TOC_NEW_OBJ_LIST,
    TOC_RAW_DATA,
)

__all__ = ["Acquisition", "RawChannel", "write_daqmx_tdms"]

logger = logging.getLogger(__name__)

_VERSION = 4713
#: Scaler data type codes (nptdms daqmx.DAQMX_TYPES).
_SCALER_CODES = {np.dtype("<u1"): 0, np.dtype("<i1"): 1, np.dtype("<u2"): 2,
                 np.dtype("<i2"): 3, np.dtype("<u4"): 4, np.dtype("<i4"): 5}
_EPOCH_1904 = np.datetime64("1904-01-01T00:00:00", "ns")


@dataclass(frozen=True)
class RawChannel:
    """One channel of raw integer samples and its scaling ``value = slope * raw + intercept``.

    Parameters
    ----------
    name : str
        Channel name (also ``NI_ChannelName``).
    raw : numpy.ndarray
        Raw samples: int16, int32 (ADC codes) or uint32 (counter values).
    slope, intercept : float
        Linear scale to the physical unit.
    unit : str or None
        ``unit_string`` (e.g. ``"Volts"``, ``"V/V"``); None writes no unit properties, as NI-DAQmx
        does for counter channels.
    """

    name: str
    raw: NDArray
    slope: float
    intercept: float
    unit: str | None


@dataclass(frozen=True)
class Acquisition:
    """One task start: a group's channels recorded from one software start time on.

    Parameters
    ----------
    group : str
        Group name (the task name).
    start_time : numpy.datetime64
        ``wf_start_time`` (UTC).
    increment : float
        ``wf_increment`` in s.
    channels : tuple of RawChannel
        Channels, equal lengths.
    """

    group: str
    start_time: np.datetime64
    increment: float
    channels: tuple[RawChannel, ...]


def _string(text: str) -> bytes:
    data = text.encode("utf-8")
    return struct.pack("<I", len(data)) + data


def _timestamp(value: np.datetime64) -> bytes:
    ns = int((np.datetime64(value, "ns") - _EPOCH_1904) / np.timedelta64(1, "ns"))
    seconds, rest = divmod(ns, 10**9)
    fraction = (rest << 64) // 10**9
    return struct.pack("<Qq", fraction, seconds)


def _property(name: str, value: object) -> bytes:
    if isinstance(value, str):
        return _string(name) + struct.pack("<I", 0x20) + _string(value)
    if isinstance(value, np.datetime64):
        return _string(name) + struct.pack("<I", 0x44) + _timestamp(value)
    if isinstance(value, np.uint32):
        return _string(name) + struct.pack("<II", 7, int(value))
    if isinstance(value, int):
        return _string(name) + struct.pack("<Ii", 3, value)
    if isinstance(value, float):
        return _string(name) + struct.pack("<Id", 10, value)
    raise ConfigError(f"TDMS property {name!r}: unsupported type {type(value).__name__}",
                      where={"key": name})


def _properties(props: dict[str, object]) -> bytes:
    return struct.pack("<I", len(props)) + b"".join(_property(k, v) for k, v in props.items())


def _path(group: str, channel: str | None = None) -> str:
    quoted = "/'" + group.replace("'", "''") + "'"
    return quoted if channel is None else quoted + "/'" + channel.replace("'", "''") + "'"


def _channel_properties(channel: RawChannel, acq: Acquisition) -> dict[str, object]:
    props: dict[str, object] = {
        "NI_Scaling_Status": "unscaled",
        "NI_Number_Of_Scales": np.uint32(2),
        "NI_Scale[1]_Scale_Type": "Linear",
        "NI_Scale[1]_Linear_Slope": float(channel.slope),
        "NI_Scale[1]_Linear_Y_Intercept": float(channel.intercept),
        "NI_Scale[1]_Linear_Input_Source": np.uint32(0),
        "NI_ChannelName": channel.name,
    }
    if channel.unit is not None:
        props["unit_string"] = channel.unit
        props["NI_UnitDescription"] = channel.unit
    props.update({"wf_start_time": np.datetime64(acq.start_time, "ns"),
                  "wf_increment": float(acq.increment), "wf_start_offset": 0.0,
                  "wf_samples": 1})
    return props


def _segment(objects: list[tuple[str, bytes, bytes]], data: bytes) -> bytes:
    meta = struct.pack("<I", len(objects)) + b"".join(
        _string(path) + index + props for path, index, props in objects)
    toc = TOC_META_DATA | TOC_NEW_OBJ_LIST | TOC_RAW_DATA | TOC_INTERLEAVED | TOC_DAQMX
    lead_in = b"TDSm" + struct.pack("<IIQQ", toc, _VERSION, len(meta) + len(data), len(meta))
    return lead_in + meta + data


def _acquisition_segments(acq: Acquisition, root_props: dict[str, object] | None,
                          new_group: bool, block: int) -> list[bytes]:
    lengths = {c.raw.size for c in acq.channels}
    if len(lengths) != 1:
        raise ConfigError(f"group {acq.group!r}: channels differ in length {sorted(lengths)}",
                          where={"key": acq.group})
    n = lengths.pop()
    dtypes = [np.dtype(c.raw.dtype).newbyteorder("<") for c in acq.channels]
    for channel, dtype in zip(acq.channels, dtypes, strict=True):
        if dtype not in _SCALER_CODES:
            raise ConfigError(f"channel {channel.name!r}: raw type {dtype} is not a DAQmx type",
                              where={"channel": channel.name})
    offsets = np.cumsum([0] + [d.itemsize for d in dtypes])
    width = int(offsets[-1])
    record = np.dtype({"names": [f"c{i}" for i in range(len(dtypes))], "formats": dtypes,
                       "offsets": [int(o) for o in offsets[:-1]], "itemsize": width})
    segments = []
    for first in range(0, n, block):
        count = min(block, n - first)
        rows = np.empty(count, dtype=record)
        for i, channel in enumerate(acq.channels):
            rows[f"c{i}"] = channel.raw[first:first + count]
        objects: list[tuple[str, bytes, bytes]] = []
        if first == 0:
            if root_props is not None:
                objects.append(("/", struct.pack("<I", NO_DATA), _properties(root_props)))
            if new_group:
                objects.append((_path(acq.group), struct.pack("<I", NO_DATA),
                                struct.pack("<I", 0)))
        for i, (channel, dtype) in enumerate(zip(acq.channels, dtypes, strict=True)):
            index = struct.pack("<IIIQI", DAQMX_FORMAT_CHANGING, DAQMX_TYPE, 1, count, 1)
            index += struct.pack("<IIIII", _SCALER_CODES[dtype], 0, int(offsets[i]), 0, 0)
            index += struct.pack("<II", 1, width)
            props = (_properties(_channel_properties(channel, acq)) if first == 0
                     else struct.pack("<I", 0))
            objects.append((_path(acq.group, channel.name), index, props))
        segments.append(_segment(objects, rows.tobytes()))
    return segments


def write_daqmx_tdms(path: str | Path, acquisitions: Sequence[Acquisition], *,
                     block_samples: int = 4096, file_name: str = "") -> Path:
    """Write acquisitions to a TDMS file laid out as NI-DAQmx logging writes raw data.

    Parameters
    ----------
    path : str or Path
        Output file (overwritten).
    acquisitions : sequence of Acquisition
        Task starts in the order they happened; a group may appear again (a restart).
    block_samples : int, default 4096
        Samples per channel per data segment (one DAQmx read).
    file_name : str, default ""
        The root object's ``name`` property.

    Returns
    -------
    Path
        The file written.
    """
    path = Path(path)
    seen: set[str] = set()
    parts: list[bytes] = []
    for number, acq in enumerate(acquisitions):
        parts += _acquisition_segments(acq, {"name": file_name} if number == 0 else None,
                                       acq.group not in seen, block_samples)
        seen.add(acq.group)
    path.write_bytes(b"".join(parts))
    logger.debug("wrote %s (%d acquisitions)", path, len(acquisitions))
    return path
