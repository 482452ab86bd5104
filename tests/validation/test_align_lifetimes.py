"""The align stage lets phi_F and the drives' encoders go before the other streams are aligned.

Its steps (:mod:`rigval.validation.pipeline`: phi_F, what is taken from it, the mean drives, the
other streams) must give what aligning every stream with phi_F at hand gives (the old order:
:func:`~rigval.processing.stream_alignment.align_streams`, then the grid on phi_F's delayed
time copy and the drives averaged on the aligned reference stream), while each step's output,
replacing its input, holds no more of phi_F, of the encoders or of the fine grid's times.
"""

from __future__ import annotations

import gc
import weakref

import numpy as np
import pytest

from rigval.processing.angle import angle_grid, cycle_grid
from rigval.processing.excitation import mean_drive_cycle
from rigval.processing.stream_alignment import align_streams
from rigval.sample_data import runs_dir
from rigval.validation import pipeline
from rigval.validation.model_run import FINE_FACTOR
from rigval.validation.read_plan import read_plan
from rigval.validation.read_stage import read_streams
from rigval.validation.scene import load_scene
from rigval.validation.stage_settings import alignment_settings, drive_encoders
from rigval.validation.stopwatch import Stopwatch
from tests.processing.alignment_checks import assert_same_alignment


@pytest.mark.parametrize("speed", ["0p8", "1p2"])
def test_align_steps_equal_the_old_order_and_let_phi_f_and_encoders_go(speed: str) -> None:
    scene = load_scene(runs_dir() / f"run_{speed}_scene.toml")
    settings = alignment_settings(scene)
    plan = read_plan(scene, settings)
    n = scene.angle.points_per_revolution
    run = read_streams(scene, plan, settings, Stopwatch())

    # the old order: every stream aligned with phi_F at hand, phi_F's times a delayed copy
    old, diagnostics, main = align_streams(settings, run.converted,
                                           device_time=scene.output.aligned, found=run.reference)
    turns, fine_grid = cycle_grid(main.phi[0], main.phi[-1], n * FINE_FACTOR)
    fine_times = np.interp(fine_grid, main.phi, main.time)
    grid = angle_grid(main.time, main.phi, n)
    drives = {e.driver: mean_drive_cycle(
        old[settings.reference], e.channel, fine_times, counts_per_rev=e.counts_per_rev,
        direction=e.direction, index_reset=e.index_reset,
        angle_at_reference=e.angle_at_reference) for e in drive_encoders(scene)}
    old_times = {name: ds["time"].to_numpy() for name, ds in old.items()}
    del old, main

    run = pipeline._phi_f(scene, settings, run)
    phi = weakref.ref(run.reference.main.phi)
    encoders = [weakref.ref(run.reference.stream[c].values) for c in plan.drives]
    assert encoders and phi() is not None
    run = pipeline._predict(scene, settings, run)
    gc.collect()
    assert phi() is None  # let go before the encoders are averaged and the streams aligned
    fine = weakref.ref(run.fine_times)
    assert np.array_equal(run.fine_times, fine_times)
    run = pipeline._drives(scene, plan, settings, run)
    gc.collect()
    assert all(encoder() is None for encoder in encoders) and fine() is None
    aligned = pipeline._align(scene, plan, settings, run)

    timeline = aligned.timeline
    assert np.array_equal(timeline.grid.turns, turns)
    assert np.array_equal(timeline.grid.times, fine_times[:, ::FINE_FACTOR])
    assert np.array_equal(timeline.angle_times.times, grid.times, equal_nan=True)
    assert timeline.angle_times.slowest == grid.slowest
    assert aligned.drives is not None
    for name, triple in drives.items():
        for got, expected in zip(aligned.drives[1][name], triple, strict=True):
            assert np.array_equal(got, expected), name
    assert set(timeline.diagnostics) == set(diagnostics) == set(scene.streams)
    for name, summary in diagnostics.items():
        assert_same_alignment(timeline.diagnostics[name], summary)
        assert np.array_equal(timeline.streams[name]["time"].to_numpy(), old_times[name])
