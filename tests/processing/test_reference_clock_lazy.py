"""The reference stream on its own clock keeps its time axis as it is (lazy for a TDMS stream).

:func:`rigval.processing.clock_fit.align_stream` with a clock that is the identity on every
segment gives each sample its own time; the independent expectation is
:meth:`~rigval.processing.clock_fit.ClockModel.to_reference` of the materialised times (the
general path), value for value, with the same attributes and ``device_time``. A clock that
moves the samples (a wireless stream's) maps the lazy axis, every time computed where read as
``to_reference`` computes it.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import xarray as xr

from rigval.acquisition.errors import DataWarning
from rigval.acquisition.sample_times import sample_times
from rigval.acquisition.schema import Channel, stream_dataset
from rigval.acquisition.time_index import BlockTimeIndex
from rigval.acquisition.timebase import Block, TimeBase
from rigval.processing import clock_fit

FS = 200.0
#: Two segments (a restart after 1.5 s), as a stream with a gap is read.
BLOCKS = [Block(0, 300, 0.0, 1 / FS), Block(300, 500, 2.0, 1 / FS)]


def _stream(lazy: bool) -> xr.Dataset:
    base = TimeBase(BLOCKS)
    time = base.times()
    segment = np.repeat([0, 1], [300, 500]).astype(np.int32)
    return stream_dataset(base if lazy else time,
                          {"x": Channel(np.cos(time), "V", "x", "x", "none", {})},
                          device="ref", start_time="2026-11-29T06:00:00Z", source_file="x.tdms",
                          source_sha256="0" * 64, fs_nominal=FS,
                          segment=None if lazy else segment)  # a TimeBase gives its own


@pytest.mark.parametrize("lazy", [True, False])
@pytest.mark.parametrize("device_time", [True, False])
def test_identity_clock_keeps_the_time_axis(lazy: bool, device_time: bool) -> None:
    stream = _stream(lazy)
    segment = stream["segment"].to_numpy()
    clock = clock_fit.identity_clock(segment)
    assert clock.segments == (0, 1)
    aligned = clock_fit.align_stream(stream, clock, name="ref", device_time=device_time)
    expected = clock.to_reference(stream["time"].to_numpy(), segment)  # the general path
    assert np.array_equal(aligned["time"].to_numpy(), expected)
    assert isinstance(aligned.xindexes["time"], BlockTimeIndex) is lazy
    assert aligned["time"].attrs["long_name"] == "time on the reference device clock"
    assert aligned["time"].attrs["units"].startswith("seconds since 2026-11-29")
    assert ("device_time" in aligned.coords) is device_time
    if device_time:
        assert np.array_equal(aligned["device_time"].to_numpy(), stream["time"].to_numpy())
    assert aligned.sel(time=slice(1.0, 2.2)).sizes["time"] == 100 + 41  # 1.0-1.495 s, 2.0-2.2 s
    assert stream["time"].attrs.get("long_name") != aligned["time"].attrs["long_name"]


@pytest.mark.parametrize("clock", [
    clock_fit.ClockModel((0, 1), (0.0, 0.25), 0.0, 0.0, 10, 10),  # one segment moved
    clock_fit.ClockModel((0, 1), (0.0, 0.0), 3e-6, 0.0, 10, 10),  # a drift
    clock_fit.ClockModel((0, 1), (-0.635271508, -0.6352), -19.55e-6, 0.0, 10, 10),  # both
])
@pytest.mark.parametrize("device_time", [True, False])
def test_a_clock_that_moves_samples_keeps_a_lazy_axis_of_the_same_times(clock, device_time
                                                                         ) -> None:
    """A wireless stream's aligned axis: ClockModel.to_reference's values, computed where read."""
    stream = _stream(lazy=True)
    aligned = clock_fit.align_stream(stream, clock, device_time=device_time)
    assert isinstance(aligned.xindexes["time"], BlockTimeIndex)
    expected = clock.to_reference(stream["time"].to_numpy(), stream["segment"].to_numpy())
    assert np.array_equal(aligned["time"].to_numpy(), expected)
    assert aligned["time"].attrs["long_name"] == "time on the reference device clock"
    if device_time:
        assert np.array_equal(aligned["device_time"].to_numpy(), stream["time"].to_numpy())
    times = sample_times(aligned)
    picked = np.array([0, 1, 299, 300, 301, 799, 555])
    assert np.array_equal(times[picked], expected[picked])  # a position's own time
    assert np.array_equal(times[290:310], expected[290:310])  # a window across the gap
    assert np.array_equal(times.window(250, 420)[10:100], expected[260:350])
    labels = np.concatenate([expected[[0, 299, 300, 799]], [expected[0] - 1.0, 1.7, 99.0]])
    for side in ("left", "right"):
        assert np.array_equal(times.searchsorted(labels, side),
                              np.searchsorted(expected, labels, side))
    lo, hi = expected[40], expected[420]
    assert aligned.sel(time=slice(lo, hi)).sizes["time"] == int(
        np.count_nonzero((expected >= lo) & (expected <= hi)))
    position = aligned.xindexes["time"].transform.reverse({"time": expected[picked]})["time"]
    assert np.allclose(position, picked, rtol=0, atol=1e-6)
    # the device's clock and the reference's are not the same axis
    assert not aligned.xindexes["time"].equals(stream.xindexes["time"])


def test_a_segment_no_clock_maps_computes_the_times() -> None:
    stream = _stream(lazy=True)
    clock = clock_fit.ClockModel((0,), (0.25,), 2e-6, 0.0, 10, 10)
    with pytest.warns(DataWarning, match="500 samples in segments"):
        aligned = clock_fit.align_stream(stream, clock, device_time=False)
    assert not isinstance(aligned.xindexes["time"], BlockTimeIndex)
    assert np.array_equal(aligned["time"].to_numpy()[:300],
                          clock.to_reference(stream["time"].to_numpy()[:300], 0))


def test_a_stream_in_memory_gets_its_times_computed() -> None:
    stream = _in_memory(_stream(lazy=True))
    clock = clock_fit.ClockModel((0, 1), (0.0, 0.25), 3e-6, 0.0, 10, 10)
    aligned = clock_fit.align_stream(stream, clock, device_time=False)
    assert not isinstance(aligned.xindexes["time"], BlockTimeIndex)
    assert np.array_equal(aligned["time"].to_numpy(),
                          clock.to_reference(stream["time"].to_numpy(),
                                             stream["segment"].to_numpy()))


def test_an_identity_clock_missing_a_segment_marks_it_unaligned() -> None:
    stream = _stream(lazy=True)
    with pytest.warns(DataWarning, match="500 samples in segments"):
        aligned = clock_fit.align_stream(stream, clock_fit.identity_clock([0]), device_time=False)
    assert not isinstance(aligned.xindexes["time"], BlockTimeIndex)
    assert int(aligned["valid"].sum()) == 300


def _in_memory(stream: xr.Dataset) -> xr.Dataset:
    """The stream with its times computed, indexed on an array (as a text file's stream)."""
    time = xr.Variable("time", stream["time"].to_numpy(), stream["time"].attrs)
    return stream.drop_indexes("time").drop_vars("time").assign_coords(time=time)


@pytest.mark.parametrize("speed", ["0p8", "1p2"])
def test_phi_f_on_a_lazy_axis_equals_phi_f_on_its_times(speed: str) -> None:
    """phi_F made and held on a TDMS stream's lazy axis: every value as on its times in memory."""
    import warnings

    from rigval.acquisition.sample_times import SampleTimes
    from rigval.processing.stream_alignment import pulse_events, reference_angle
    from rigval.sample_data import runs_dir
    from rigval.validation.read_plan import read_streams
    from rigval.validation.scene import load_scene
    from rigval.validation.stage_settings import alignment_settings, convert_stream

    scene = load_scene(runs_dir() / f"run_{speed}_scene.toml")
    settings = alignment_settings(scene)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        raw = read_streams(scene, only=settings.reference)[settings.reference]
    lazy = convert_stream(raw, scene.streams[settings.reference])
    assert isinstance(lazy.xindexes["time"], BlockTimeIndex)  # a TDMS stream's axis
    made = {kind: reference_angle(settings, stream, device_time=False)
            for kind, stream in (("lazy", lazy), ("memory", _in_memory(lazy)))}
    main, expected = made["lazy"].main, made["memory"].main
    assert isinstance(main.axis, SampleTimes)  # held lazy
    assert isinstance(made["lazy"].stream.xindexes["time"], BlockTimeIndex)
    assert np.array_equal(main.phi, expected.phi)
    assert np.array_equal(main.time, expected.time)
    assert main.zero_u95_s == expected.zero_u95_s and main.delay_s == expected.delay_s
    angles = np.linspace(main.phi[0], main.phi[-1], 2001)
    assert np.array_equal(main.times_at(angles), expected.times_at(angles))
    for name, events in pulse_events(settings, main).items():
        assert np.array_equal(events, pulse_events(settings, expected)[name]), name
    grid, expected_grid = main.grid(360), expected.grid(360)
    assert np.array_equal(grid.times, expected_grid.times, equal_nan=True)
    assert grid.slowest == expected_grid.slowest
    record, expected_record = made["lazy"].record, made["memory"].record
    for field in dataclasses.fields(record.summary):
        value, other = (getattr(one, field.name) for one in (record.summary,
                                                              expected_record.summary))
        assert np.array_equal(value, other) if isinstance(value, np.ndarray) \
            else value == other, field.name
    assert np.array_equal(record.pulses, expected_record.pulses)


def test_mean_drive_cycle_on_a_lazy_axis_equals_it_on_its_times() -> None:
    """The measured drives smoothed on the lazy axis, piece by piece: the same means, bit for bit.

    (The grid: eleven revolutions, 720 points each.)
    """
    import warnings

    from rigval.processing.excitation import mean_drive_cycle
    from rigval.processing.stream_alignment import reference_angle
    from rigval.sample_data import runs_dir
    from rigval.validation.read_plan import read_streams
    from rigval.validation.scene import load_scene
    from rigval.validation.stage_settings import alignment_settings, convert_stream

    scene = load_scene(runs_dir() / "run_0p8_scene.toml")
    settings = alignment_settings(scene)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        raw = read_streams(scene, only=settings.reference)[settings.reference]
    lazy = reference_angle(settings, convert_stream(raw, scene.streams[settings.reference]),
                           device_time=False)
    turns = np.arange(1, 12)
    times = lazy.main.times_at(2 * np.pi * (turns[:, None] + np.arange(720)[None, :] / 720))
    for channel in ("enc1", "enc2"):
        means = [mean_drive_cycle(stream, channel, times, counts_per_rev=8192,
                                  angle_at_reference=1.0)
                 for stream in (lazy.stream, _in_memory(lazy.stream))]
        assert isinstance(lazy.stream.xindexes["time"], BlockTimeIndex)
        for got, expected in zip(*means, strict=True):
            assert np.array_equal(got, expected), channel
