"""The stream schema: one place that builds and checks the Dataset every reader returns.

A *stream* is one device's channels sharing one time base (docs/formats.md, "Stream schema"). It
is an :class:`xarray.Dataset` (``Conventions = "CF-1.13"``) with

- dim ``time``: seconds on the device's own clock since its first sample (float64, strictly
  increasing, gaps kept as jumps, never filled). The coordinate carries the CF attributes
  ``units = "seconds since <start_time>"``, ``calendar = "standard"``, ``standard_name = "time"``,
  so ``xr.decode_cf`` and ``xr.open_dataset`` turn it into wall-clock ``datetime64``; in memory
  it stays float seconds. Readers that know the time base as blocks (TDMS) give a lazy index
  (:mod:`rigval.acquisition.time_index`) that computes times on access;
- one variable per channel with ``units`` (UDUNITS), ``long_name``, ``source_channel`` and
  ``scaling`` (what was applied to reach these values), plus any sensor metadata;
- ``valid`` (bool, time): False for samples that exist in the file but cannot be used; the reasons
  and counts are the attributes ``invalid_reason`` (list of str) and ``invalid_count`` (int64
  array; see :func:`invalid_counts`);
- ``segment`` (int32, time): index of the gap-free segment each sample belongs to;
- the gap table as array attributes, one entry per gap: ``gap_start_s`` (time of the last
  sample before the gap), ``gap_end_s`` (of the first sample after it), ``gap_missing_samples``
  (see :func:`stream_gaps`). Attributes, not variables on a ``gap`` dimension, so that
  ``ds.to_dataframe()`` stays one row per sample;
- attributes ``device``, ``start_time`` (ISO 8601 UTC), ``source_file``, ``source_sha256``,
  ``fs_nominal`` (Hz), ``gap_count`` and ``missing_samples``.

``valid`` and ``segment`` of a stream without invalid samples or gaps are read-only broadcast
views (no memory per sample); replace them rather than writing into them.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import itertools
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from rigval.acquisition.errors import DataError
from rigval.acquisition.stream_attrs import attr_list
from rigval.acquisition.timebase import TimeBase

__all__ = [
    "REQUIRED_STREAM_ATTRS",
    "Channel",
    "append_history",
    "cf_time_attrs",
    "check_stream",
    "file_sha256",
    "invalid_counts",
    "parse_start_time",
    "stream_dataset",
    "stream_gaps",
    "string_table",
    "string_table_attrs",
    "utc_iso",
    "with_invalid_counts",
]

REQUIRED_STREAM_ATTRS = ("device", "start_time", "source_file", "source_sha256", "fs_nominal",
                         "gap_count", "missing_samples", "gap_start_s", "gap_end_s",
                         "gap_missing_samples", "invalid_reason", "invalid_count")
REQUIRED_CHANNEL_ATTRS = ("units", "long_name", "source_channel", "scaling")

#: A step between samples larger than this many nominal sample intervals is a gap.
GAP_FACTOR = 1.5


@dataclass(frozen=True)
class Channel:
    """One channel's samples and metadata, as a reader hands it to :func:`stream_dataset`.

    Parameters
    ----------
    data : numpy.ndarray
        Samples, one per time stamp, in ``units``.
    units : str
        UDUNITS string: ``"m s-2"``, ``"N m"``, ``"Pa"``, ``"rad"``, ``"V"``, ``"1"`` for strain or
        counts.
    long_name : str
        Human-readable name used in plot labels.
    source_channel : str
        Where the data came from, e.g. the TDMS path ``/'Group'/'Channel'`` or a CSV column name.
    scaling : str
        What was applied to the stored values to obtain ``data`` (``"none"``,
        ``"linear 2.5e-4 V/LSB"``).
    attrs : mapping
        Sensor metadata (``sensor_id``, ``gauge_factor``, ``bridge_type``, ...).
    """

    data: np.ndarray
    units: str
    long_name: str
    source_channel: str
    scaling: str = "none"
    attrs: Mapping[str, Any] = field(default_factory=dict)


def utc_iso(value: str | np.datetime64 | _dt.datetime) -> str:
    """Return a time stamp as an ISO 8601 UTC string with nanoseconds and a trailing ``Z``.

    Naive inputs are taken as UTC; aware datetimes are converted to UTC.
    """
    if isinstance(value, _dt.datetime) and value.tzinfo is not None:
        value = value.astimezone(_dt.UTC).replace(tzinfo=None)
    stamp = parse_start_time(value) if isinstance(value, str) else np.datetime64(value, "ns")
    return str(np.datetime_as_string(stamp, unit="ns")) + "Z"


def parse_start_time(text: str | np.datetime64) -> np.datetime64:
    """Parse a stream's ``start_time`` attribute into a naive UTC ``datetime64[ns]``.

    Accepts ISO 8601 with ``Z``, with a UTC offset (converted to UTC) or naive (taken as UTC),
    keeping sub-microsecond digits.
    """
    stamp = pd.Timestamp(text)
    if stamp.tzinfo is not None:
        stamp = stamp.tz_convert("UTC").tz_localize(None)
    return stamp.to_datetime64().astype("datetime64[ns]")


def file_sha256(path: str | Path, chunk_bytes: int = 1 << 22) -> str:
    """Return the SHA-256 hex digest of a file, read in chunks (bounded memory)."""
    digest = hashlib.sha256()
    buffer = bytearray(chunk_bytes)  # one buffer, refilled: no new memory per chunk
    view = memoryview(buffer)
    with open(path, "rb", buffering=0) as handle:
        while size := handle.readinto(buffer):
            digest.update(view[:size])
    return digest.hexdigest()


def _segments(time: np.ndarray, fs_nominal: float) -> np.ndarray:
    """Return segment indices: a new segment after every step above ``GAP_FACTOR / fs``."""
    jumps = np.flatnonzero(np.diff(time) > GAP_FACTOR / fs_nominal)
    if not jumps.size:
        return np.broadcast_to(np.int32(0), time.shape)
    segment = np.zeros(time.size, dtype=np.int32)
    segment[jumps + 1] = 1
    return np.cumsum(segment, dtype=np.int32)


def _gap_table(before: np.ndarray, after: np.ndarray, fs_nominal: float) -> dict[str, Any]:
    """Return the gap attributes for gaps between times ``before[k]`` and ``after[k]`` (s)."""
    dt = 1.0 / fs_nominal
    before = np.asarray(before, dtype=np.float64).reshape(-1)
    after = np.asarray(after, dtype=np.float64).reshape(-1)
    missing = np.maximum(np.round((after - before) / dt) - 1, 0).astype(np.int64)
    return {"gap_start_s": before, "gap_end_s": after, "gap_missing_samples": missing}


def _time_from_blocks(timebase: TimeBase, start: int, stop: int, where: dict[str, Any],
                      attrs: Mapping[str, Any]) -> tuple[xr.Coordinates, np.ndarray,
                                                         dict[str, Any]]:
    """Return the lazy time coordinate, the segment index and the gap table of a window."""
    from rigval.acquisition.time_index import lazy_time_coords

    parts = [(k, lo, hi, b) for k, b, lo, hi in timebase.overlaps(start, stop)]
    for (_, _, hi, b), (_, lo, _, nxt) in itertools.pairwise(parts):
        if not (b.dt > 0 and nxt.t_start > b.t_start + (hi - 1 - b.first) * b.dt):
            raise DataError(f"time is not strictly increasing: block at sample {lo} starts at "
                            f"{nxt.t_start!r} s, before the end of the previous block",
                            where=where, hint="rigval never reorders samples")
    if len(parts) <= 1:
        k = parts[0][0] if parts else 0
        segment = np.broadcast_to(np.int32(k), (stop - start,))
    else:
        segment = np.repeat(np.array([k for k, *_ in parts], dtype=np.int32),
                            [hi - lo for _, lo, hi, _ in parts])
    before = np.array([b.t_start + (hi - 1 - b.first) * b.dt for _, _, hi, b in parts[:-1]])
    after = np.array([b.t_start + (lo - b.first) * b.dt for _, lo, _, b in parts[1:]])
    return lazy_time_coords(timebase, start, stop, attrs), segment, {"before": before,
                                                                      "after": after}


def cf_time_attrs(start_time: str, long_name: str) -> dict[str, str]:
    """Return the CF attributes of a ``time`` coordinate in s since ``start_time`` (ISO, UTC).

    ``xr.decode_cf`` and ``xr.open_dataset`` decode such a coordinate to ``datetime64[ns]``
    equal to the start plus the seconds (to the nanosecond; sub-microsecond starts are kept).
    """
    stamp = np.datetime_as_string(parse_start_time(start_time), unit="ns")
    day, clock = str(stamp).split("T")
    return {"units": f"seconds since {day} {clock}", "calendar": "standard",
            "standard_name": "time", "axis": "T", "long_name": long_name}


def _attr_array(ds: xr.Dataset, name: str, dtype: Any) -> np.ndarray:
    """Return an array attribute as a 1-D array of ``dtype`` (entries as ``attr_list`` gives)."""
    return np.asarray(attr_list(ds.attrs, name), dtype=dtype).reshape(-1)


def stream_gaps(ds: xr.Dataset) -> list[dict[str, float | int]]:
    """Return a stream's gaps as ``{"after_s", "duration_s", "missing_samples"}`` dicts.

    ``after_s`` is the time of the last sample before the gap (``gap_start_s``), ``duration_s``
    the time missing beyond one nominal sample interval
    (``gap_end_s - gap_start_s - 1 / fs_nominal``).
    """
    dt = 1.0 / float(ds.attrs["fs_nominal"])
    starts = _attr_array(ds, "gap_start_s", np.float64)
    ends = _attr_array(ds, "gap_end_s", np.float64)
    missing = _attr_array(ds, "gap_missing_samples", np.int64)
    return [{"after_s": float(a), "duration_s": float(b - a - dt), "missing_samples": int(m)}
            for a, b, m in zip(starts, ends, missing, strict=True)]


def invalid_counts(ds: xr.Dataset) -> dict[str, int]:
    """Return a stream's invalid-sample counts by reason (empty when every sample is valid)."""
    reasons = _attr_array(ds, "invalid_reason", object)
    counts = _attr_array(ds, "invalid_count", np.int64)
    return {str(r): int(c) for r, c in zip(reasons, counts, strict=True)}


