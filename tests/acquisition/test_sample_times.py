"""Lazy sample times against the materialised time axis."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import xarray as xr

from rigval.acquisition.sample_times import SampleTimes, sample_times, times_of
from rigval.acquisition.time_index import lazy_time_coords
from rigval.acquisition.timebase import Block, TimeBase


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
