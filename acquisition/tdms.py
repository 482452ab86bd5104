"""Read NI TDMS files into stream Datasets (one per time base).

nptdms reads and scales the values (DAQmx raw data, big-endian files, linear/polynomial/strain
scales); rigval builds the time axis itself from ``wf_start_time``, ``wf_start_offset`` and
``wf_increment`` of every segment (:mod:`rigval.acquisition.tdms_layout`), so that task restarts
become gaps and fallbacks are explicit:

==============================  ==========================================================
file says                       rigval does (and records in ``time_fallbacks``)
==============================  ==========================================================
no ``wf_start_offset``          offset 0 s (SignalExpress, LabVIEW Biomedical)
no ``wf_increment``             the ``fs`` option, else sample index with a DataWarning
``wf_increment`` with 6 digits  the exact interval (``timebase.exact_increment``)
``wf_start_time`` = 1904        relative time; ``start_time`` from ``NI_ExpStartTimeStamp``,
                                the group/file ``DateTime``, else 1904-01-01
no ``wf_start_time``            as 1904
new ``wf_start_time`` later     a restart: new block, gap kept (never interpolated)
==============================  ==========================================================

Channels of one group with the same interval, length and blocks form one stream; their start
times may differ by less than half a sample (convert delay of scanned modules): each channel keeps
its own offset in the attribute ``time_offset_s`` and the data are never shifted. SignalExpress
``Decimated Data_LevelN`` groups are skipped unless asked for.
"""

from __future__ import annotations

import io
import logging
import os
from collections.abc import Iterator, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np
import xarray as xr
from nptdms import TdmsFile

from rigval.acquisition.detect import checked_path, source_checksum
from rigval.acquisition.devices import DeviceProfile, get_device, module_attrs
from rigval.acquisition.errors import ChannelNotFoundError, DataFileError
from rigval.acquisition.hugepages import plain_pages
from rigval.acquisition.schema import Channel, stream_dataset
from rigval.acquisition.tdms_layout import (
    ChannelLayout,
    TdmsLayout,
    TdmsStamp,
    object_path_parts,
    scan_tdms,
)
from rigval.acquisition.tdms_log import captured_nptdms_messages
from rigval.acquisition.timebase import Block, TimeBase, exact_increment
from rigval.acquisition.warn import warn_data

__all__ = ["TdmsStreamPlan", "iter_tdms", "plan_tdms", "read_tdms", "warn_about_plans"]

logger = logging.getLogger(__name__)

_NUMERIC_TYPES = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 0x19, 0x1A, 0xFFFFFFFF}
_SUPPORTED_SCALES = {"Linear", "Polynomial", "RTD", "Strain", "Table", "Thermistor",
                     "Thermocouple", "Add", "Subtract", "AdvancedAPI"}
_EPOCH_1904 = TdmsStamp(0, 0)
#: A ``wf_start_offset`` beyond this (s, about 115 days) is taken as damage, not as an offset.
_MAX_OFFSET_S = 1e7
#: A ``wf_increment`` outside these bounds (s: 1 THz, about 115 days) is taken as damage.
_MIN_DT_S, _MAX_DT_S = 1e-12, 1e7


@dataclass
class _ChannelTime:
    """Time description of one channel: blocks relative to its own first sample."""

    start: TdmsStamp | None  # absolute time of the first sample (None: unknown / relative)
    relative: bool
    blocks: list[tuple[int, int, float]]  # (first index, n, seconds since first sample)
    dt: float
    notes: list[str]


@dataclass
class TdmsStreamPlan:
    """One stream of a TDMS file before its data are read.

    Attributes
    ----------
    name : str
        Stream name (the group name; ``"<group>@<fs>Hz"`` when a group holds several rates).
    group : str
        TDMS group.
    channels : dict
        Variable name -> channel object path.
    offsets : dict
        Variable name -> start offset in s relative to the stream's first sample.
    timebase : TimeBase
        Time axis of all samples.
    start_time : numpy.datetime64
        Absolute time of the first sample (naive UTC, ns).
    fs_nominal : float
        1 / dt, Hz.
    notes : list of str
        Time-axis fallbacks applied.
    lengths : dict
        Variable name -> values readable from the file (before cropping to whole samples).
    expected : dict
        Variable name -> values the file announces.
    attrs : dict
        Further stream attributes.
    """

    name: str
    group: str
    channels: dict[str, str]
    offsets: dict[str, float]
    timebase: TimeBase
    start_time: np.datetime64
    fs_nominal: float
    notes: list[str]
    lengths: dict[str, int]
    expected: dict[str, int]
    attrs: dict[str, Any] = field(default_factory=dict)


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


