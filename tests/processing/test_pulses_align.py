"""Edges, pulse classification and clock alignment on synthetic two-clock runs with known truth."""

from __future__ import annotations

import numpy as np
import pytest

from rigval.acquisition.schema import invalid_counts
from rigval.processing import angle, clock_fit, encoder, excitation, pulses
from rigval.processing.errors import AlignmentError


def _edges(rig, polarity: str) -> tuple[np.ndarray, np.ndarray]:
    ref = pulses.detect_edges(rig.opt1, rig.t_ref, refine="sinc", holdoff_s=0.01,
                              polarity=polarity)
    dev = pulses.detect_edges(rig.opt2, rig.t_dev, refine="sinc", holdoff_s=0.01,
                              polarity=polarity)
    return pulses.classify_pulses(ref).good, pulses.classify_pulses(dev).good - rig.delay


def test_band_limited_edges_are_timed_well_below_a_twentieth_of_a_sample(synth) -> None:
    FS_REF, pulse_signal = synth.FS_REF, synth.pulse_signal
    rng = np.random.default_rng(5)
    t = np.arange(0.0, 30.0, 1 / FS_REF)
    rises = np.arange(1.0, 29.0, 0.97) + rng.uniform(0, 1 / FS_REF, 29)
    x = pulse_signal(t, rises, 0.03, FS_REF, rng, noise=1e-3)
    linear = (pulses.detect_edges(x, t) - rises) * FS_REF
    sinc = (pulses.detect_edges(x, t, refine="sinc") - rises) * FS_REF
    assert np.sqrt(np.mean(linear**2)) < 0.05
    assert np.sqrt(np.mean(sinc**2)) < 0.005
    falling = pulses.detect_edges(x, t, refine="sinc", polarity="falling")
    assert np.max(np.abs(falling - rises - 0.03)) * FS_REF < 0.01


def test_hysteresis_ignores_noise_around_the_threshold_and_holdoff_debounces() -> None:
    t = np.arange(0, 1, 1e-3)
    x = np.where((t > 0.2) & (t < 0.5), 1.0, 0.0)
    x[200:210] = [0.45, 0.55, 0.45, 0.55, 0.45, 0.9, 0.2, 1, 1, 1]     # chatter at the edge
    edges = pulses.detect_edges(x, t, low=0.3, high=0.7)
    assert edges.size == 2                                             # chatter re-arms once
    debounced = pulses.detect_edges(x, t, low=0.3, high=0.7, holdoff_s=0.01)
    # timed at the last mid-level crossing before the trigger fired (0.45 -> 0.9)
    assert debounced.size == 1 and debounced[0] == pytest.approx(0.204 + 0.05 / 0.45 * 1e-3)


def test_classification_finds_spurious_and_missing_pulses(synth) -> None:
    true = synth.crossing_times(synth.TWO_PI * np.arange(1, 40))
    observed = np.sort(np.concatenate([np.delete(true, [5, 17, 18]), [true[9] + 0.31,
                                                                      true[30] + 0.62]]))
    train = pulses.classify_pulses(observed)
    np.testing.assert_allclose(np.sort(observed[train.spurious]),
                               [true[9] + 0.31, true[30] + 0.62])
    np.testing.assert_allclose(train.missing_times, true[[5, 17, 18]], atol=0.05)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_clock_offset_and_drift_from_a_two_second_coarse_error(make_rig, seed: int) -> None:
    """Done-when: 20 s at ~1 rev/s, 10 % missing, spurious pulses, start times 2 s off."""
    rig = make_rig(seed, missing=0.1, spurious=2)
    kinds = [_edges(rig, p) for p in ("rising", "falling")]
    clock = clock_fit.estimate_clock([k[0] for k in kinds], [k[1] for k in kinds],
                                 coarse_offset_s=0.0, max_offset_error_s=5.0)
    assert abs(clock.offsets_s[0] - rig.offset) < 5e-6
    assert abs(clock.drift - rig.drift) * 1e6 < 0.05
    assert clock.residual_rms_s < 3e-6
    assert clock.pulses_matched >= 30