def with_invalid_counts(ds: xr.Dataset, counts: Mapping[str, int]) -> xr.Dataset:
    """Return ``ds`` (a shallow copy) with its invalid-sample counts set to ``counts``."""
    out = ds.copy()
    out.attrs.update(_invalid_table(counts))
    return out


def string_table_attrs(prefix: str, table: Mapping[str, str]) -> dict[str, list[str]]:
    """Return a text-to-text mapping (a file header) as two netCDF-storable attributes.

    ``<prefix>_keys`` and ``<prefix>_values`` are string arrays in the mapping's order, so a
    header survives ``to_netcdf``/``open_datatree`` as data (read it back with
    :func:`string_table`), whatever characters its keys hold.
    """
    return {f"{prefix}_keys": [str(k) for k in table],
            f"{prefix}_values": [str(v) for v in table.values()]}


def string_table(attrs: Mapping[str, Any], prefix: str) -> dict[str, str]:
    """Return the mapping stored by :func:`string_table_attrs` (empty when absent).

    Parameters
    ----------
    attrs : mapping
        Attributes of a stream (``ds.attrs``), in memory or read back from netCDF (which
        returns a one-entry array as a plain string).
    prefix : str
        The prefix given to :func:`string_table_attrs` (``"text_header"``, ``"lvm_header"``).

    Raises
    ------
    DataError
        When the keys and values differ in number (a file edited by hand).
    """
    keys, values = (attr_list(attrs, f"{prefix}_{part}") for part in ("keys", "values"))
    if len(keys) != len(values):
        raise DataError(f"{prefix}_keys has {len(keys)} entries, {prefix}_values {len(values)}",
                        where={"attribute": f"{prefix}_keys"},
                        hint="both attributes must list one entry per header line")
    return {str(k): str(v) for k, v in zip(keys, values, strict=True)}


