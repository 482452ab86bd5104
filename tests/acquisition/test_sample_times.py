"""Lazy sample times against the materialised time axis, and what is computed on them.

The resampling and the diagnosis signal read a lazy axis a slice or a few samples at a time;
the independent expectation is the same computation on the materialised axis, bit for bit.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import xarray as xr

from rigval.acquisition.sample_times import SampleTimes, sample_times, times_of
from rigval.acquisition.schema import Channel, stream_dataset
from rigval.acquisition.time_index import lazy_time_coords
from rigval.acquisition.timebase import Block, TimeBase
from rigval.processing.angle import interpolate_runs
from rigval.processing.stretch_decimation import diagnosis_signal


def _stream(start: int = 0, stop: int | None = None) -> xr.Dataset:
    """A stream of three blocks: two gaps, the second block at another rate."""
    base = TimeBase([Block(0, 1000, 0.0, 1e-3), Block(1000, 500, 1.7, 2e-3),
                     Block(1500, 777, 3.1, 1e-3)])
    stop = base.length if stop is None else stop
    coords = lazy_time_coords(base, start, stop, {"units": "s"})
    return xr.Dataset({"x": ("time", np.zeros(stop - start))}, coords=coords)


@pytest.mark.parametrize(("start", "stop"), [(0, None), (250, 1900)])
def test_values_and_positions_equal_the_materialised_axis(start: int, stop: int | None) -> None:
    stream = _stream(start, stop)
    lazy, whole = sample_times(stream), stream["time"].to_numpy()
    assert isinstance(lazy, SampleTimes) and lazy.shape == whole.shape and len(lazy) == whole.size
    rng = np.random.default_rng(3)
    index = rng.integers(-whole.size, whole.size, (7, 5))
    assert np.array_equal(lazy[index], whole[index])
    assert lazy[3] == whole[3] and lazy[-1] == whole[-1]
    assert np.array_equal(lazy[10:400:7], whole[10:400:7])
    mask = rng.random(whole.size) < 0.1
    assert np.array_equal(lazy[mask], whole[mask])
    probes = np.concatenate((whole[rng.integers(0, whole.size, 50)],  # on samples
                             rng.uniform(whole[0] - 1, whole[-1] + 1, 200),  # between, outside
                             [whole[0], whole[-1], -np.inf, np.inf]))
    for side in ("left", "right"):
        assert np.array_equal(np.searchsorted(lazy, probes, side=side),
                              np.searchsorted(whole, probes, side=side))
        assert lazy.searchsorted(float(whole[17]), side=side) == np.searchsorted(
            whole, whole[17], side=side)
    with pytest.raises(IndexError):
        lazy[whole.size]


def test_materialised_axis_and_plain_arrays_pass_through() -> None:
    stream = _stream()
    plain = stream.assign_coords(time=stream["time"].to_numpy())
    assert isinstance(sample_times(plain), np.ndarray)
    assert times_of([0, 1, 2]).dtype == np.float64
    lazy = sample_times(stream)
    assert times_of(lazy) is lazy


def test_health_and_pulses_on_lazy_times_equal_those_on_the_whole_axis() -> None:
    """A sample run's reference stream, with faults added, checked both ways."""
    from rigval.processing.health_check import stream_health
    from rigval.processing.pulses import stream_pulses
    from rigval.sample_data import shipped_runs
    from rigval.validation.read_plan import read_streams
    from rigval.validation.scene import load_scene

    scene = load_scene(next(p for p in shipped_runs() if "0p8" in p.name))
    stream = read_streams(scene, {"cdaq": ("enc1", "opt1", "acc1")}, only="cdaq")["cdaq"]
    assert isinstance(sample_times(stream), SampleTimes)
    enc = stream["enc1"].to_numpy().copy()
    enc[40_000:] += 50  # a count jump
    acc = stream["acc1"].to_numpy().copy()
    acc[[5_000, 30_001, 60_002]] += 3.0  # spikes
    lazy = stream.assign(enc1=("time", enc), acc1=("time", acc))
    whole = lazy.assign_coords(time=lazy["time"].to_numpy())
    kinds = {"enc1": "counter", "opt1": "pulse", "acc1": "analog"}
    found = stream_health(lazy, kinds, name="cdaq", counts_per_rev={"enc1": 8192.0})
    assert {f.fault for f in found} >= {"count jump", "spikes"}
    assert found == stream_health(whole, kinds, name="cdaq", counts_per_rev={"enc1": 8192.0})
    pulses, expected = stream_pulses(lazy, "opt1"), stream_pulses(whole, "opt1")
    assert pulses.times.size > 10
    for field in dataclasses.fields(expected):
        mine, theirs = getattr(pulses, field.name), getattr(expected, field.name)
        assert np.array_equal(mine, theirs) if isinstance(theirs, np.ndarray) else mine == theirs


