"""Read NI TDMS files into stream Datasets (one per time base).

Plain little-endian numbers are read straight into the output arrays while the file is hashed
in the same pass (:mod:`rigval.acquisition.tdms_direct`), and so are NI-DAQmx raw rows with
linear or polynomial scales (:mod:`rigval.acquisition.tdms_daqmx`); nptdms reads and scales
everything else (other DAQmx layouts and scales, interleaved and big-endian segments). The
streams, their time axes and the fallbacks applied come from the file's metadata
(:mod:`rigval.acquisition.tdms_plan`, on :mod:`rigval.acquisition.tdms_layout`).
"""

from __future__ import annotations

import io
import logging
import os
from collections.abc import Iterator, Mapping, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np
import xarray as xr
from nptdms import TdmsFile

from rigval.acquisition.detect import (
    NOT_COMPUTED,
    cached_checksum,
    checked_path,
    checksum_key,
    remember_checksum,
    source_checksum,
)
from rigval.acquisition.devices import DeviceProfile, get_device, module_attrs
from rigval.acquisition.errors import DataFileError
from rigval.acquisition.hugepages import plain_pages
from rigval.acquisition.schema import Channel, stream_dataset
from rigval.acquisition.tdms_daqmx import DaqmxSelection, daqmx_selection, read_daqmx
from rigval.acquisition.tdms_direct import PlainChannel, plain_selection, read_plain
from rigval.acquisition.tdms_layout import (
    TdmsLayout,
    TdmsStamp,
    object_path_parts,
    scan_tdms,
)
from rigval.acquisition.tdms_log import captured_nptdms_messages
from rigval.acquisition.tdms_plan import (
    TdmsStreamPlan,
    plan_tdms,
    raise_empty,
    warn_about_plans,
)
from rigval.acquisition.time_fallbacks import time_fallback_attrs

__all__ = ["TdmsStreamPlan", "iter_tdms", "plan_tdms", "read_tdms", "warn_about_plans"]

logger = logging.getLogger(__name__)


class _Prefix(io.RawIOBase):
    """Read-only view of the first ``end`` bytes of a file (hides a damaged tail from nptdms)."""

    def __init__(self, raw: BinaryIO, end: int) -> None:
        self._raw, self._end, self._pos = raw, end, 0

    def readable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return True

    def tell(self) -> int:
        return self._pos

    def seek(self, offset: int, whence: int = os.SEEK_SET) -> int:
        base = {os.SEEK_SET: 0, os.SEEK_CUR: self._pos, os.SEEK_END: self._end}[whence]
        self._pos = max(0, min(base + offset, self._end))
        return self._pos

    def readinto(self, buffer: Any) -> int:
        view = memoryview(buffer).cast("B")
        size = max(0, min(len(view), self._end - self._pos))
        self._raw.seek(self._pos)
        got = self._raw.readinto(view[:size]) or 0
        self._pos += got
        return got


def _json_value(value: Any) -> Any:
    """Return a property value in a form netCDF attributes and JSON accept."""
    if isinstance(value, TdmsStamp):
        if not value.in_range():
            return f"out of range ({value.seconds} s since 1904)"
        return str(np.datetime_as_string(value.to_datetime64(), unit="ns")) + "Z"
    if isinstance(value, bool | np.bool_):
        return int(value)
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, complex):
        return str(value)
    return value


def _scaling_text(props: Mapping[str, Any]) -> str:
    """Describe the NI scaling applied to a channel (by rigval's DAQmx reader or nptdms)."""
    count = props.get("NI_Number_Of_Scales")
    if not count or props.get("NI_Scaling_Status") == "scaled":
        return "none"
    parts = []
    for k in range(int(count)):
        kind = props.get(f"NI_Scale[{k}]_Scale_Type")
        if kind is None:
            continue
        if kind == "Linear":
            parts.append(f"NI_Scale[{k}] Linear slope {props.get(f'NI_Scale[{k}]_Linear_Slope')}"
                         f" intercept {props.get(f'NI_Scale[{k}]_Linear_Y_Intercept')}")
        else:
            parts.append(f"NI_Scale[{k}] {kind}")
    if not parts:
        return "none"
    return "DAQmx raw data scaled by the file's NI scales: " + "; ".join(parts)


