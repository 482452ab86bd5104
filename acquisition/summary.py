"""Describe a data file's streams (groups, channels, rates, lengths, units, start times, gaps).

TDMS files are described from their metadata alone (no sample is read); text formats are parsed,
since their metadata and data are interleaved. The description is a plain JSON-serialisable dict,
printed by ``rigval info``.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from rigval.acquisition.detect import checked_path, detect_format

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["describe"]


def _describe_tdms(path: Path, **options: Any) -> dict[str, Any]:
    """Describe a TDMS file from its segment metadata."""
    from rigval.acquisition.tdms_layout import object_path_parts, scan_tdms
    from rigval.acquisition.tdms_plan import plan_tdms, raise_empty, warn_about_plans

    layout = scan_tdms(path)
    plans = plan_tdms(layout, **options)
    if not plans:
        raise_empty(layout)  # as read() does: no samples is an error, never an empty listing
    warn_about_plans(layout, plans)
    skipped = sorted({object_path_parts(p)[0] for p in layout.channels}
                     - {p.group for p in plans})
    streams = []
    for plan in plans:
        tb = plan.timebase
        gaps = []
        for before, after in zip(tb.blocks[:-1], tb.blocks[1:], strict=True):
            end = before.t_start + (before.n - 1) * before.dt
            gaps.append({"after_s": end, "duration_s": after.t_start - end - before.dt,
                         "missing_samples": max(round((after.t_start - end) / before.dt) - 1, 0)})
        channels = []
        for name, obj in plan.channels.items():
            props = layout.channels[obj].properties
            channels.extend({  # a complex channel is read as its parts: their names
                "name": shown, "path": obj, "samples": plan.lengths[name],
                "expected_samples": plan.expected[name],
                "units": str(props.get("unit_string", "")),
                "time_offset_s": plan.offsets[name],
                "scaled_by_nptdms": bool(props.get("NI_Number_Of_Scales"))
                and props.get("NI_Scaling_Status") != "scaled",
            } for shown in [f"{name}.{part}" for part in plan.parts.get(name, ())] or [name])
        streams.append({
            "name": plan.name, "group": plan.group, "fs_hz": plan.fs_nominal,
            "samples": tb.length,
            "duration_s": (float(tb.times(tb.length - 1)[0]) + tb.dt) if tb.length else 0.0,
            "start_time": str(np.datetime_as_string(plan.start_time, unit="ns")) + "Z",
            "gaps": gaps, "time_fallbacks": [asdict(f) for f in plan.fallbacks],
            "channels": channels,
        })
    return {"segments": layout.segments, "tdms_version": layout.version,
            "big_endian": layout.big_endian, "daqmx_raw": layout.daqmx,
            "problem": layout.problem, "skipped_groups": skipped, "streams": streams}


def _describe_stream(name: str, ds: xr.Dataset) -> dict[str, Any]:
    """Describe a stream Dataset read from a text file."""
    from rigval.acquisition.schema import stream_gaps
    from rigval.acquisition.time_fallbacks import time_fallbacks

    duration = float(ds.time[-1]) + 1.0 / ds.attrs["fs_nominal"] if ds.sizes["time"] else 0.0
    return {
        "name": name, "fs_hz": ds.attrs["fs_nominal"], "samples": int(ds.sizes["time"]),
        "duration_s": duration, "start_time": ds.attrs["start_time"],
        "gaps": stream_gaps(ds),
        "time_fallbacks": [asdict(f) for f in time_fallbacks(ds.attrs)],
        "channels": [{"name": str(v), "samples": int(ds.sizes["time"]),
                      "units": ds[v].attrs.get("units_in_file", ds[v].attrs["units"]),
                      "empty_cells": ds[v].attrs.get("empty_cells", 0)}
                     for v in ds.data_vars if v not in ("valid", "segment")],
    }


def describe(path: str | os.PathLike[str], *, include_decimated: bool = False,
             **options: Any) -> dict[str, Any]:
    """Return a JSON-serialisable description of a data file.

    Parameters
    ----------
    path : str or path-like
        A TDMS, LVM or CSV file.
    include_decimated : bool
        TDMS: also describe SignalExpress decimated groups.
    **options
        Reader options (``group``, ``delimiter``, ...).

    Returns
    -------
    dict
        ``file``, ``format``, ``bytes``, ``warnings`` and ``streams`` (each with name, rate in Hz,
        samples, duration in s, start time, gaps, time fallbacks and channels); TDMS adds segment
        count, version, byte order, DAQmx raw data, the damage found and skipped groups.

    Raises
    ------
    RigvalError
        For files that cannot be read at all.
    """
    file = checked_path(path)
    kind = detect_format(file)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        if kind == "tdms":
            body = _describe_tdms(file, include_decimated=include_decimated, **options)
        else:
            from rigval.acquisition.reader import read

            streams = read(file, format=kind, checksum=False, **options)
            body = {"streams": [_describe_stream(n, ds) for n, ds in streams.items()]}
    return {"file": str(file), "format": kind, "bytes": file.stat().st_size,
            "warnings": [str(w.message) for w in caught], **body}
