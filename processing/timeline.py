"""All aligned streams on one uniform reference-clock time grid (the ``/aligned`` group).

:func:`~rigval.processing.clock_fit.align_stream` keeps every stream's own samples; plots, exports
and time-domain comparisons want one ``time`` axis. :func:`common_timeline` evaluates every channel
at the grid times with an interpolating spline, after removing its module input delay, per gap-free
run (grid points in another stream's gap are NaN, never filled), low-passing first at 0.45 of the
grid rate when a stream is sampled faster than the grid.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence

import numpy as np
import xarray as xr

from rigval.acquisition.errors import ChannelNotFoundError, ConfigError
from rigval.acquisition.schema import append_history
from rigval.processing.angle import interpolate_runs
from rigval.processing.clock_fit import channel_time
from rigval.processing.filters import zero_phase
from rigval.processing.selection import merged_history, selected_channels

__all__ = ["CLOCK_ATTRS", "common_timeline"]

logger = logging.getLogger(__name__)

#: Clock-model attributes copied from each aligned stream onto its channels.
CLOCK_ATTRS = ("clock_offset_s", "clock_drift_ppm", "residual_rms_s", "pulses_matched",
               "segments", "segment_clock_offset_s", "segment_clock_offset_u95_s",
               "segment_clock_group", "unaligned_segments")


def common_timeline(aligned: Mapping[str, xr.Dataset], reference: str, *,
                    channels: Mapping[str, Sequence[str]] | None = None,
                    fs: float | None = None, order: int = 5) -> xr.Dataset:
    """Return the channels of all aligned streams on one uniform reference-clock grid.

    Parameters
    ----------
    aligned : mapping of str to xarray.Dataset
        Aligned streams by name.
    reference : str
        The reference stream; the grid spans its first to last sample.
    channels : mapping of str to list of str, optional
        Channels per stream; default every data variable but ``valid``/``segment``. A channel
        name used by two streams is prefixed with its stream name.
    fs : float, optional
        Grid rate in Hz; default the reference stream's ``fs_nominal``.
    order : int, default 5
        Interpolation spline degree (1, 3, 5).

    Returns
    -------
    xarray.Dataset
        Dim ``time`` (s on the reference clock, with the reference stream's CF ``units``
        ``"seconds since <start>"``); one variable per channel with its attributes, its
        ``stream`` and the stream's clock model (:data:`CLOCK_ATTRS`); attribute ``streams`` (the
        stream names, in order) and a history line.
    """
    if reference not in aligned:
        raise ChannelNotFoundError(f"no aligned stream {reference!r}", where={"key": "reference"},
                                   available=list(aligned))
    ref = aligned[reference]
    rate = float(fs or ref.attrs["fs_nominal"])
    if rate <= 0:
        raise ConfigError(f"grid rate must be positive, got {rate} Hz", where={"key": "fs"})
    ref_time = ref["time"].to_numpy()
    grid = ref_time[0] + np.arange(int(np.floor((ref_time[-1] - ref_time[0]) * rate)) + 1) / rate
    data_vars = {}
    selected = selected_channels(aligned, channels)
    models = {name: {key: aligned[name].attrs[key] for key in CLOCK_ATTRS
                     if key in aligned[name].attrs} for name in channels or aligned}
    for stream_name, var, out_name in selected:
        ds = aligned[stream_name]
        stream_fs = float(ds.attrs["fs_nominal"])
        segment, valid = ds["segment"].to_numpy(), ds["valid"].to_numpy()
        values = ds[var].to_numpy().astype(np.float64)
        if stream_fs > rate:
            values = zero_phase(values, stream_fs, 0.45 * rate, order=8, segment=segment,
                                valid=valid)
        resampled = interpolate_runs(channel_time(ds, var), values, grid, order=order,
                                     segment=segment, valid=valid)
        attrs = {**ds[var].attrs, "stream": stream_name, **models[stream_name],
                 "resampling": f"spline order {order} onto {rate:g} Hz, delay removed"}
        attrs.pop("input_delay_s", None)
        data_vars[out_name] = ("time", resampled, attrs)
    time_attrs = {**ref["time"].attrs, "long_name": "time on the reference device clock"}
    out = xr.Dataset(data_vars, coords={"time": ("time", grid, time_attrs)},
        attrs={"reference_stream": reference, "fs_nominal": rate, "streams": list(models),
               "history": merged_history(aligned, models)})
    append_history(out, f"processing.common_timeline {len(data_vars)} channels onto "
                        f"{rate:g} Hz ({reference} clock)")
    return out
