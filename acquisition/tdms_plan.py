"""Plan the streams of a TDMS file from its metadata alone: time bases, fallbacks, warnings.

rigval builds the time axis itself from ``wf_start_time``, ``wf_start_offset`` and
``wf_increment`` of every segment (:mod:`rigval.acquisition.tdms_layout`), so that task restarts
become gaps and fallbacks are explicit:

==============================  ==========================================================
file says                       rigval does (and records as a ``TimeFallback``)
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

No sample is read here: :mod:`rigval.acquisition.tdms` reads the data of the plans, and
``rigval info`` describes a file from its plans without importing xarray or nptdms.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rigval.acquisition.errors import ChannelNotFoundError, DataFileError
from rigval.acquisition.tdms_layout import ChannelLayout, TdmsLayout, TdmsStamp, object_path_parts
from rigval.acquisition.time_fallbacks import TimeFallback
from rigval.acquisition.timebase import Block, TimeBase, exact_increment
from rigval.acquisition.warn import warn_data

__all__ = ["COMPLEX_PARTS", "TdmsStreamPlan", "plan_tdms", "raise_empty", "warn_about_plans"]

logger = logging.getLogger(__name__)

_NUMERIC_TYPES = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 0x19, 0x1A, 0xFFFFFFFF}
#: Names of the TDMS value types rigval does not read as waveforms (type code -> name).
_UNREAD_TYPES = {0: "void", 11: "extended float", 0x1B: "extended float with unit",
                 0x20: "text", 0x21: "boolean", 0x44: "timestamp", 0x08000C: "complex64",
                 0x10000D: "complex128"}
_COMPLEX_TYPES = {0x08000C, 0x10000D}
_READ_TYPES = _NUMERIC_TYPES | _COMPLEX_TYPES
#: The real variables a complex channel is read as: ``<channel>.real`` and ``<channel>.imag``.
COMPLEX_PARTS = ("real", "imag")
_SUPPORTED_SCALES = {"Linear", "Polynomial", "RTD", "Strain", "Table", "Thermistor",
                     "Thermocouple", "Add", "Subtract", "AdvancedAPI"}
_EPOCH_1904 = TdmsStamp(0, 0)
#: A ``wf_start_offset`` beyond this (s, about 115 days) is taken as damage, not as an offset.
_MAX_OFFSET_S = 1e7
#: A ``wf_increment`` outside these bounds (s: 1 THz, about 115 days) is taken as damage.
_MIN_DT_S, _MAX_DT_S = 1e-12, 1e7
#: The fallbacks that are warned about (the others are logged): no interval, a restart moved.
_SAMPLE_INDEX, _PLACED_AFTER = "time is the sample index", "placed right after it"


@dataclass
class _ChannelTime:
    """Time description of one channel: blocks relative to its own first sample."""

    start: TdmsStamp | None  # absolute time of the first sample (None: unknown / relative)
    relative: bool
    blocks: list[tuple[int, int, float]]  # (first index, n, seconds since first sample)
    dt: float
    fallbacks: list[tuple[str, str]]  # (reason, what was used instead)


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
    fallbacks : tuple of TimeFallback
        Time-axis fallbacks applied, sorted (channel ``""``: all of the stream's channels).
    lengths : dict
        Variable name -> values readable from the file (before cropping to whole samples).
    expected : dict
        Variable name -> values the file announces.
    attrs : dict
        Further stream attributes.
    parts : dict
        Variable name of a complex channel -> the parts to read (of :data:`COMPLEX_PARTS`).
    """

    name: str
    group: str
    channels: dict[str, str]
    offsets: dict[str, float]
    timebase: TimeBase
    start_time: np.datetime64
    fs_nominal: float
    fallbacks: tuple[TimeFallback, ...]
    lengths: dict[str, int]
    expected: dict[str, int]
    attrs: dict[str, Any] = field(default_factory=dict)
    parts: dict[str, tuple[str, ...]] = field(default_factory=dict)


def _is_decimated(group: str, properties: Mapping[str, Any]) -> bool:
    """Return True for SignalExpress decimated-data groups."""
    level = properties.get("DecimationLevel", 0)
    return "Decimated Data_Level" in group or (isinstance(level, int | np.integer) and level > 0)


