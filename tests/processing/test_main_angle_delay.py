"""phi_F held as the reference time axis and the encoder's input delay, not their copy.

:class:`~rigval.processing.stream_alignment.MainAngle` keeps the stream's time axis and the
encoder's delay apart; what it gives (times at angles, the events other streams are aligned on,
the uniform grid) must equal, bit for bit, what the delayed copy of the axis gives (the old way).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from rigval.acquisition.sample_times import SampleTimes
from rigval.acquisition.time_index import BlockTimeIndex
from rigval.processing.angle import angle_grid
from rigval.processing.clock_fit import reference_event_times
from rigval.processing.encoder import interp_minus
from rigval.processing.stream_alignment import MainAngle, pulse_events, reference_angle
from rigval.sample_data import runs_dir
from rigval.validation.read_plan import read_streams, stream_part
from rigval.validation.scene import load_scene
from rigval.validation.stage_settings import alignment_settings, convert_stream


@pytest.mark.parametrize("block", [3, 1 << 16])
def test_interp_minus_equals_interp_of_the_shifted_copy(block: int,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    from rigval.processing import encoder
    monkeypatch.setattr(encoder, "_INTERP_BLOCK", block)
    rng = np.random.default_rng(7)
    xp = np.cumsum(rng.uniform(0.1, 1.0, 200_001))
    fp = 1000.0 + np.cumsum(rng.uniform(1e-4, 2e-4, xp.size))
    shift = 5e-7
    cases = [np.sort(rng.uniform(xp[0] - 5, xp[-1] + 5, 5_000)),   # beyond both ends too
             rng.uniform(xp[0], xp[-1], (40, 70)),                  # unsorted, 2-D
             xp[::3].copy(),                                        # at the samples
             np.linspace(xp[0], xp[-1], 37),                        # sparse
             np.array([xp[-1]]), np.array([xp[0] - 1.0])]
    for x in cases:
        expected = np.interp(x, xp, fp - shift)
        got = interp_minus(x, xp, fp, shift)
        assert got.shape == expected.shape and np.array_equal(got, expected)


@pytest.mark.parametrize("speed", ["0p8", "1p2"])
def test_main_angle_gives_what_the_delayed_copy_gives(speed: str) -> None:
    scene = load_scene(runs_dir() / f"run_{speed}_scene.toml")
    settings = alignment_settings(scene)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the CSV reader notes its guesses
        raw = read_streams(scene, {settings.reference: [settings.encoder.name,
                                                        settings.reference_pulse.name]},
                           only=settings.reference)[settings.reference]
    ref = convert_stream(raw, stream_part(scene.streams[settings.reference], raw.data_vars))
    reference = reference_angle(settings, ref)
    main = reference.main
    assert main.delay_s > 0.0  # the NI 9411's 500 ns: the case the copy was made for
    # the stream keeps its lazy time axis, and phi_F is held on it
    assert isinstance(reference.stream.xindexes["time"], BlockTimeIndex)
    assert isinstance(main.axis, SampleTimes)
    assert np.array_equal(main.axis[:], reference.stream["time"].to_numpy())
    copied = reference.stream["time"].to_numpy() - main.delay_s
    assert np.array_equal(main.time, copied)
    old = MainAngle(copied, main.phi, main.zero_u95_s)  # no delay: plain np.interp
    fine = 2 * np.pi * np.arange(int(main.phi[0] // (2 * np.pi)) + 1,
                                 int(main.phi[-1] // (2 * np.pi)), 1 / 1440)
    assert np.array_equal(main.times_at(fine), old.times_at(fine))
    assert main.span_s == (float(copied[0]), float(copied[-1]))
    for name, events in pulse_events(settings, main).items():
        clock = settings.streams[name]
        expected = reference_event_times(copied, main.phi, event_angle=clock.angle,
                                         events_per_rev=clock.per_revolution)
        assert events.size > 10 and np.array_equal(events, expected), name
    grid, expected = main.grid(360), angle_grid(copied, main.phi, 360)
    assert np.array_equal(grid.cycles, expected.cycles)
    assert np.array_equal(grid.times, expected.times, equal_nan=True)
    assert grid.slowest == expected.slowest