def test_pulses_twice_per_revolution_align_on_encoder_crossings(make_rig, synth) -> None:
    FS_REF, TWO_PI = synth.FS_REF, synth.TWO_PI
    rig = make_rig(7)
    theta = encoder.counts_to_angle(encoder.unwrap_counts(rig.counts), 8192)
    smooth = excitation.drive_angle(rig.t_ref, theta, fs=FS_REF, step_rad=TWO_PI / 8192)
    opt1 = pulses.classify_pulses(pulses.detect_edges(rig.opt1, rig.t_ref, refine="sinc")).good
    zero, scatter = angle.zero_at_reference(rig.t_ref, smooth.angle, opt1)
    assert scatter < 1e-4
    ref_events = clock_fit.reference_event_times(rig.t_ref, smooth.angle - zero, event_angle=0.3,
                                             events_per_rev=2)
    dev = pulses.detect_edges(rig.opt3, rig.t_dev, refine="sinc") - rig.delay
    clock = clock_fit.estimate_clock(ref_events, dev, coarse_offset_s=1.2)
    assert abs(clock.offsets_s[0] - rig.offset) < 5e-6
    assert abs(clock.drift - rig.drift) * 1e6 < 0.15
    with pytest.raises(AlignmentError, match="inconsistent periods"):
        clock_fit.estimate_clock(opt1, dev, coarse_offset_s=1.2)


def test_perfectly_regular_pulses_with_a_large_coarse_error_are_ambiguous() -> None:
    ref = np.arange(0.0, 30.0, 1.0)
    dev = np.arange(0.3, 20.0, 1.0)
    with pytest.raises(AlignmentError, match="ambiguity"):
        clock_fit.estimate_clock(ref, dev, coarse_offset_s=0.0, max_offset_error_s=3.0)
    clock = clock_fit.estimate_clock(ref, dev, coarse_offset_s=2.6, max_offset_error_s=0.4)
    assert clock.offsets_s[0] == pytest.approx(2.7, abs=1e-9)


def test_no_overlap_and_too_few_events_are_reported() -> None:
    ref = np.arange(0.0, 20.0, 1.0)
    with pytest.raises(AlignmentError, match="no overlap"):
        clock_fit.estimate_clock(ref, np.arange(0.0, 10.0, 1.0), coarse_offset_s=100.0)
    with pytest.raises(AlignmentError, match="too few"):
        clock_fit.estimate_clock(ref, np.array([1.0, 2.0]))


def test_restarted_segments_get_their_own_offsets(make_rig) -> None:
    rig = make_rig(11, missing=0.0, spurious=0)
    edges = pulses.detect_edges(rig.opt2, rig.t_dev, refine="sinc") - rig.delay
    # The reader placed the block after a restart 0.4 s wrong: events of segment 1 shift.
    segment = (edges > 10.0).astype(np.int64)
    shifted = edges + 0.4 * segment
    ref = pulses.detect_edges(rig.opt1, rig.t_ref, refine="sinc")
    clock = clock_fit.estimate_clock(ref, shifted, segment, coarse_offset_s=2.0)
    assert clock.segments == (0, 1)
    assert clock.offsets_s[0] == pytest.approx(rig.offset, abs=5e-6)
    assert clock.offsets_s[1] == pytest.approx(rig.offset - 0.4 * (1 + rig.drift), abs=5e-6)
    mapped = clock.to_reference(shifted, segment)
    np.testing.assert_allclose(mapped, rig.offset + (1 + rig.drift) * edges, atol=5e-6)


def test_ni9237_delay_values(synth) -> None:
    FS_DEV = synth.FS_DEV
    assert clock_fit.ni9237_input_delay(5000.0) == pytest.approx(8.0065e-3, abs=1e-7)
    assert clock_fit.ni9237_input_delay(FS_DEV) == pytest.approx(24.81e-3, abs=1e-5)
    assert (clock_fit.input_delay({"module": "NI 9237"}, 5000.0)
            == clock_fit.ni9237_input_delay(5000.0))
    assert clock_fit.input_delay({"module": "NI 9411"}, 5000.0) == 0.0
    assert clock_fit.input_delay({"input_delay_s": 1e-3, "module": "NI 9237"}, 5000.0) == 1e-3


