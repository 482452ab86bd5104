"""The stream schema: one place that builds and checks the Dataset every reader returns.

A *stream* is one device's channels sharing one time base (docs/formats.md, *What a stream carries*). It is an
:class:`xarray.Dataset` with

- dim ``time``: seconds on the device's own clock since its first sample (float64, strictly
  increasing, gaps kept as jumps, never filled);
- one variable per channel with ``units`` (UDUNITS), ``long_name``, ``source_channel`` and
  ``scaling`` (what was applied to reach these values), plus any sensor metadata;
- ``valid`` (bool, time): False for samples that exist in the file but cannot be used; the reasons
  and counts are in the attribute ``invalid_counts`` (JSON);
- ``segment`` (int32, time): index of the gap-free segment each sample belongs to;
- attributes ``device``, ``start_time`` (ISO 8601 UTC), ``source_file``, ``source_sha256``,
  ``fs_nominal`` (Hz), ``gap_count``, ``missing_samples`` and ``gaps`` (JSON list of
  ``{"after_s", "duration_s", "missing_samples"}``).
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from rigval.acquisition.errors import DataError

__all__ = [
    "REQUIRED_STREAM_ATTRS",
    "Channel",
    "append_history",
    "check_stream",
    "file_sha256",
    "parse_start_time",
    "stream_dataset",
    "utc_iso",
]

REQUIRED_STREAM_ATTRS = ("device", "start_time", "source_file", "source_sha256", "fs_nominal",
                         "gap_count", "missing_samples", "gaps")
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
    with open(path, "rb") as handle:
        while block := handle.read(chunk_bytes):
            digest.update(block)
    return digest.hexdigest()


def _segments(time: np.ndarray, fs_nominal: float) -> tuple[np.ndarray, list[dict[str, Any]]]:
    """Return segment indices and the gaps (steps above ``GAP_FACTOR / fs_nominal``)."""
    step = np.diff(time)
    dt = 1.0 / fs_nominal
    jumps = np.flatnonzero(step > GAP_FACTOR * dt)
    segment = np.zeros(time.size, dtype=np.int32)
    if jumps.size:
        segment[jumps + 1] = 1
        segment = np.cumsum(segment, dtype=np.int32)
    gaps = [
        {
            "after_s": float(time[i]),
            "duration_s": float(step[i] - dt),
            "missing_samples": max(round(step[i] / dt) - 1, 0),
        }
        for i in jumps
    ]
    return segment, gaps


def stream_dataset(
    time: np.ndarray,
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
) -> xr.Dataset:
    """Build a stream Dataset with the attributes of docs/formats.md, *What a stream carries*.

    Parameters
    ----------
    time : numpy.ndarray
        Sample times in s on the device clock since its first sample, strictly increasing.
    channels : mapping of str to Channel
        The stream's channels by name; every one has ``time.size`` samples.
    device : str
        Device kind, e.g. ``"cDAQ-9172"`` or ``"WLS-9163"``.
    start_time : str, numpy.datetime64 or datetime.datetime
        Wall-clock time of the first sample as the device wrote it (UTC).
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
        Segment index per sample. Default: derived from jumps in ``time`` larger than
        ``GAP_FACTOR / fs_nominal``.
    attrs : mapping, optional
        Further stream attributes (device serial, module, reader notes, ...).

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
    time = np.asarray(time, dtype=np.float64)
    where = {"file": str(source_file), "device": device}
    if time.ndim != 1:
        raise DataError("the time axis must be one-dimensional", where=where)
    if not np.isfinite(fs_nominal) or fs_nominal <= 0:
        raise DataError(f"fs_nominal must be a positive rate in Hz, got {fs_nominal!r}",
                        where=where)
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
    if valid is None:
        valid = np.ones(time.size, dtype=bool)
    valid = np.asarray(valid, dtype=bool)
    counts = {k: int(v) for k, v in (invalid_counts or {}).items() if int(v)}
    n_invalid = int(valid.size - np.count_nonzero(valid))
    if valid.shape != time.shape or sum(counts.values()) != n_invalid:
        raise DataError(
            f"valid mask ({valid.size} samples, {n_invalid} invalid) does not match the time axis "
            f"({time.size}) and the invalid counts {counts}",
            where=where,
        )
    gaps: list[dict[str, Any]]
    if segment is None:
        segment, gaps = _segments(time, fs_nominal)
    else:
        segment = np.asarray(segment, dtype=np.int32)
        starts = np.flatnonzero(np.diff(segment)) + 1
        dt = 1.0 / fs_nominal
        gaps = [{"after_s": float(time[i - 1]), "duration_s": float(time[i] - time[i - 1] - dt),
                 "missing_samples": max(round((time[i] - time[i - 1]) / dt) - 1, 0)}
                for i in starts]
    data_vars: dict[str, Any] = {}
    for name, channel in channels.items():
        values = np.asarray(channel.data)
        if values.shape != time.shape:
            raise DataError(
                f"channel {name!r} has {values.size} samples but the time axis has {time.size}",
                where={**where, "channel": channel.source_channel},
            )
        data_vars[name] = ("time", values, {
            **dict(channel.attrs),
            "units": channel.units,
            "long_name": channel.long_name,
            "source_channel": channel.source_channel,
            "scaling": channel.scaling,
        })
    data_vars["valid"] = ("time", valid, {"long_name": "sample is usable", "units": "1"})
    data_vars["segment"] = ("time", segment, {"long_name": "gap-free segment index",
                                              "units": "1"})
    time_attrs = {"units": "s", "long_name": "time on the device clock since first sample"}
    ds = xr.Dataset(data_vars, coords={"time": ("time", time, time_attrs)})
    ds.attrs = {
        **dict(attrs or {}),
        "device": device,
        "start_time": utc_iso(start_time),
        "source_file": str(source_file),
        "source_sha256": source_sha256,
        "fs_nominal": float(fs_nominal),
        "gap_count": len(gaps),
        "missing_samples": int(sum(g["missing_samples"] for g in gaps)),
        "gaps": json.dumps(gaps),
        "invalid_counts": json.dumps(counts),
    }
    return ds


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