def _channel_attrs(layout: TdmsLayout, plan: TdmsStreamPlan, name: str,
                   profile: DeviceProfile | None,
                   modules: Mapping[str, str] | None) -> tuple[str, dict[str, Any]]:
    """Return (units, attrs) of one channel variable."""
    from rigval.acquisition.units import udunits

    path = plan.channels[name]
    props = layout.channels[path].properties
    unit_text = str(props.get("unit_string", props.get("NI_UnitDescription", "")))
    attrs: dict[str, Any] = {
        "units_in_file": unit_text,
        "time_offset_s": plan.offsets[name],
        **{f"tdms_{k.replace('/', '_')}": _json_value(v) for k, v in props.items()},
    }
    module_name = _module_for(name, props, profile, modules)
    if module_name is not None:
        attrs.update(module_attrs(module_name, plan.fs_nominal,
                                  where={"file": str(layout.path), "channel": path}))
    return udunits(unit_text), attrs


def _module_for(name: str, props: Mapping[str, Any], profile: DeviceProfile | None,
                modules: Mapping[str, str] | None) -> str | None:
    """Return the module a channel sits on: ``modules`` option, else the device default."""
    physical = str(props.get("NI_ChannelName", name))
    for key, module in (modules or {}).items():
        if key in (name, physical) or physical.startswith(key + "/") or name.startswith(key):
            return module
    return profile.default_module if profile is not None else None


def _open_nptdms(handle: BinaryIO, layout: TdmsLayout) -> TdmsFile:
    """Open the readable part of a TDMS file with nptdms (metadata only)."""
    handle.seek(0)
    source: Any = handle
    if layout.good_end < layout.file_size:
        source = io.BufferedReader(_Prefix(handle, layout.good_end))
    try:
        with captured_nptdms_messages():  # rigval reports truncation itself, with counts
            return TdmsFile.open(source)
    except Exception as error:  # nptdms raises ValueError, KeyError, struct.error, ...
        raise DataFileError(f"nptdms cannot read the file: {type(error).__name__}: {error}",
                            where={"file": str(layout.path)},
                            hint="the file may be damaged; see 'rigval info'") from error


def _read_values(tdms: TdmsFile, path: str, start: int, count: int, file: Path) -> np.ndarray:
    """Read ``count`` scaled values of a channel from ``start``; damage becomes DataFileError."""
    group, name = object_path_parts(path)[:2]
    try:
        with captured_nptdms_messages():
            data = tdms[group][name].read_data(offset=start, length=count)
    except Exception as error:
        raise DataFileError(f"cannot read channel data: {type(error).__name__}: {error}",
                            where={"file": str(file), "channel": path},
                            hint="the file may be damaged; see 'rigval info'") from error
    if data.dtype.kind not in "iufbc":
        raise DataFileError(f"channel holds {data.dtype} values, not numbers",
                            where={"file": str(file), "channel": path})
    return data


def _build(layout: TdmsLayout, plan: TdmsStreamPlan, data: Mapping[str, np.ndarray],
           start: int, stop: int, *, device: str | None, modules: Mapping[str, str] | None,
           sha: str) -> xr.Dataset:
    """Assemble one stream Dataset for samples ``start`` to ``stop - 1``."""
    profile = get_device(device) if device else None
    channels: dict[str, Channel] = {}
    for name, values in data.items():
        path = plan.channels[name]
        props = layout.channels[path].properties
        units, attrs = _channel_attrs(layout, plan, name, profile, modules)
        long_name = str(props.get("NI_ChannelName", name))
        for part in plan.parts.get(name, ()):  # a complex channel: one real variable per part
            channels[f"{name}.{part}"] = Channel(
                np.ascontiguousarray(getattr(values, part)), units,
                f"{long_name} ({part} part)", path, _scaling_text(props),
                {**attrs, "complex_part": part, "complex_type": str(values.dtype)})
        if name not in plan.parts:
            channels[name] = Channel(values, units, long_name, path, _scaling_text(props), attrs)
    attrs: dict[str, Any] = {
        **plan.attrs,
        "source_format": "tdms",
        "tdms_group": plan.group,
        "tdms_version": layout.version,
        **time_fallback_attrs(plan.fallbacks),
        "first_sample": start,
        "samples_in_file": plan.timebase.length,
    }
    if layout.problem:
        attrs["file_problem"] = layout.problem
    if profile is not None:
        attrs.update(profile.stream_attrs())
    return stream_dataset(
        plan.timebase, channels, device=profile.name if profile else "unknown",
        start_time=plan.start_time, source_file=layout.path, source_sha256=sha,
        fs_nominal=plan.fs_nominal, window=(start, stop), attrs=attrs)


