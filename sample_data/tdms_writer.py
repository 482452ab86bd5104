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
from rigval.acquisition.tdms_daqmx import DAQMX_DTYPES
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

__all__ = ["Acquisition", "DaqmxTdmsWriter", "RawChannel", "write_daqmx_tdms"]

logger = logging.getLogger(__name__)

_VERSION = 4713
#: Raw integer type (8 to 32 bits, as NI's ADCs write) -> its DAQmx scaler data type code.
_SCALER_CODES = {np.dtype(name): code for code, name in DAQMX_DTYPES.items()
                 if np.dtype(name).kind in "iu" and np.dtype(name).itemsize <= 4}
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


def _record_dtype(acq: Acquisition) -> tuple[np.dtype, list[np.dtype], np.ndarray]:
    """Return the interleaved row dtype, the channels' dtypes and their byte offsets."""
    dtypes = [np.dtype(c.raw.dtype).newbyteorder("<") for c in acq.channels]
    for channel, dtype in zip(acq.channels, dtypes, strict=True):
        if dtype not in _SCALER_CODES:
            raise ConfigError(f"channel {channel.name!r}: raw type {dtype} is not a DAQmx type",
                              where={"channel": channel.name})
    offsets = np.cumsum([0] + [d.itemsize for d in dtypes])
    record = np.dtype({"names": [f"c{i}" for i in range(len(dtypes))], "formats": dtypes,
                       "offsets": [int(o) for o in offsets[:-1]], "itemsize": int(offsets[-1])})
    return record, dtypes, offsets


class DaqmxTdmsWriter:
    """Write a DAQmx-style raw TDMS file piece by piece, in bounded memory.

    :meth:`start` begins an acquisition (a task start), :meth:`append` adds samples of its
    channels in pieces of any length; full blocks of ``block_samples`` are written as they fill,
    the rest when the next acquisition starts or at :meth:`close`. The bytes equal those of
    :func:`write_daqmx_tdms` with all samples at once.

    Parameters
    ----------
    path : str or Path
        Output file (overwritten).
    block_samples : int, default 4096
        Samples per channel per data segment (one DAQmx read).
    file_name : str, default ""
        The root object's ``name`` property.
    """

    def __init__(self, path: str | Path, *, block_samples: int = 4096,
                 file_name: str = "") -> None:
        self.path = Path(path)
        self._file = self.path.open("wb")
        self._block = block_samples
        self._file_name = file_name
        self._seen: set[str] = set()
        self._acquisitions = 0
        self._acq: Acquisition | None = None
        self._pending: list[list[NDArray]] = []
        self._written = 0

    def start(self, acq: Acquisition) -> None:
        """Begin an acquisition; its channels' ``raw`` arrays give the dtypes (and first samples).

        Raises
        ------
        ConfigError
            If a channel's raw type is not a DAQmx type.
        """
        self._flush(final=True)
        _record_dtype(acq)
        self._root = {"name": self._file_name} if self._acquisitions == 0 else None
        self._new_group = acq.group not in self._seen
        self._seen.add(acq.group)
        self._acquisitions += 1
        self._acq = acq
        self._pending = [[] for _ in acq.channels]
        self._written = 0
        self.append([c.raw for c in acq.channels])

    def append(self, raw: Sequence[NDArray]) -> None:
        """Append samples to the current acquisition, one array per channel (equal lengths).

        Raises
        ------
        ConfigError
            Before :meth:`start`, or for channels of unequal lengths.
        """
        if self._acq is None:
            raise ConfigError("append before start: no acquisition begun", where={})
        lengths = {np.asarray(r).size for r in raw}
        if len(lengths) != 1 or len(raw) != len(self._acq.channels):
            raise ConfigError(f"group {self._acq.group!r}: channels differ in length "
                              f"{sorted(lengths)}", where={"key": self._acq.group})
        for pending, values in zip(self._pending, raw, strict=True):
            pending.append(np.asarray(values))
        self._flush(final=False)

    def _flush(self, final: bool) -> None:
        acq = self._acq
        if acq is None:
            return
        joined = [np.concatenate(p) if len(p) != 1 else p[0] for p in self._pending]
        n = joined[0].size if joined else 0
        record, dtypes, offsets = _record_dtype(acq)
        width = record.itemsize
        first = 0
        while n - first >= self._block or (final and n - first > 0):
            count = min(self._block, n - first)
            rows = np.empty(count, dtype=record)
            for i, values in enumerate(joined):
                rows[f"c{i}"] = values[first:first + count]
            objects: list[tuple[str, bytes, bytes]] = []
            opening = self._written == 0
            if opening:
                if self._root is not None:
                    objects.append(("/", struct.pack("<I", NO_DATA), _properties(self._root)))
                if self._new_group:
                    objects.append((_path(acq.group), struct.pack("<I", NO_DATA),
                                    struct.pack("<I", 0)))
            for i, (channel, dtype) in enumerate(zip(acq.channels, dtypes, strict=True)):
                index = struct.pack("<IIIQI", DAQMX_FORMAT_CHANGING, DAQMX_TYPE, 1, count, 1)
                index += struct.pack("<IIIII", _SCALER_CODES[dtype], 0, int(offsets[i]), 0, 0)
                index += struct.pack("<II", 1, width)
                props = (_properties(_channel_properties(channel, acq)) if opening
                         else struct.pack("<I", 0))
                objects.append((_path(acq.group, channel.name), index, props))
            self._file.write(_segment(objects, rows.tobytes()))
            self._written += count
            first += count
        self._pending = [[values[first:]] for values in joined]
        if final:
            self._acq = None

    def close(self) -> None:
        """Write what is pending and close the file."""
        self._flush(final=True)
        self._file.close()

    def __enter__(self) -> DaqmxTdmsWriter:
        return self

    def __exit__(self, kind: type[BaseException] | None, *exc: object) -> None:
        if kind is None:
            self.close()
        else:  # a failed write leaves no partial file behind
            self._file.close()
            self.path.unlink(missing_ok=True)


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
    with DaqmxTdmsWriter(path, block_samples=block_samples, file_name=file_name) as writer:
        for acq in acquisitions:
            writer.start(acq)
    logger.debug("wrote %s (%d acquisitions)", path, len(acquisitions))
    return path
