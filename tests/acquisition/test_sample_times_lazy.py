"""A lazy time axis read a sample, a slice or a set of samples at a time gives the array's values.

:class:`rigval.acquisition.time_index.SampleTimes` stands for the whole-record array of a lazy
``time`` coordinate; the independent expectation is that array
(:meth:`~rigval.acquisition.timebase.TimeBase.times`), bit for bit, and the resampling and the
diagnosis signal computed on it.
"""

from __future__ import annotations

import numpy as np
import pytest

from rigval.acquisition.schema import Channel, stream_dataset
from rigval.acquisition.time_index import SampleTimes, sample_times
from rigval.acquisition.timebase import Block, TimeBase
from rigval.processing.angle import interpolate_runs
from rigval.processing.stretch_decimation import diagnosis_signal

FS = 1000.0
#: Three blocks: a gap after the first, a restart of the clock at another rate after the second.
BASE = TimeBase([Block(0, 4000, 0.0, 1 / FS), Block(4000, 3000, 4.5, 1 / FS),
                 Block(7000, 2500, 8.0, 1 / 999.5)])


def _stream():
    time = BASE.times()
    values = np.sin(2 * np.pi * 3.0 * time) + 0.1 * np.cos(2 * np.pi * 41.0 * time)
    return stream_dataset(BASE, {"x": Channel(values, "V", "x", "x", "none", {})}, device="d",
                          start_time="2026-11-29T06:00:00Z", source_file="x.tdms",
                          source_sha256="0" * 64, fs_nominal=FS)


def test_sample_times_give_the_arrays_values_bit_for_bit():
    ds = _stream()
    lazy, whole = sample_times(ds["time"]), BASE.times()
    assert isinstance(lazy, SampleTimes) and lazy.size == len(lazy) == whole.size
    for key in (slice(None), slice(3990, 4010), slice(6999, 7001), slice(100, 9000, 7),
                slice(9400, 20000), slice(50, 50), slice(-20, None)):
        assert np.array_equal(lazy[key], whole[key]), key
    for k in (0, 3999, 4000, 8999, -1):
        assert lazy[k] == whole[k]
    at = np.array([[5, 4000], [7001, 9499]])
    assert np.array_equal(lazy[at], whole[at])
    with pytest.raises(IndexError):
        lazy[9500]
    with pytest.raises(IndexError):
        lazy[np.array([0.5])]
    window = ds.isel(time=slice(3000, 8000))  # a window of the axis: its own positions
    assert np.array_equal(sample_times(window["time"])[10:20], whole[3010:3020])


def test_a_time_array_is_given_as_it_is():
    ds = _stream().isel(time=np.arange(0, 9500, 2))  # a stepped selection: times in memory
    times = sample_times(ds["time"])
    assert isinstance(times, np.ndarray) and np.shares_memory(times, ds["time"].to_numpy())


@pytest.mark.parametrize("order", [1, 3, 5])
def test_resampling_on_lazy_times_equals_the_array(order):
    ds = _stream()
    values, segment = ds["x"].to_numpy(), ds["segment"].to_numpy()
    valid = ds["valid"].to_numpy().copy()
    valid[2000:2010] = False
    at = np.random.default_rng(3).uniform(-0.5, 11.0, (40, 25))
    lazy = interpolate_runs(sample_times(ds["time"]), values, at, order=order, segment=segment,
                            valid=valid, time_offset=2e-4)
    whole = interpolate_runs(BASE.times(), values, at, order=order, segment=segment,
                             valid=valid, time_offset=2e-4)
    assert np.array_equal(lazy, whole, equal_nan=True)
    assert np.isfinite(lazy).sum() > 500


def test_the_diagnosis_signal_on_lazy_times_equals_the_array():
    ds = _stream()
    args = (ds["x"].to_numpy(), ds["segment"].to_numpy(), ds["valid"].to_numpy(), FS, 40.0)
    lazy = diagnosis_signal(sample_times(ds["time"]), *args, delay_s=3e-4)
    whole = diagnosis_signal(BASE.times(), *args, delay_s=3e-4)
    assert lazy.sizes["time"] > 100
    assert lazy.identical(whole)