def _is_decimated(group: str, properties: Mapping[str, Any]) -> bool:
    """Return True for SignalExpress decimated-data groups."""
    level = properties.get("DecimationLevel", 0)
    return "Decimated Data_Level" in group or (isinstance(level, int | np.integer) and level > 0)


def _channel_time(layout: ChannelLayout, fs: float | None, group_props: Mapping[str, Any],
                  root_props: Mapping[str, Any]) -> _ChannelTime:
    """Build a channel's blocks from its time marks, applying and noting the fallbacks."""
    notes: list[str] = []
    props = layout.properties
    first_marks: dict[str, Any] = {}
    for _, marks in layout.time_marks:
        for key, value in marks.items():
            first_marks.setdefault(key, value)
    dt_raw = first_marks.get("wf_increment")
    if _finite(dt_raw, None) is None or not _MIN_DT_S <= dt_raw <= _MAX_DT_S:
        if fs is not None:
            dt = 1.0 / fs
            notes.append(f"no usable wf_increment ({dt_raw!r}): dt = 1/fs from the fs option")
        else:
            dt = 1.0
            notes.append(f"no usable wf_increment ({dt_raw!r}): time is the sample index")
    else:
        dt = float(dt_raw)
        exact = exact_increment(dt)
        if exact is not None:
            notes.append(f"wf_increment {dt!r} rounded in the file: using {exact!r} s "
                         f"({1.0 / exact:.9g} Hz)")
            dt = exact
    offset = _finite(first_marks.get("wf_start_offset"), None)
    if offset is None:
        notes.append("no wf_start_offset: taken as 0 s")
        offset = 0.0
    elif abs(offset) > _MAX_OFFSET_S:
        notes.append(f"wf_start_offset {offset!r} s is implausible: taken as 0 s")
        offset = 0.0
    t0 = first_marks.get("wf_start_time")
    if isinstance(t0, TdmsStamp) and not t0.in_range():
        notes.append(f"wf_start_time out of range ({t0.seconds} s since 1904): ignored")
        t0 = None
    relative = not isinstance(t0, TdmsStamp) or t0.is_zero()
    start: TdmsStamp | None = None
    if relative:
        what = "no wf_start_time" if t0 is None else "wf_start_time is 1904-01-01 (relative time)"
        for key, source in (("NI_ExpStartTimeStamp", props), ("DateTime", group_props),
                            ("DateTime", root_props)):
            if isinstance(source.get(key), TdmsStamp) and source[key].in_range():
                start = source[key]
                notes.append(f"{what}: start_time from {key}")
                break
        else:
            notes.append(f"{what}: start_time unknown (1904-01-01)")
    else:
        start = t0
    blocks = _blocks(layout, dt, float(offset), notes)
    if start is not None and not relative:
        start = _add_seconds(start, float(offset))
    return _ChannelTime(start, relative, blocks, dt, notes)


def _finite(value: Any, default: float | None) -> float | None:
    """Return ``value`` as a float if it is a finite number, else ``default``."""
    if isinstance(value, int | float) and not isinstance(value, bool) and np.isfinite(value):
        return float(value)
    return default


def _add_seconds(stamp: TdmsStamp, seconds: float) -> TdmsStamp:
    """Return ``stamp + seconds``."""
    whole = int(np.floor(seconds))
    fraction = stamp.fraction + round((seconds - whole) * 2.0**64)
    carry, fraction = divmod(fraction, 1 << 64)
    return TdmsStamp(stamp.seconds + whole + carry, fraction)


def _blocks(layout: ChannelLayout, dt: float, offset0: float,
            notes: list[str]) -> list[tuple[int, int, float]]:
    """Split a channel at restarts (a later segment with a new ``wf_start_time``)."""
    starts: list[tuple[int, float]] = [(0, 0.0)]
    t0: TdmsStamp | None = None
    offset = offset0
    block_t0: TdmsStamp | None = None
    for index, marks in layout.time_marks:
        new_t0 = marks.get("wf_start_time")
        if not (isinstance(new_t0, TdmsStamp) and new_t0.in_range()):
            new_t0 = None
        offset = _finite(marks.get("wf_start_offset"), offset)
        if abs(offset) > _MAX_OFFSET_S:
            offset = offset0
        if t0 is None or block_t0 is None:
            t0 = block_t0 = new_t0
            continue
        if index == 0 or new_t0 is None or new_t0 == t0:
            continue
        first, at = starts[-1]
        declared = new_t0.seconds_since(block_t0) - at + offset - offset0
        expected = (index - first) * dt
        t0 = new_t0
        if abs(declared - expected) <= 0.5 * dt:
            continue
        if declared < expected:
            notes.append(f"restart at sample {index}: its wf_start_time lies "
                         f"{expected - declared:.6g} s before the end of the previous block; "
                         "placed right after it")
            declared = expected
        starts.append((index, at + declared))
    blocks = []
    for k, (first, at) in enumerate(starts):
        end = starts[k + 1][0] if k + 1 < len(starts) else layout.length
        blocks.append((first, end - first, at))
    return blocks