def test_a_segment_without_enough_pulses_is_marked_invalid_not_guessed(make_rig, synth) -> None:
    from rigval.acquisition.errors import DataWarning
    from rigval.acquisition.schema import Channel, stream_dataset

    rig = make_rig(12, missing=0.0, spurious=0)
    segment = (rig.t_dev > 18.6).astype(np.int32)            # the last 1.4 s: one pulse at most
    wls = stream_dataset(rig.t_dev, {"opt2": Channel(rig.opt2, "V", "opt2", "/'w'/'opt2'",
                                                     attrs={"module": "NI 9237"})},
                         device="WLS-9163", start_time="2026-03-02T10:00:02Z",
                         source_file="w.tdms", source_sha256="0", fs_nominal=synth.FS_DEV,
                         segment=segment)
    dev = pulses.stream_pulses(wls, "opt2")
    ref = pulses.detect_edges(rig.opt1, rig.t_ref, refine="sinc")
    clock = clock_fit.estimate_clock(ref, dev.good, dev.good_segment, coarse_offset_s=2.0)
    assert clock.segments == (0,) and clock.unaligned_segments == (1,)
    with pytest.warns(DataWarning, match="could not be aligned"):
        aligned = clock_fit.align_stream(wls, clock)
    assert not aligned["valid"].to_numpy()[segment == 1].any()
    assert aligned["valid"].to_numpy()[segment == 0].all()
    assert np.all(np.diff(aligned["time"].to_numpy()) > 0)
    assert invalid_counts(aligned)["unaligned segment"] == (segment == 1).sum()
    np.testing.assert_allclose(aligned["time"].to_numpy()[segment == 0],
                               rig.offset + (1 + rig.drift) * rig.t_dev[segment == 0], atol=5e-6)


def test_exactly_periodic_events_are_ambiguous_too() -> None:
    ref = np.arange(0.0, 64.0, 0.5)                       # exact binary fractions: zero residual
    dev = np.arange(0.25, 40.0, 0.5)
    with pytest.raises(AlignmentError, match="ambiguity"):
        clock_fit.estimate_clock(ref, dev, coarse_offset_s=1.0, max_offset_error_s=2.0)


def test_two_hours_of_events_at_100_ppm_drift_all_match(synth) -> None:
    rng = np.random.default_rng(9)
    ref = synth.crossing_times(synth.TWO_PI * np.arange(1, 7200))
    drift, offset = 100e-6, 3.217
    dev = (ref - offset) / (1 + drift) + 1e-6 * rng.standard_normal(ref.size)
    dev = dev[(dev > 0) & (dev < 7000)]
    clock = clock_fit.estimate_clock(ref, np.delete(dev, np.arange(0, dev.size, 7)),
                                 coarse_offset_s=offset - 1.5)
    assert clock.pulses_matched == dev.size - dev[::7].size
    assert abs(clock.drift - drift) * 1e6 < 1e-3
    assert abs(clock.offsets_s[0] - offset) < 1e-6


def test_sinc_crossings_of_all_edges_at_once_equal_brent_on_each(synth) -> None:
    # the vectorised Illinois search against scipy's brentq on the same reconstruction, edge by
    # edge; near the record's ends (window outside) both fall back to the linear crossing
    from scipy.optimize import brentq
    from scipy.special import i0
    FS_REF, pulse_signal = synth.FS_REF, synth.pulse_signal
    rng = np.random.default_rng(11)
    t = np.arange(0.0, 20.0, 1 / FS_REF)
    rises = np.concatenate([[0.0015], np.arange(0.5, 19.5, 0.61) + rng.uniform(0, 1 / FS_REF, 32)])
    x = pulse_signal(t, rises, 0.03, FS_REF, rng, noise=1e-3)
    low, high = pulses.state_levels(x)
    mid = 0.5 * (low + high)
    ups = np.flatnonzero((x[:-1] < mid) & (x[1:] >= mid))
    found = pulses._sinc_crossings(x, ups, mid)
    half, beta = pulses._HALF_WINDOW, pulses._KAISER_BETA
    for j, position in zip(ups, found, strict=True):
        if j - half + 1 < 0 or j + half + 1 > x.size:
            assert np.isnan(position)
            continue
        n = np.arange(j - half + 1, j + half + 1)

        def level(p: float, n: np.ndarray = n) -> float:
            d = p - n
            w = i0(beta * np.sqrt(np.clip(1 - (d / half) ** 2, 0, None))) / i0(beta)
            return float(np.sum(x[n] * np.sinc(d) * w)) - mid

        assert abs(position - brentq(level, j, j + 1, xtol=1e-12)) < 1e-9
    assert np.isfinite(found).sum() >= 30


def test_state_levels_in_chunks_with_a_mask_equal_the_masked_copy(monkeypatch) -> None:
    rng = np.random.default_rng(4)
    x = np.where(rng.random(300_001) < 0.3, 5.0, 0.2) + 0.01 * rng.standard_normal(300_001)
    x[::1000] = np.nan
    valid = rng.random(x.size) > 0.05
    valid[:5000] = False
    x[:5000] = 50.0                                   # invalid samples far outside: ignored
    whole = pulses.state_levels(x[valid & np.isfinite(x)])
    monkeypatch.setattr(pulses, "_LEVEL_CHUNK", 7_777)
    np.testing.assert_allclose(pulses.state_levels(x, mask=valid), whole, rtol=1e-12)
    assert whole[0] == pytest.approx(0.2, abs=1e-3) and whole[1] == pytest.approx(5.0, abs=1e-3)