def read_tdms(path: str | os.PathLike[str], *, group: str | Sequence[str] | None = None,
              channels: Sequence[str] | None = None,
              time_range: tuple[float | None, float | None] | None = None,
              device: str | None = None, modules: Mapping[str, str] | None = None,
              fs: float | None = None, include_decimated: bool = False,
              checksum: bool = True) -> dict[str, xr.Dataset]:
    """Read a TDMS file into stream Datasets, one per time base.

    Only the selected channels and the samples in ``time_range`` are read from disk.

    Parameters
    ----------
    path : str or path-like
        The ``.tdms`` file (a ``.tdms_index`` next to it is not used: it may be stale).
    group : str or sequence of str, optional
        Groups to read (default: all except SignalExpress decimated groups).
    channels : sequence of str, optional
        Channel names, ``"group/channel"`` or TDMS paths (default: every numeric channel).
    time_range : tuple of float or None, optional
        ``(t_from, t_to)`` in s since each stream's first sample, inclusive; None for an open end.
    device : str, optional
        Device profile (``"cDAQ-9172"``, ``"WLS-9163"``); default ``"unknown"``.
    modules : mapping of str to str, optional
        Channel name, physical channel (``NI_ChannelName``) or its prefix (``"cDAQ1Mod3"``) ->
        module (``"NI 9237"``); default: the device's module (NI 9237 for the WLS-9163).
    fs : float, optional
        Sampling rate in Hz for files without ``wf_increment``.
    include_decimated : bool
        Also read SignalExpress decimated groups.
    checksum : bool
        Compute ``source_sha256`` (default); False skips hashing large files.

    Returns
    -------
    dict of str to xarray.Dataset
        Stream name (the group name) -> stream (docs/formats.md, *What a stream carries*), in
        file order.

    Raises
    ------
    DataFileError
        Not a TDMS file, a Git-LFS pointer, or damaged before the first readable segment.
    ChannelNotFoundError
        An unknown group or channel (the message lists the available ones).

    Warns
    -----
    DataWarning
        Truncated or damaged files (recovered and expected sample counts), missing
        ``wf_increment``, restarts with overlapping start times, unsupported scales.
    """
    file = checked_path(path)
    with open(file, "rb") as handle:
        layout = scan_tdms(file, handle)
        plans = plan_tdms(layout, group=group, channels=channels, fs=fs,
                          include_decimated=include_decimated)
        if not plans:
            raise_empty(layout)
        warn_about_plans(layout, plans)
        windows = [(plan, *((0, plan.timebase.length) if time_range is None
                            else plan.timebase.index_range(*time_range))) for plan in plans]
        ranges = {p: (start, stop) for plan, start, stop in windows
                  for p in plan.channels.values()}
        plain = plain_selection(layout, ranges)
        daqmx = None if plain is not None else daqmx_selection(layout, ranges)
        if plain is not None or daqmx is not None:
            with plain_pages():
                values, sha = _read_direct_hashed(file, layout, plain, daqmx, checksum)
            return {plan.name: _build(layout, plan,
                                      {n: values[p] for n, p in plan.channels.items()},
                                      start, stop, device=device, modules=modules, sha=sha)
                    for plan, start, stop in windows}
        tdms = _open_nptdms(handle, layout)
        # the SHA-256 runs in a second thread (hashlib releases the GIL) while nptdms reads;
        # its cost per GiB is measured in docs/performance.md
        with ThreadPoolExecutor(max_workers=1) as pool, plain_pages():
            sha_future = pool.submit(source_checksum, file, checksum)
            selections = []
            for plan, start, stop in windows:
                data = {name: _read_values(tdms, p, start, stop - start, file)[:stop - start]
                        for name, p in plan.channels.items()}
                short = min(v.size for v in data.values())
                if short < stop - start:
                    raise DataFileError(f"nptdms returned {short} of {stop - start} values "
                                        "announced by the metadata", where={"file": str(file)},
                                        hint="the file may be damaged; see 'rigval info'")
                selections.append((plan, data, start, stop))
            sha = sha_future.result()
    return {plan.name: _build(layout, plan, data, start, stop, device=device, modules=modules,
                              sha=sha)
            for plan, data, start, stop in selections}


def _read_direct_hashed(file: Path, layout: TdmsLayout, plain: list[PlainChannel] | None,
                        daqmx: DaqmxSelection | None,
                        checksum: bool) -> tuple[dict[str, np.ndarray], str]:
    """Read plain (or else DAQmx) channels directly, hashing the file in the same pass.

    The file is not hashed again when its digest is known.

    Returns the values per object path and ``source_sha256`` (:data:`NOT_COMPUTED` without
    ``checksum``); a digest computed here is remembered while the file stays unchanged.
    """
    key = checksum_key(file) if checksum else None
    known = cached_checksum(key) if key is not None else None
    hash_it = key is not None and known is None
    if plain is not None:
        values, digest = read_plain(file, layout, plain, checksum=hash_it)
    else:
        assert daqmx is not None
        values, digest = read_daqmx(file, layout, daqmx, checksum=hash_it)
    if digest is not None and checksum_key(file) == key:
        remember_checksum(key, digest)
    return values, known or digest or NOT_COMPUTED