def _select_groups(layout: TdmsLayout, group: str | Sequence[str] | None,
                   include_decimated: bool) -> list[str]:
    """Return the groups to read, in file order."""
    groups: list[str] = []
    for path in layout.channels:
        name = object_path_parts(path)[0]
        if name not in groups:
            groups.append(name)
    if group is not None:
        wanted = [group] if isinstance(group, str) else list(group)
        missing = [g for g in wanted if g not in groups]
        if missing:
            raise ChannelNotFoundError(f"group {missing[0]!r} not in the file",
                                       where={"file": str(layout.path)}, available=groups)
        return wanted
    kept = [g for g in groups
            if include_decimated or not _is_decimated(g, layout.group_properties.get(g, {}))]
    skipped = [g for g in groups if g not in kept]
    if skipped:
        logger.info("%s: skipped SignalExpress decimated groups %s (include_decimated=True "
                    "reads them)", layout.path, skipped)
    return kept


def _match_channels(layout: TdmsLayout, groups: list[str],
                    channels: Sequence[str] | None) -> list[str]:
    """Return the object paths of the numeric channels to read."""
    candidates = [p for p in layout.channels if object_path_parts(p)[0] in groups]
    if channels is None:
        return [p for p in candidates if layout.channels[p].data_type in _NUMERIC_TYPES
                and layout.channels[p].expected_length > 0]
    chosen = []
    for wanted in channels:
        hits = [p for p in candidates
                if wanted in (p, object_path_parts(p)[1], "/".join(object_path_parts(p)))]
        if not hits:
            raise ChannelNotFoundError(
                f"channel {wanted!r} not in the file", where={"file": str(layout.path)},
                available=[object_path_parts(p)[1] for p in candidates],
                hint="name a channel as written in the file, or as 'group/channel'")
        if len(hits) > 1:
            raise ChannelNotFoundError(
                f"channel {wanted!r} is in several groups", where={"file": str(layout.path)},
                available=["/".join(object_path_parts(p)) for p in hits],
                hint="name it as 'group/channel'")
        chosen.append(hits[0])
    return chosen


def plan_tdms(layout: TdmsLayout, *, group: str | Sequence[str] | None = None,
              channels: Sequence[str] | None = None, fs: float | None = None,
              include_decimated: bool = False) -> list[TdmsStreamPlan]:
    """Group a file's channels into streams from its metadata alone.

    Parameters
    ----------
    layout : TdmsLayout
        From :func:`~rigval.acquisition.tdms_layout.scan_tdms`.
    group : str or sequence of str, optional
        Groups to read (default: all but SignalExpress decimated groups).
    channels : sequence of str, optional
        Channel names, ``group/channel`` or object paths (default: all numeric channels).
    fs : float, optional
        Sampling rate in Hz for channels without ``wf_increment``.
    include_decimated : bool
        Also read SignalExpress ``Decimated Data_LevelN`` groups.

    Returns
    -------
    list of TdmsStreamPlan
        In file order.
    """
    groups = _select_groups(layout, group, include_decimated)
    paths = _match_channels(layout, groups, channels)
    plans: list[TdmsStreamPlan] = []
    pending: dict[str, list[tuple[str, _ChannelTime]]] = {}
    for path in paths:
        channel = layout.channels[path]
        group_name, name = object_path_parts(path)[:2]
        if channel.data_type not in _NUMERIC_TYPES:
            raise DataFileError(f"channel {name!r} holds no numeric samples",
                                where={"file": str(layout.path), "channel": path},
                                hint="rigval reads numeric waveforms only")
        info = _channel_time(channel, fs, layout.group_properties.get(group_name, {}),
                             layout.root_properties)
        pending.setdefault(group_name, []).append((path, info))
    for group_name, members in pending.items():
        streams: list[list[tuple[str, _ChannelTime]]] = []
        for path, info in members:
            for stream in streams:
                if _same_time_base(stream[0], (path, info), layout):
                    stream.append((path, info))
                    break
            else:
                streams.append([(path, info)])
        rates = [1.0 / stream[0][1].dt for stream in streams]
        for stream in streams:
            plan = _plan(layout, group_name, stream, several=len(streams) > 1)
            if len(streams) > 1 and rates.count(1.0 / stream[0][1].dt) > 1:
                # several streams at one rate differ in length: say so in the name
                plan.name = f"{plan.name}[{max(plan.expected.values())}]"
            plans.append(plan)
    names = [p.name for p in plans]
    for plan in plans:
        if names.count(plan.name) > 1:
            plan.name = f"{plan.name}#{plans.index(plan)}"
    return plans


