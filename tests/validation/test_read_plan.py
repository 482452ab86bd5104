"""The read plan: every channel of a run is read once, each stage gets what it needs (issue 29).

The shipped 0.8 rev/s scene is validated with the file reader spied on: no (stream, channel) is
read twice, every compared channel is read, and a TDMS stream's compared channels are not among
the channels read before the alignment. The plan itself is checked against the scene: each
compared channel is released once, at its stream's last comparison that uses it.
"""

from __future__ import annotations

import dataclasses
from collections import Counter

import numpy as np
import pytest
import xarray as xr

from rigval.acquisition.errors import DataError
from rigval.sample_data import runs_dir
from rigval.validation import read_plan as plan_module
from rigval.validation import read_stage
from rigval.validation.health import HealthLog
from rigval.validation.pipeline import run_scene
from rigval.validation.scene import load_scene
from rigval.validation.stage_settings import alignment_settings

SCENE = runs_dir() / "run_0p8_scene.toml"


def test_a_run_reads_every_channel_once(monkeypatch: pytest.MonkeyPatch) -> None:
    reads: Counter[tuple[str, str]] = Counter()
    real = plan_module.load_stream

    def spy(spec, **kwargs):
        reads.update((spec.name, channel) for channel in spec.channels)
        return real(spec, **kwargs)

    monkeypatch.setattr(plan_module, "load_stream", spy)
    # every stream read here, where the spy sees it (not beside, in a child of this process)
    monkeypatch.setattr(read_stage, "BESIDE_BYTES", -1)
    result = run_scene(SCENE)
    assert result.comparisons
    twice = [key for key, n in reads.items() if n > 1]
    assert not twice, f"read more than once: {twice}"
    scene = result.scene
    compared = {(ref.stream, ref.channel) for c in scene.comparisons for _, ref in c.terms}
    assert compared <= set(reads)


def test_the_plan_reads_compared_channels_late_and_releases_each_once() -> None:
    scene = load_scene(SCENE)
    plan = plan_module.read_plan(scene, alignment_settings(scene))
    assert not plan.whole
    compared = {(ref.stream, ref.channel) for c in scene.comparisons for _, ref in c.terms}
    for stream, spec in scene.streams.items():
        if spec.file.suffix.lower() == ".tdms":  # read channel by channel: compared ones late
            assert not {(stream, c) for c in plan.first[stream]} & compared
    read_late = Counter((s.comparison.measured.stream, c) for s in plan.compared for c in s.read)
    released = Counter((s.comparison.measured.stream, c) for s in plan.compared
                       for c in s.release)
    assert max(read_late.values()) == 1 and max(released.values()) == 1
    assert set(released) == compared
    for i, step in enumerate(plan.compared):  # released at the last comparison that uses it
        stream = step.comparison.measured.stream
        later = {ref.channel for s in plan.compared[i + 1:] for _, ref in s.comparison.terms
                 if s.comparison.measured.stream == stream}
        assert not set(step.release) & later


def test_first_read_holds_encoders_as_exact_integers_and_their_health_unchanged() -> None:
    scene = load_scene(SCENE)
    settings = alignment_settings(scene)
    plan = plan_module.read_plan(scene, settings)
    stream = plan_module.read_first(scene, plan, settings.reference)
    as_read = plan_module.load_stream(plan_module.stream_part(
        scene.streams[settings.reference], plan.first[settings.reference]))
    encoders = [c for c, table in scene.streams[settings.reference].channels.items()
                if table.sensor == "encoder" and c in stream]
    assert encoders
    for channel in encoders:
        assert as_read[channel].dtype == np.float64 and stream[channel].dtype == np.int32
        assert np.array_equal(stream[channel].to_numpy(), as_read[channel].to_numpy())
    compact, whole = HealthLog(scene), HealthLog(scene)
    compact.check(settings.reference, stream)
    whole.check(settings.reference, as_read)
    assert compact.findings == whole.findings
    # the output keeping every channel keeps them as read
    kept = dataclasses.replace(plan, whole=True)
    assert plan_module.read_first(scene, kept, settings.reference)[encoders[0]].dtype == \
        np.float64