def iter_tdms(path: str | os.PathLike[str], *, group: str | None = None,
              channels: Sequence[str] | None = None, chunk_samples: int = 1 << 20,
              device: str | None = None, modules: Mapping[str, str] | None = None,
              fs: float | None = None, checksum: bool = True) -> Iterator[xr.Dataset]:
    """Stream one TDMS stream in windows of ``chunk_samples`` samples, in bounded memory.

    Each window is a stream Dataset (docs/formats.md, *What a stream carries*) whose ``time``
    continues the previous one; the attribute ``first_sample`` gives its first sample's index in
    the stream. Memory stays about ``chunk_samples x channels x 8`` bytes plus one file segment,
    whatever the file size.

    Parameters
    ----------
    path : str or path-like
        The ``.tdms`` file.
    group : str, optional
        Group to stream; required when the file holds several streams.
    channels : sequence of str, optional
        Channels to keep (default: all numeric channels of the stream).
    chunk_samples : int
        Samples per window (the last window may be shorter).
    device, modules, fs, checksum
        As for :func:`read_tdms`.

    Yields
    ------
    xarray.Dataset
        Consecutive windows of the stream.

    Raises
    ------
    DataFileError
        Damaged file, or the selection holds several streams.
    """
    file = checked_path(path)
    if chunk_samples < 1:
        raise ValueError(f"chunk_samples must be positive, got {chunk_samples}")
    with open(file, "rb") as handle:
        layout = scan_tdms(file, handle)
        plans = plan_tdms(layout, group=group, channels=channels, fs=fs)
        if len(plans) != 1:
            raise DataFileError(
                f"streaming needs exactly one stream, the selection holds {len(plans)}: "
                f"{[p.name for p in plans]}", where={"file": str(file)},
                hint="pass group=... and/or channels=... to pick one")
        plan = plans[0]
        warn_about_plans(layout, plans)
        # the SHA-256 runs in a second thread while nptdms opens the file and reads the first
        # window; every window carries the digest (docs/formats.md), so the first one waits for it
        with ThreadPoolExecutor(max_workers=1) as pool:
            sha = pool.submit(source_checksum, file, checksum)
            tdms = _open_nptdms(handle, layout)
            yield from _windows(tdms, layout, plan, chunk_samples, device, modules, sha)


def _windows(tdms: TdmsFile, layout: TdmsLayout, plan: TdmsStreamPlan, chunk_samples: int,
             device: str | None, modules: Mapping[str, str] | None,
             sha: Future[str]) -> Iterator[xr.Dataset]:
    """Accumulate nptdms data chunks into windows and yield them as stream Datasets.

    ``sha`` gives the file's ``source_sha256``; the first window waits for it.
    """
    total = plan.timebase.length
    names = {object_path_parts(p)[:2]: n for n, p in plan.channels.items()}
    pending: dict[str, list[np.ndarray]] = {n: [] for n in plan.channels}
    held = dict.fromkeys(plan.channels, 0)
    start = 0
    chunks = tdms.data_chunks()
    try:
        while True:
            with captured_nptdms_messages():
                chunk = next(chunks, None)
            if chunk is None:
                break
            group_chunk = chunk[plan.group]
            for channel_chunk in group_chunk.channels():
                name = names.get((plan.group, channel_chunk.name))
                if name is not None and len(channel_chunk):
                    pending[name].append(channel_chunk[:])
                    held[name] += len(channel_chunk)
            while start < total and min(held.values()) >= min(chunk_samples, total - start):
                stop = min(start + chunk_samples, total)
                window = {n: _take(pending[n], stop - start) for n in plan.channels}
                for n in plan.channels:
                    held[n] -= stop - start
                yield _build(layout, plan, window, start, stop, device=device, modules=modules,
                             sha=sha.result())
                start = stop
    except DataFileError:
        raise
    except Exception as error:  # nptdms on a damaged file
        raise DataFileError(f"cannot stream channel data: {type(error).__name__}: {error}",
                            where={"file": str(layout.path)},
                            hint="the file may be damaged; see 'rigval info'") from error


def _take(parts: list[np.ndarray], count: int) -> np.ndarray:
    """Remove and return the first ``count`` values of a list of arrays (in place)."""
    if parts and parts[0].size == count:
        return parts.pop(0)
    out = np.empty(count, dtype=parts[0].dtype)
    filled = 0
    while filled < count:
        part = parts[0]
        take = min(part.size, count - filled)
        out[filled:filled + take] = part[:take]
        filled += take
        if take == part.size:
            parts.pop(0)
        else:
            parts[0] = part[take:]
    return out