def _same_time_base(a: tuple[str, _ChannelTime], b: tuple[str, _ChannelTime],
                    layout: TdmsLayout) -> bool:
    """Return True if two channels share a time base (same dt, blocks; starts within dt/2)."""
    (pa, ia), (pb, ib) = a, b
    if abs(ia.dt - ib.dt) > 1e-9 * ia.dt or len(ia.blocks) != len(ib.blocks):
        return False
    ca, cb = layout.channels[pa], layout.channels[pb]
    if ca.expected_length != cb.expected_length:
        return False  # channels of different lengths are different streams, whatever dt says
    if ca.length != cb.length:
        # only a truncated contiguous final chunk may leave channels a few values apart
        last = max(ca.counts[-1:] + cb.counts[-1:] + [0])
        if layout.problem is None or abs(ca.length - cb.length) > last:
            return False
    for (fa, na, ta), (fb, nb, tb) in zip(ia.blocks[:-1], ib.blocks[:-1], strict=True):
        if fa != fb or na != nb or abs(ta - tb) > 0.5 * ia.dt:
            return False
    if ia.relative != ib.relative:
        return False
    if ia.start is not None and ib.start is not None and not ia.relative:
        return abs(ib.start.seconds_since(ia.start)) < 0.5 * ia.dt
    return True


def _plan(layout: TdmsLayout, group: str, members: list[tuple[str, _ChannelTime]],
          several: bool) -> TdmsStreamPlan:
    """Build the plan of one stream from its channels."""
    ref = members[0][1]
    if not ref.relative and ref.start is not None:
        first = ref.start
        ref = min((info for _, info in members),
                  key=lambda info: info.start.seconds_since(first) if info.start else 0.0)
    names: dict[str, str] = {}
    offsets: dict[str, float] = {}
    for path, info in members:
        name = object_path_parts(path)[1]
        if name in names:
            name = path
        names[name] = path
        offset = 0.0
        if not info.relative and info.start is not None and ref.start is not None:
            offset = round(info.start.seconds_since(ref.start), 12)
        offsets[name] = offset
    lengths = {n: layout.channels[p].length for n, p in names.items()}
    n = min(lengths.values())
    blocks = []
    for first, count, at in ref.blocks:
        count = max(0, min(count, n - first))
        blocks.append(Block(first, count, at, ref.dt))
    start = ref.start if ref.start is not None else _EPOCH_1904
    notes = sorted({note for _, info in members for note in info.notes})
    fs_nominal = 1.0 / ref.dt
    name = group if not several else f"{group}@{fs_nominal:.6g}Hz"
    return TdmsStreamPlan(
        name=name, group=group, channels=names, offsets=offsets, timebase=TimeBase(blocks),
        start_time=start.to_datetime64(), fs_nominal=fs_nominal, notes=notes, lengths=lengths,
        expected={k: layout.channels[p].expected_length for k, p in names.items()},
        attrs={"relative_time": int(ref.relative)},
    )


def _scaling_text(props: Mapping[str, Any]) -> str:
    """Describe the NI scaling nptdms applied to a channel."""
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
    return ("DAQmx raw data scaled by nptdms: " + "; ".join(parts)) if parts else "none"


def _unsupported_scale(props: Mapping[str, Any]) -> str | None:
    """Return a scale type nptdms cannot apply (it then returns raw values), else None."""
    if props.get("NI_Scaling_Status") == "scaled":
        return None
    for key, value in props.items():
        if key.endswith("_Scale_Type") and value not in _SUPPORTED_SCALES:
            return str(value)
    return None


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
    if data.dtype.kind not in "iufb":
        raise DataFileError(f"channel holds {data.dtype} values, not numbers",
                            where={"file": str(file), "channel": path})
    return data