def _channel_time(layout: ChannelLayout, fs: float | None, group_props: Mapping[str, Any],
                  root_props: Mapping[str, Any]) -> _ChannelTime:
    """Build a channel's blocks from its time marks, applying and noting the fallbacks."""
    notes: list[tuple[str, str]] = []
    props = layout.properties
    first_marks: dict[str, Any] = {}
    for _, marks in layout.time_marks:
        for key, value in marks.items():
            first_marks.setdefault(key, value)
    dt_raw = first_marks.get("wf_increment")
    if _finite(dt_raw, None) is None or not _MIN_DT_S <= dt_raw <= _MAX_DT_S:
        if fs is not None:
            dt = 1.0 / fs
            notes.append((f"no usable wf_increment ({dt_raw!r})", "dt = 1/fs from the fs option"))
        else:
            dt = 1.0
            notes.append((f"no usable wf_increment ({dt_raw!r})", _SAMPLE_INDEX))
    else:
        dt = float(dt_raw)
        exact = exact_increment(dt)
        if exact is not None:
            notes.append((f"wf_increment {dt!r} rounded in the file",
                          f"using {exact!r} s ({1.0 / exact:.9g} Hz)"))
            dt = exact
    offset = _finite(first_marks.get("wf_start_offset"), None)
    if offset is None:
        notes.append(("no wf_start_offset", "taken as 0 s"))
        offset = 0.0
    elif abs(offset) > _MAX_OFFSET_S:
        notes.append((f"wf_start_offset {offset!r} s is implausible", "taken as 0 s"))
        offset = 0.0
    t0 = first_marks.get("wf_start_time")
    if isinstance(t0, TdmsStamp) and not t0.in_range():
        notes.append((f"wf_start_time out of range ({t0.seconds} s since 1904)", "ignored"))
        t0 = None
    relative = not isinstance(t0, TdmsStamp) or t0.is_zero()
    start: TdmsStamp | None = None
    if relative:
        what = "no wf_start_time" if t0 is None else "wf_start_time is 1904-01-01 (relative time)"
        for key, source in (("NI_ExpStartTimeStamp", props), ("DateTime", group_props),
                            ("DateTime", root_props)):
            if isinstance(source.get(key), TdmsStamp) and source[key].in_range():
                start = source[key]
                notes.append((what, f"start_time from {key}"))
                break
        else:
            notes.append((what, "start_time unknown (1904-01-01)"))
    else:
        start = t0
    blocks = _blocks(layout, dt, float(offset), notes)
    if start is not None and not relative:
        start = _add_seconds(start, float(offset))
    return _ChannelTime(start, relative, blocks, dt, notes)


def _fallbacks(members: Mapping[str, _ChannelTime]) -> tuple[TimeFallback, ...]:
    """Return a stream's fallbacks: once when every channel has one, else once per channel."""
    found = {pair for info in members.values() for pair in info.fallbacks}
    records = []
    for reason, used in found:
        having = [name for name, info in members.items() if (reason, used) in info.fallbacks]
        if len(having) == len(members):
            records.append(TimeFallback(reason, used))
        else:
            records.extend(TimeFallback(reason, used, name) for name in having)
    return tuple(sorted(records))


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
            notes: list[tuple[str, str]]) -> list[tuple[int, int, float]]:
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
            notes.append((f"restart at sample {index}: its wf_start_time lies "
                          f"{expected - declared:.6g} s before the end of the previous block",
                          _PLACED_AFTER))
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
                    channels: Sequence[str] | None) -> dict[str, tuple[str, ...]]:
    """Return the object paths of the channels to read, each with the complex parts to read.

    A real channel has no parts (``()``); a complex channel is asked for by its name (both
    parts) or as ``<name>.real`` / ``<name>.imag``.
    """
    candidates = [p for p in layout.channels if object_path_parts(p)[0] in groups]
    if channels is None:
        _warn_unread(layout, [p for p in candidates
                              if layout.channels[p].data_type not in _READ_TYPES])
        return {p: _parts(layout, p) for p in candidates
                if layout.channels[p].data_type in _READ_TYPES
                and layout.channels[p].expected_length > 0}
    chosen: dict[str, tuple[str, ...]] = {}
    for wanted in channels:
        parts: tuple[str, ...] | None = None
        hits = _hits(candidates, wanted)
        stem, _, part = wanted.rpartition(".")
        if not hits and part in COMPLEX_PARTS:
            hits = [p for p in _hits(candidates, stem)
                    if layout.channels[p].data_type in _COMPLEX_TYPES]
            parts = (part,)
        if not hits:
            raise ChannelNotFoundError(
                f"channel {wanted!r} not in the file", where={"file": str(layout.path)},
                available=[object_path_parts(p)[1] for p in candidates],
                hint="a complex channel C is read as 'C.real' and 'C.imag'")
        if len(hits) > 1:
            raise ChannelNotFoundError(
                f"channel {wanted!r} is in several groups", where={"file": str(layout.path)},
                available=["/".join(object_path_parts(p)) for p in hits],
                hint="name it as 'group/channel'")
        path = hits[0]
        whole = _parts(layout, path) if parts is None else parts
        chosen[path] = tuple(p for p in COMPLEX_PARTS if p in chosen.get(path, ()) + whole)
    return chosen