FS = 1000.0
#: Three blocks: a gap after the first, a restart of the clock at another rate after the second.
BASE = TimeBase([Block(0, 4000, 0.0, 1 / FS), Block(4000, 3000, 4.5, 1 / FS),
                 Block(7000, 2500, 8.0, 1 / 999.5)])


def _channel_stream():
    time = BASE.times()
    values = np.sin(2 * np.pi * 3.0 * time) + 0.1 * np.cos(2 * np.pi * 41.0 * time)
    return stream_dataset(BASE, {"x": Channel(values, "V", "x", "x", "none", {})}, device="d",
                          start_time="2026-11-29T06:00:00Z", source_file="x.tdms",
                          source_sha256="0" * 64, fs_nominal=FS)


def test_sample_times_give_the_arrays_values_bit_for_bit():
    ds = _channel_stream()
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
    window = ds.isel(time=slice(3000, 8000))  # a window of the axis: its own positions
    assert np.array_equal(sample_times(window["time"])[10:20], whole[3010:3020])


def test_a_time_array_is_given_as_it_is():
    ds = _channel_stream().isel(time=np.arange(0, 9500, 2))  # a stepped selection: times in memory
    times = sample_times(ds["time"])
    assert isinstance(times, np.ndarray) and np.shares_memory(times, ds["time"].to_numpy())


@pytest.mark.parametrize("order", [1, 3, 5])
def test_resampling_on_lazy_times_equals_the_array(order):
    ds = _channel_stream()
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
    ds = _channel_stream()
    args = (ds["x"].to_numpy(), ds["segment"].to_numpy(), ds["valid"].to_numpy(), FS, 40.0)
    lazy = diagnosis_signal(sample_times(ds["time"]), *args, delay_s=3e-4)
    whole = diagnosis_signal(BASE.times(), *args, delay_s=3e-4)
    assert lazy.sizes["time"] > 100
    assert lazy.identical(whole)


def test_a_clocked_time_base_gives_each_block_its_own_map_bit_for_bit():
    """``on_clock``: scale * t + shift of the block, as the whole axis computes it."""
    blocks = [Block(0, 7, 0.0, 0.1), Block(7, 5, 1.5, 0.1), Block(12, 9, 4.0, 0.1)]
    base = TimeBase(blocks)
    shifts = [0.25, -3.125, 7.0]
    clocked = base.on_clock(1.0 + 31.2e-6, shifts)
    whole = base.times()
    expected = (1.0 + 31.2e-6) * whole + np.repeat(shifts, [7, 5, 9])
    assert np.array_equal(clocked.times(), expected)
    assert np.array_equal(clocked.times(5, 14), expected[5:14])  # across two block edges
    assert np.array_equal(base.times(5, 14), whole[5:14])
    coords = lazy_time_coords(clocked, 3, 20, {})
    assert np.array_equal(coords["time"].to_numpy(), expected[3:20])
    assert np.array_equal(sample_times(coords["time"])[[0, 4, 9, 16]], expected[[3, 7, 12, 19]])
    assert clocked == base.on_clock(1.0 + 31.2e-6, shifts) and clocked != base
    assert base.on_clock(1.0, [0.0, np.nan, 1.0]) == base.on_clock(1.0, [0.0, np.nan, 1.0])
    with pytest.raises(ValueError, match="2 clock shifts for 3 blocks"):
        base.on_clock(1.0, [0.0, 1.0])


@pytest.mark.parametrize("first", [1, 3, 7])
def test_a_clocked_window_maps_times_back_to_its_positions(first: int):
    """``reverse`` of a window whose clock maps no block before it (NaN shifts there)."""
    from rigval.acquisition.time_index import BlockTimeTransform

    blocks = [Block(100 * i, 100, 3.0 * i, 0.01) for i in range(12)]
    clocked = TimeBase(blocks).on_clock(1.0 + 3e-6, [np.nan] * first + [0.1] * (12 - first))
    window = BlockTimeTransform(clocked, 100 * first, 100 * (12 - first))
    positions = np.arange(0, 100 * (12 - first), 37)
    times = window.forward({"time": positions})["time"]
    assert np.allclose(window.reverse({"time": times})["time"], positions, rtol=0, atol=1e-6)