def _warn_truncation(layout: TdmsLayout, plan: TdmsStreamPlan) -> None:
    """Warn once per stream with recovered and expected counts when samples are missing."""
    n = plan.timebase.length
    expected = max(plan.expected.values())
    longest = max(plan.lengths.values())
    if expected > n or longest > n or layout.problem:
        dropped = {k: v - n for k, v in plan.lengths.items() if v > n}
        text = (f"stream {plan.name!r}: recovered {n} of {expected} samples per channel"
                + (f" ({layout.problem})" if layout.problem else ""))
        if dropped:
            text += f"; values past the last whole sample not used: {dropped}"
        if layout.good_end < layout.file_size:
            text += (f"; bytes {layout.good_end} to {layout.file_size} not read "
                     "(any samples there are lost)")
        damaged = layout.problem is not None and layout.problem.startswith("damaged")
        warn_data(text, where={"file": str(layout.path)},
                  hint=("the file is damaged there; the segments before the damage were read"
                        if damaged else "the file was cut short (crash, copy or still being "
                        "written)"), stacklevel=4)


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
        channels[name] = Channel(values, units, str(props.get("NI_ChannelName", name)), path,
                                 _scaling_text(props), attrs)
    attrs: dict[str, Any] = {
        **plan.attrs,
        "source_format": "tdms",
        "tdms_group": plan.group,
        "tdms_version": layout.version,
        "time_fallbacks": "\n".join(plan.notes),
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


def warn_about_plans(layout: TdmsLayout, plans: list[TdmsStreamPlan]) -> None:
    """Warn about what the plans found: truncation, an unusable time axis, unapplied scales.

    Parameters
    ----------
    layout : TdmsLayout
        The file's structure.
    plans : list of TdmsStreamPlan
        From :func:`plan_tdms`.

    Warns
    -----
    DataWarning
        One per problem, with counts; benign fallbacks are logged at INFO level instead.
    """
    for note in layout.notes:
        warn_data(f"damaged metadata: {note}", where={"file": str(layout.path)},
                  hint="the file is damaged; check the values of the named segment",
                  stacklevel=3)
    for plan in plans:
        _warn_truncation(layout, plan)
        for note in plan.notes:
            if "time is the sample index" in note or "restart at sample" in note:
                warn_data(f"stream {plan.name!r}: {note}",
                                          where={"file": str(layout.path)},
                                          hint="pass fs=... if the rate is known", stacklevel=3)
            else:
                logger.info("%s, stream %r: %s", layout.path, plan.name, note)
        for name, path in plan.channels.items():
            scale = _unsupported_scale(layout.channels[path].properties)
            if scale is not None:
                warn_data(
                    f"scale type {scale!r} is not applied by nptdms: channel {name!r} holds raw "
                    "values", where={"file": str(layout.path), "channel": path},
                    hint="convert the raw values in processing", stacklevel=3)


def _raise_empty(layout: TdmsLayout) -> None:
    """Raise the DataFileError for a file (selection) without one numeric sample."""
    found = [f"{'/'.join(object_path_parts(p))} ({c.length} values)"
             for p, c in layout.channels.items()]
    raise DataFileError(
        "no numeric channel with samples" + (f" before the damage ({layout.problem})"
                                             if layout.problem else "")
        + (f"; channels found: {found}" if found else "; the file holds no channels"),
        where={"file": str(layout.path)},
        hint=("the file is damaged; see 'rigval info'" if layout.problem else
              "choose a group/channels holding waveforms (include_decimated=True for "
              "SignalExpress decimated groups)"))


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
            _raise_empty(layout)
        warn_about_plans(layout, plans)
        tdms = _open_nptdms(handle, layout)
        # hashing (about 0.7 s per GiB) runs on the other core while nptdms reads
        with ThreadPoolExecutor(max_workers=1) as pool, plain_pages():
            sha_future = pool.submit(source_checksum, file, checksum)
            selections = []
            for plan in plans:
                start, stop = (0, plan.timebase.length) if time_range is None else \
                    plan.timebase.index_range(*time_range)
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
        sha = source_checksum(file, checksum)
        tdms = _open_nptdms(handle, layout)
        yield from _windows(tdms, layout, plan, chunk_samples, device, modules, sha)


def _windows(tdms: TdmsFile, layout: TdmsLayout, plan: TdmsStreamPlan, chunk_samples: int,
             device: str | None, modules: Mapping[str, str] | None,
             sha: str) -> Iterator[xr.Dataset]:
    """Accumulate nptdms data chunks into windows and yield them as stream Datasets."""
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
                             sha=sha)
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
