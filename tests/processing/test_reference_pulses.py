"""The main reference pulses found as the reference stream is read, its channel let go after.

:func:`~rigval.processing.stream_alignment.reference_pulses` keeps the pulse channel as its
edges and the samples near them; the alignment made with them must equal the one made on the
whole channel (the old way), pulse window included, and the kept samples must equal the
channel's wherever a window can reach.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

from rigval.acquisition.schema import Channel, stream_dataset
from rigval.processing.alignment_summary import (
    pulse_samples,
    stream_summary,
    with_pulse_window,
)
from rigval.processing.clock_fit import align_stream, identity_clock
from rigval.processing.stream_alignment import align_streams, reference_pulses
from rigval.sample_data import runs_dir
from rigval.validation.read_plan import read_streams
from rigval.validation.scene import load_scene
from rigval.validation.stage_settings import alignment_settings, convert_stream
from tests.processing.alignment_checks import assert_same_alignment

FS = 1000.0


@pytest.mark.parametrize("speed", ["0p8", "1p2"])
def test_alignment_with_pulses_found_as_read_equals_the_whole_channels(speed: str) -> None:
    scene = load_scene(runs_dir() / f"run_{speed}_scene.toml")
    settings = alignment_settings(scene)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the CSV reader notes its guesses
        raw = read_streams(scene)
    converted = {name: convert_stream(raw[name], spec) for name, spec in scene.streams.items()}
    whole = align_streams(settings, converted)

    reference, found = reference_pulses(settings, converted[settings.reference])
    assert found is not None
    assert settings.reference_pulse.name not in reference
    kept = found.samples.values.size / converted[settings.reference].sizes["time"]
    assert 0.0 < kept < 0.2  # 8 % of a revolution around each pulse, and a margin
    reduced = align_streams(settings, {**converted, settings.reference: reference}, found=found)

    for name in scene.streams:
        assert_same_alignment(whole[1][name], reduced[1][name])
        assert np.array_equal(whole[0][name]["time"].to_numpy(),
                              reduced[0][name]["time"].to_numpy())
    assert whole[1][settings.reference].pulse_signal.size > 0
    assert np.array_equal(whole[2].time, reduced[2].time)
    assert np.array_equal(whole[2].phi, reduced[2].phi)
    assert whole[2].zero_u95_s == reduced[2].zero_u95_s


def _pulse_stream(rises: np.ndarray) -> tuple:
    """A 1 kS/s pulse channel in two blocks (a 0.5 s gap after sample 3000), 10 ms marks."""
    n = 6000
    time = np.arange(n) / FS
    time[3000:] += 0.5
    values = np.zeros(n)
    for rise in rises:
        values[(time >= rise) & (time < rise + 0.01)] = 5.0
    segment = (np.arange(n) >= 3000).astype(np.int32)
    stream = stream_dataset(time, {"opt": Channel(values, "V", "opt", "opt")}, device="cDAQ-9172",
                            start_time="2026-03-02T10:00:00Z", source_file="x.tdms",
                            source_sha256="0" * 64, fs_nominal=FS, segment=segment)
    return stream, time, values


def test_kept_samples_equal_the_channel_around_every_edge() -> None:
    # edges near the start (window clipped at sample 0), two close enough for their windows
    # to merge, one each side of the gap
    edges = np.array([0.004, 0.8, 0.9, 2.95, 3.6, 5.0, 6.2])
    stream, time, values = _pulse_stream(edges)
    half_width, delay = 0.06, 0.0
    kept = pulse_samples(stream, "opt", edges, half_width, delay)
    assert kept.starts.size == edges.size - 1  # 0.8 and 0.9 share a run
    assert np.all(kept.starts[1:] > kept.stops[:-1])
    assert kept.values.size < values.size / 5
    for centre in edges:
        lo = max(int(np.searchsorted(time, centre - half_width)) - 2, 0)
        hi = min(int(np.searchsorted(time, centre + half_width)) + 2, time.size)
        assert np.array_equal(kept.between(lo, hi), values[lo:hi])
    with pytest.raises(ValueError, match="not kept"):
        kept.between(1500, 1600)  # between two edges' windows


def test_window_from_kept_samples_equals_the_window_from_the_channel() -> None:
    edges = np.array([0.5, 1.5, 2.5, 3.7, 4.7, 5.7])
    stream, _, _ = _pulse_stream(edges)
    aligned = align_stream(stream, identity_clock(stream["segment"]), name="cdaq")
    summary = stream_summary("cdaq", aligned, identity_clock(), is_reference=True,
                             residual_time=edges, residual=np.zeros(edges.size),
                             matched=edges.size, missing=0, spurious=0)
    delay = float(aligned["opt"].attrs["input_delay_s"])
    kept = pulse_samples(stream, "opt", edges, 0.1, delay)
    for centre in edges:
        for half_width in (0.02, 0.1):  # up to the width the samples were kept for
            old = with_pulse_window(summary, aligned, "opt", edges, centre, half_width)
            new = with_pulse_window(summary, aligned.drop_vars("opt"), "opt", edges, centre,
                                    half_width, kept)
            assert_same_alignment(old, new)
            assert old.pulse_signal.size > 0


def test_fewer_than_two_edges_keep_the_channel() -> None:
    stream, _, _ = _pulse_stream(np.array([2.0]))
    scene = load_scene(runs_dir() / "run_0p8_scene.toml")
    settings = dataclasses.replace(
        alignment_settings(scene), reference_pulse=dataclasses.replace(
            alignment_settings(scene).reference_pulse, name="opt", module=""))
    same, found = reference_pulses(settings, stream)
    assert found is None and same is stream