def _hits(candidates: list[str], wanted: str) -> list[str]:
    """Return the object paths named by ``wanted``: a path, a channel or ``group/channel``."""
    return [p for p in candidates
            if wanted in (p, object_path_parts(p)[1], "/".join(object_path_parts(p)))]


def _parts(layout: TdmsLayout, path: str) -> tuple[str, ...]:
    """Return the parts a channel is read as: both for a complex channel, none for a real one."""
    return COMPLEX_PARTS if layout.channels[path].data_type in _COMPLEX_TYPES else ()


def _type_name(data_type: int | None) -> str:
    """Return a readable name of a TDMS value type."""
    if data_type is None:
        return "no type"
    return _UNREAD_TYPES.get(data_type, f"type 0x{data_type:X}")


def _warn_unread(layout: TdmsLayout, paths: list[str]) -> None:
    """Warn about channels holding values that are not numbers (text, time stamps, booleans).

    Such a channel is not read; the DataWarning names each one with its value type and count,
    so that nothing is left out silently. Complex channels are read (as their two parts).
    """
    unread = [f"{'/'.join(object_path_parts(p))} ({_type_name(layout.channels[p].data_type)}, "
              f"{layout.channels[p].length} values)"
              for p in paths if layout.channels[p].length > 0]
    if unread:
        warn_data(f"{len(unread)} channel(s) hold values that are not numbers and are not "
                  f"read: {'; '.join(unread)}", where={"file": str(layout.path)},
                  hint="rigval reads numeric waveforms; export them as numeric channels to use "
                  "them", stacklevel=4)


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
        if channel.data_type not in _READ_TYPES:
            raise DataFileError(f"channel {name!r} holds {_type_name(channel.data_type)} values "
                                f"({channel.length}), not numeric samples",
                                where={"file": str(layout.path), "channel": path},
                                hint="rigval reads numeric waveforms (real or complex) only")
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
            plan.parts = {n: paths[p] for n, p in plan.channels.items() if paths[p]}
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
        last = max([*ca.counts[-1:], *cb.counts[-1:], 0])
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
    times: dict[str, _ChannelTime] = {}
    for path, info in members:
        name = object_path_parts(path)[1]
        if name in names:
            name = path
        names[name] = path
        times[name] = info
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
    fs_nominal = 1.0 / ref.dt
    name = group if not several else f"{group}@{fs_nominal:.6g}Hz"
    return TdmsStreamPlan(
        name=name, group=group, channels=names, offsets=offsets, timebase=TimeBase(blocks),
        start_time=start.to_datetime64(), fs_nominal=fs_nominal, fallbacks=_fallbacks(times),
        lengths=lengths,
        expected={k: layout.channels[p].expected_length for k, p in names.items()},
        attrs={"relative_time": int(ref.relative)},
    )


def _unsupported_scale(props: Mapping[str, Any]) -> str | None:
    """Return a scale type nptdms cannot apply (it then returns raw values), else None."""
    if props.get("NI_Scaling_Status") == "scaled":
        return None
    for key, value in props.items():
        if key.endswith("_Scale_Type") and value not in _SUPPORTED_SCALES:
            return str(value)
    return None


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
        for fallback in plan.fallbacks:
            if fallback.used in (_SAMPLE_INDEX, _PLACED_AFTER):
                warn_data(f"stream {plan.name!r}: {fallback.text()}",
                                          where={"file": str(layout.path)},
                                          hint="pass fs=... if the rate is known", stacklevel=3)
            else:
                logger.info("%s, stream %r: %s", layout.path, plan.name, fallback.text())
        for name, path in plan.channels.items():
            scale = _unsupported_scale(layout.channels[path].properties)
            if scale is not None:
                warn_data(
                    f"scale type {scale!r} is not applied by nptdms: channel {name!r} holds raw "
                    "values", where={"file": str(layout.path), "channel": path},
                    hint="convert the raw values in processing", stacklevel=3)


def raise_empty(layout: TdmsLayout) -> None:
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