def test_a_tdms_streams_counters_are_read_one_at_a_time_into_the_stream_one_read_gives(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Each counter alone, compacted before the next is read, then the rest: the same stream."""
    scene = load_scene(SCENE)
    settings = alignment_settings(scene)
    plan = plan_module.read_plan(scene, settings)
    spec = scene.streams[settings.reference]
    once = plan_module.load_stream(plan_module.stream_part(spec, plan.first[settings.reference]))
    reads: list[list[str]] = []
    real = plan_module.load_stream

    def spy(part, **kwargs):
        reads.append(list(part.channels))
        return real(part, **kwargs)

    monkeypatch.setattr(plan_module, "load_stream", spy)
    stream = plan_module.read_first(scene, plan, settings.reference)
    counters = [c for c in once.data_vars if c in spec.channels
                and spec.channels[c].sensor == "encoder"]
    assert len(counters) == 2 and reads[:2] == [[c] for c in counters]
    assert reads[2:] == [[c for c in plan.first[settings.reference] if c not in counters]]
    for channel in counters:  # the one read's values, as exact integers
        once[channel] = once[channel].copy(data=once[channel].to_numpy().astype(np.int32))
    xr.testing.assert_identical(stream, once)  # samples, axis, masks, attributes, order
    assert list(stream.data_vars) == list(once.data_vars)

    def short(part, **kwargs):  # a damaged file whose counter holds fewer samples
        ds = real(part, **kwargs)
        return ds.isel(time=slice(0, -3)) if list(part.channels) == counters[1:2] else ds

    monkeypatch.setattr(plan_module, "load_stream", short)
    with pytest.raises(DataError, match=f"channel '{counters[1]}' of .* holds") as caught:
        plan_module.read_first(scene, plan, settings.reference)
    assert caught.value.where["channel"] == counters[1]


def test_filters_write_into_the_values_only_when_no_later_comparison_needs_them(
        monkeypatch: pytest.MonkeyPatch) -> None:
    # wls1.tor1 is compared alone and then in torque_F: filtered in place the first time, the
    # sum would take its filtered values. The run's revolutions must be those of filters that
    # never write into their input, to the bit, and the sums and released channels in place.
    from rigval.validation import pipeline

    def run(force_copy: bool) -> tuple[dict[str, np.ndarray], dict[str, list[bool]]]:
        cycles: dict[str, np.ndarray] = {}
        overwrites: dict[str, list[bool]] = {}
        real_resample, real_filter = pipeline._resample, pipeline.zero_phase

        def resample(scene, comparison, signal, grid, diagnosis):
            overwrites[comparison.name] = []
            cycles[comparison.name], corner = real_resample(scene, comparison, signal, grid,
                                                            diagnosis)
            return cycles[comparison.name], corner

        def zero_phase(*args, overwrite=False, **kwargs):
            overwrites[list(overwrites)[-1]].append(overwrite)
            return real_filter(*args, overwrite=overwrite and not force_copy, **kwargs)

        with monkeypatch.context() as patch:
            patch.setattr(pipeline, "_resample", resample)
            patch.setattr(pipeline, "zero_phase", zero_phase)
            run_scene(SCENE)
        return cycles, overwrites

    in_place, overwrites = run(force_copy=False)
    copied, _ = run(force_copy=True)
    assert sorted(in_place) == sorted(copied)
    for name in in_place:
        assert in_place[name].tobytes() == copied[name].tobytes(), name
    assert overwrites["tor1"] == [False] and overwrites["torque_F"] == [True]
    assert overwrites["tor2"] == [False] and overwrites["acc1"] == [True, True]


def test_streams_held_whole_are_compared_first_then_the_longest(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A text file's stream (its compared channels read with it) is let go before any is read."""
    import xarray as xr

    scene = load_scene(SCENE)
    plan = plan_module.read_plan(scene, alignment_settings(scene))
    reads = {s.comparison.measured.stream for s in plan.compared if s.read}
    assert reads == {"cdaq", "wls1"}  # wls2 is a CSV file: parsed whole at the first read
    # stand-ins of the aligned streams, the text file's not the shortest
    lengths = {"cdaq": 30, "wls1": 10, "wls2": 20}
    held = {name: xr.Dataset({c: ("time", np.zeros(n)) for c in plan.first[name]}
                             | {"valid": ("time", np.ones(n, bool)),
                                "segment": ("time", np.zeros(n, np.int32))},
                             coords={"time": np.arange(n) / 100.0},
                             attrs={"fs_nominal": 100.0})
            for name, n in lengths.items()}

    def read(scene_, stream, ds, names, on_read):  # the channels "read": zeros
        return ds.assign({c: ("time", np.zeros(ds.sizes["time"])) for c in names})

    monkeypatch.setattr(plan_module, "_add_channels", read)
    seen = [c for c, _ in plan_module.measured_signals(scene, plan, held)]
    streams = [c.measured.stream for c in seen]
    assert list(dict.fromkeys(streams)) == ["wls2", "cdaq", "wls1"]
    assert sorted(streams, key=streams.index) == streams  # each stream's comparisons together
    for stream in lengths:  # and in the scene's order
        assert [c.name for c in seen if c.measured.stream == stream] == [
            c.name for c in scene.comparisons if c.measured.stream == stream]
    assert not held  # every stream let go after its last comparison
