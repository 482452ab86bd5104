"""Too few reference pulses: a short record blames the cycles asked for, a dead channel the pulse.

A 15-revolution record asked for 20 cycles has a pulse for every turn the encoder made: the
error names ``angle.min_cycles`` (record longer or ask fewer). The same record whose pulse channel
shows 3 pulses in 15 turns names ``alignment.main_reference_pulse`` (threshold, edge, wiring).
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from rigval.acquisition.channel_map import ChannelSpec
from rigval.acquisition.errors import DataError
from rigval.acquisition.schema import Channel, stream_dataset
from rigval.processing import stream_alignment


def _settings(cpr: int, min_pulses: int) -> stream_alignment.AlignmentSettings:
    return stream_alignment.AlignmentSettings(
        reference="ref",
        encoder=ChannelSpec("enc", "enc", "encoder", {"counts_per_rev": cpr}, None, "", "enc"),
        reference_pulse=ChannelSpec("opt", "opt", "optical", {"threshold": 0.5}, None, "",
                                    "opt"),
        min_pulses=min_pulses, min_pulses_key="angle.min_cycles")


def _run(synth, rises: np.ndarray, turns: float):
    """A reference stream turning ``turns`` revolutions at 1 rev/s with pulses at ``rises``."""
    fs, cpr = synth.FS_REF, synth.CPR
    time = np.arange(0.0, turns, 1 / fs)
    opt = synth.pulse_signal(time, rises, 0.03, fs, np.random.default_rng(2))
    counts = np.floor((synth.TWO_PI * time + 0.5) / synth.TWO_PI * cpr).astype(np.int64)
    return stream_dataset(
        time, {"enc": Channel(counts % 2**32, "counts", "enc", "enc"),
               "opt": Channel(opt, "V", "opt", "opt")},
        device="cDAQ-9172", start_time="2026-03-02T10:00:00Z", source_file="ref.tdms",
        source_sha256="0" * 64, fs_nominal=fs)


def _main_angle(settings: stream_alignment.AlignmentSettings, stream: xr.Dataset
                ) -> stream_alignment.MainAngle:
    """phi_F from the stream's encoder, zero at its reference pulses (found on it first)."""
    found = stream_alignment._pulses(stream, settings.reference_pulse)
    return stream_alignment._main_angle(settings, stream, found)


def test_short_record_names_min_cycles(synth) -> None:
    stream = _run(synth, np.arange(1.0, 15.0) + 0.25, 15.0)  # 14 pulses in 15 turns
    with pytest.raises(DataError, match="fewer than the 20 cycles asked for") as error:
        _main_angle(_settings(synth.CPR, 20), stream)
    assert error.value.where["key"] == "angle.min_cycles"
    assert "turned 15 revolutions" in str(error.value)
    _main_angle(_settings(synth.CPR, 14), stream)  # 14 asked: accepted


def test_pulses_missing_from_a_long_record_name_the_pulse_channel(synth) -> None:
    stream = _run(synth, np.array([3.25, 7.25, 11.25]), 15.0)  # 3 pulses in 15 turns
    with pytest.raises(DataError, match="only 3 reference pulses") as error:
        _main_angle(_settings(synth.CPR, 5), stream)
    assert error.value.where["key"] == "alignment.main_reference_pulse"