def _invalid_table(counts: Mapping[str, int]) -> dict[str, Any]:
    """Return the invalid-sample attributes: reasons (list of str) and counts (int64)."""
    kept = {str(k): int(v) for k, v in counts.items() if int(v)}
    return {"invalid_reason": list(kept),
            "invalid_count": np.array(list(kept.values()), dtype=np.int64)}


def stream_dataset(
    time: np.ndarray | TimeBase,
    channels: Mapping[str, Channel],
    *,
    device: str,
    start_time: str | np.datetime64 | _dt.datetime,
    source_file: str | Path,
    source_sha256: str,
    fs_nominal: float,
    valid: np.ndarray | None = None,
    invalid_counts: Mapping[str, int] | None = None,
    segment: np.ndarray | None = None,
    attrs: Mapping[str, Any] | None = None,
    window: tuple[int, int] | None = None,
) -> xr.Dataset:
    """Build a stream Dataset with the attributes of the stream schema (``docs/formats.md``).

    Parameters
    ----------
    time : numpy.ndarray or TimeBase
        Sample times in s on the device clock since its first sample, strictly increasing; or the
        blocks that describe them (:class:`~rigval.acquisition.timebase.TimeBase`), which gives a
        lazy ``time`` index and the segments and gaps of the blocks.
    channels : mapping of str to Channel
        The stream's channels by name; every one has one sample per time.
    device : str
        Device kind, e.g. ``"cDAQ-9172"`` or ``"WLS-9163"``.
    start_time : str, numpy.datetime64 or datetime.datetime
        Wall-clock time of the first sample of the stream as the device wrote it (UTC).
    source_file : str or pathlib.Path
        File the stream was read from.
    source_sha256 : str
        SHA-256 of that file (see :func:`file_sha256`).
    fs_nominal : float
        Nominal sampling rate in Hz (from ``wf_increment`` or the header).
    valid : numpy.ndarray of bool, optional
        False for samples that cannot be used. Default: all valid.
    invalid_counts : mapping of str to int, optional
        Reason -> count for the invalid samples; the counts must add up to the number of False
        entries in ``valid``.
    segment : numpy.ndarray of int, optional
        Segment index per sample (array ``time`` only). Default: derived from jumps in ``time``
        larger than ``GAP_FACTOR / fs_nominal``.
    attrs : mapping, optional
        Further stream attributes (device serial, module, reader notes, ...).
    window : tuple of int, optional
        With a TimeBase: the samples ``start ... stop - 1`` the channels hold (default: all).

    Returns
    -------
    xarray.Dataset
        The stream.

    Raises
    ------
    DataError
        If the time axis is not strictly increasing, a channel has the wrong length, or the invalid
        counts do not add up.
    """
    where = {"file": str(source_file), "device": device}
    if not np.isfinite(fs_nominal) or fs_nominal <= 0:
        raise DataError(f"fs_nominal must be a positive rate in Hz, got {fs_nominal!r}",
                        where=where)
    start_iso = utc_iso(start_time)
    time_attrs = cf_time_attrs(start_iso, "time on the device clock since first sample")
    if isinstance(time, TimeBase):
        if segment is not None:
            raise DataError("segment comes from the TimeBase blocks; do not pass both",
                            where=where)
        lo, hi = window if window is not None else (0, time.length)
        coords, segment, jumps = _time_from_blocks(time, lo, hi, where, time_attrs)
        size = hi - lo
    else:
        time = np.asarray(time, dtype=np.float64)
        if time.ndim != 1:
            raise DataError("the time axis must be one-dimensional", where=where)
        _check_increasing(time, where)
        size = time.size
        if segment is None:
            segment = _segments(time, fs_nominal)
        segment = np.asarray(segment, dtype=np.int32)
        starts = np.flatnonzero(np.diff(segment)) + 1
        jumps = {"before": time[starts - 1], "after": time[starts]}
        coords = xr.Coordinates({"time": ("time", time, time_attrs)})
    if valid is None:
        valid = np.broadcast_to(np.True_, (size,))
    valid = np.asarray(valid, dtype=bool)
    counts = {k: int(v) for k, v in (invalid_counts or {}).items() if int(v)}
    n_invalid = int(valid.size - np.count_nonzero(valid))
    if valid.shape != (size,) or sum(counts.values()) != n_invalid:
        raise DataError(
            f"valid mask ({valid.size} samples, {n_invalid} invalid) does not match the time axis "
            f"({size}) and the invalid counts {counts}",
            where=where,
        )
    data_vars: dict[str, Any] = {}
    for name, channel in channels.items():
        values = np.asarray(channel.data)
        if values.shape != (size,):
            raise DataError(
                f"channel {name!r} has {values.size} samples but the time axis has {size}",
                where={**where, "channel": channel.source_channel},
            )
        data_vars[name] = xr.Variable("time", values, {  # a Variable: half the cost of a tuple
            **dict(channel.attrs),
            "units": channel.units,
            "long_name": channel.long_name,
            "source_channel": channel.source_channel,
            "scaling": channel.scaling,
        })
    data_vars["valid"] = ("time", valid, {"long_name": "sample is usable", "units": "1"})
    data_vars["segment"] = ("time", segment, {"long_name": "gap-free segment index",
                                              "units": "1"})
    gaps = _gap_table(jumps["before"], jumps["after"], fs_nominal)
    ds = xr.Dataset(data_vars, coords=coords)
    ds.attrs = {
        "Conventions": "CF-1.13",
        **dict(attrs or {}),
        "device": device,
        "start_time": start_iso,
        "source_file": str(source_file),
        "source_sha256": source_sha256,
        "fs_nominal": float(fs_nominal),
        "gap_count": int(gaps["gap_start_s"].size),
        "missing_samples": int(gaps["gap_missing_samples"].sum()),
        **gaps,
        **_invalid_table(counts),
    }
    return ds