def test_a_stray_partner_in_a_four_pulse_segment_is_rejected_by_the_whole_fit() -> None:
    # Seed 21 of the virtual rig: after a dropout the device restarts with 4 pulses left; its
    # last pulse is missing and a spurious one 0.12 s earlier takes its partner. The segment's
    # own line cannot tell the stray (1 in 4); the drift of the long segment can.
    ref = np.arange(0.0, 17.0, 1.0) + 0.003
    drift, offsets = 33e-6, (1.1, 1.3)
    segment = (ref > 12.5).astype(np.int64)
    dev = (ref - np.take(offsets, segment)) / (1 + drift)
    dev[-1] -= 0.12
    clock = clock_fit.estimate_clock(ref, dev, segment, coarse_offset_s=1.2,
                                     max_offset_error_s=0.3)
    assert clock.segments == (0, 1)
    assert clock.pulses_matched == ref.size - 1
    # noise-free pulses: the fit without the stray is exact to rounding
    assert clock.offsets_s == pytest.approx(offsets, abs=1e-9)
    assert clock.drift == pytest.approx(drift, abs=1e-12)


def _late_restart(drift_bound: float, period: float = 1.0, window: float = 0.116,
                  restart: float = 9454.8
                  ) -> tuple[clock_fit.ClockModel, np.ndarray, np.ndarray, np.ndarray]:
    """Four hours of pulses; the device restarts after a dropout, ``restart`` s in, with a new
    host stamp.

    The reference's record runs 26.7 ppm slow of host time, so by a restart 9454.8 s in it is
    0.25 s behind the stamps: the restarted segment lies 0.28 s off its stamps' offset, beyond
    the 0.116 s window the stamps alone allow (WLS #1 of the 4 h virtual-rig record, seed 1).
    """
    rng = np.random.default_rng(3)
    count = round(14400 / period)
    true = np.cumsum(period * (1.0 + 0.004 * rng.standard_normal(count)))  # speed wander
    ref_drift, dev_drift = -26.7e-6, -7.9e-6
    start, gap = 0.635, 0.2
    stamp0, stamp1 = start + 0.0376, restart + 0.0295  # host stamps, ms off
    seen = (true > start + 0.5) & ~((true > restart - gap) & (true <= restart))
    true = true[seen]
    segment = (true > restart).astype(np.int64)
    dev = np.where(segment == 0, (true - start) * (1 + dev_drift),
                   (stamp1 - stamp0) + (true - restart) * (1 + dev_drift))
    ref = true * (1 + ref_drift)
    clock = clock_fit.estimate_clock(ref, dev, segment, coarse_offset_s=stamp0,
                                     max_offset_error_s=window, drift_bound=drift_bound)
    return clock, ref, dev, segment


def test_a_restart_hours_in_is_matched_although_the_reference_ran_off_host_time() -> None:
    clock, ref, dev, segment = _late_restart(drift_bound=100e-6)  # 2 x 50 ppm oscillators
    assert clock.segments == (0, 1) and not clock.unaligned_segments
    assert clock.pulses_matched == ref.size
    np.testing.assert_allclose(clock.to_reference(dev, segment), ref, rtol=0, atol=1e-6)
    # the window without the clocks' drift leaves the restarted segment out
    stamps_only, *_ = _late_restart(drift_bound=0.0)
    assert stamps_only.unaligned_segments == (1,)


def test_a_late_segment_the_data_placed_is_kept_though_whole_periods_from_the_first() -> None:
    """Two pulses per revolution (0.5 s), a 1.116 s window and a restart 10868 s in (WLS #2 of
    the 4 h record): the data place the restarted segment 0.32 s (more than half a period)
    from the first segment's offset, which the clocks' drift over that time allows; it must
    not be matched again around the first segment's offset."""
    late = {"period": 0.5, "window": 1.116, "restart": 10868.5}
    clock, ref, dev, segment = _late_restart(100e-6, **late)
    assert not clock.unaligned_segments and clock.pulses_matched == ref.size
    np.testing.assert_allclose(clock.to_reference(dev, segment), ref, rtol=0, atol=1e-6)
    stamps_only, *_ = _late_restart(0.0, **late)
    assert stamps_only.unaligned_segments == (1,)
