"""The interval of phi_F = 0 holds the reference pulses' scatter (closed form)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import t as student_t

from rigval.acquisition.channel_map import ChannelSpec
from rigval.acquisition.schema import Channel, stream_dataset
from rigval.processing import stream_alignment
from rigval.processing.pulses import SYMMETRIC_BOUND


def test_zero_interval_is_the_student_t_interval_of_the_pulse_jitter(synth) -> None:
    """Pulses alternately +-d s off phi_F = 2 pi k at exactly 1 rev/s: the rms scatter of the
    pulses about phi_F = 0 is d (2 pi d rad), so the half-width of the mean's 95 % interval is
    t_0.975(n - 1) d / sqrt(n), combined with the band-limited edges' bound (no module: no
    half-sample bound)."""
    fs, cpr, jitter = synth.FS_REF, synth.CPR, 1e-3
    rng = np.random.default_rng(4)
    time = np.arange(0.0, 41.0, 1 / fs)
    revs = np.arange(1, 41)
    rises = revs + jitter * (-1.0) ** revs                    # 40 pulses, mean offset 0
    opt = synth.pulse_signal(time, rises, 0.03, fs, rng)
    counts = np.floor((synth.TWO_PI * time + 0.5) / synth.TWO_PI * cpr).astype(np.int64)
    stream = stream_dataset(
        time, {"enc": Channel(counts % 2**32, "counts", "enc", "enc"),
               "opt": Channel(opt, "V", "opt", "opt")},
        device="cDAQ-9172", start_time="2026-03-02T10:00:00Z", source_file="ref.tdms",
        source_sha256="0" * 64, fs_nominal=fs)
    settings = stream_alignment.AlignmentSettings(
        reference="ref",
        encoder=ChannelSpec("enc", "enc", "encoder", {"counts_per_rev": cpr}, None, "", "enc"),
        reference_pulse=ChannelSpec("opt", "opt", "optical", {"threshold": 0.5}, None, "",
                                    "opt"))
    found = stream_alignment._pulses(stream, settings.reference_pulse)
    main = stream_alignment._main_angle(settings, stream, found)
    n = found.good.size
    # band-limited edges: bounded by the sinc crossing's own error (SYMMETRIC_BOUND sample)
    bound = SYMMETRIC_BOUND / fs
    assert n == revs.size and found.shape == "symmetric" and found.timing_bound_s == bound
    expected = float(np.hypot(float(student_t.ppf(0.975, n - 1)) * jitter / np.sqrt(n), bound))
    # 2 %: the edges' timing error (< 0.005 sample rms, see test_pulses_align) and the
    # smoothed encoder angle's quantisation (1/8192 rev) are below 1 % of d = 5 samples
    assert main.zero_u95_s == pytest.approx(expected, rel=0.02)