def _check_increasing(time: np.ndarray, where: dict[str, Any]) -> None:
    """Raise DataError at the first step of ``time`` that is not positive."""
    if time.size > 1:
        bad = np.flatnonzero(~(np.diff(time) > 0))
        if bad.size:
            i = int(bad[0])
            raise DataError(
                f"time is not strictly increasing: sample {i + 1} at {time[i + 1]!r} s follows "
                f"{time[i]!r} s ({bad.size} such steps)",
                where=where,
                hint="check the reader options (time column, start offsets); rigval never reorders",
            )


def check_stream(ds: xr.Dataset) -> None:
    """Check that a Dataset follows the stream schema.

    Raises
    ------
    DataError
        Naming the attribute or variable that is missing.
    """
    where = {"file": ds.attrs.get("source_file")}
    missing = [a for a in REQUIRED_STREAM_ATTRS if a not in ds.attrs]
    if missing:
        raise DataError(f"stream lacks the attributes {missing}", where=where,
                        hint="build streams with rigval.acquisition.schema.stream_dataset")
    for name in ("valid", "segment"):
        if name not in ds or ds[name].dims != ("time",):
            raise DataError(f"stream lacks the variable {name!r} on dim 'time'", where=where)
    for name, var in ds.data_vars.items():
        if name in ("valid", "segment"):
            continue
        lacking = [a for a in REQUIRED_CHANNEL_ATTRS if a not in var.attrs]
        if lacking:
            raise DataError(f"channel {name!r} lacks the attributes {lacking}",
                            where={**where, "channel": name})


def append_history(ds: xr.Dataset | xr.DataTree, step: str) -> None:
    """Append one CF ``history`` line (UTC ISO time first) for a processing step, in place."""
    now = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ")
    line = f"{now} rigval {step}"
    previous = ds.attrs.get("history", "")
    ds.attrs["history"] = f"{previous}\n{line}" if previous else line
