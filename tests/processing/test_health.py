"""Sensor health checks on synthetic channels with faults put in by hand (exact places)."""

from __future__ import annotations

import numpy as np
import pytest

from rigval.processing.health import analog_health
from rigval.processing.health_events import counter_health, pulse_health

FS = 2000.0
N = 40_000  # 20 s at 1 rev/s
LSB = 3e-9


def _signal(seed: int, drift: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """A bridge-like signal: two harmonics of 1e-4, noise 2e-7 rms, 24-bit-like steps."""
    rng = np.random.default_rng(seed)
    t = np.arange(N) / FS
    x = 1e-4 * np.sin(2 * np.pi * t) + 3e-5 * np.sin(4 * np.pi * t + 1.0)
    x += 2e-7 * rng.standard_normal(N) + drift * t / t[-1]
    return t, np.round(x / LSB) * LSB


def _faults(found, kind):
    return [f for f in found if f.fault == kind]


@pytest.mark.parametrize("seed", [1, 2, 3, 4, 5])
def test_clean_channels_raise_nothing(seed):
    # a typical bridge drift (0.4 % of the span over the record) is no fault
    t, x = _signal(seed, drift=1e-6)
    assert analog_health(x, t, channel="tor", fs=FS, period_samples=FS) == []
    counts = np.floor(8192 * t + 100.3).astype(np.int64)
    assert counter_health(counts, t, channel="enc", counts_per_rev=8192) == []


def test_clipping_gives_the_clipped_samples():
    t, x = _signal(1)
    level = 0.8 * np.max(np.abs(x))
    truth = np.flatnonzero(np.abs(x) > level)
    clipped = np.clip(x, -level, level)
    (found,) = _faults(analog_health(clipped, t, channel="tor2", fs=FS, unit="V/V"), "clipping")
    # runs shorter than 3 samples at the level cannot be told from a natural maximum: where
    # noise crosses the level at the ends of a clipped stretch a sample or two is not counted
    assert truth.size - 10 <= found.samples <= truth.size
    assert abs(found.first_sample - truth[0]) <= 3 and abs(found.last_sample - truth[-1]) <= 3
    assert f"{100 * found.samples / N:.2g} % of samples clipped at -0.000103 V/V" in found.text
    assert not found.trusted and found.line().endswith("; not trusted")


def test_flat_line_from_its_first_sample():
    t, x = _signal(2)
    x[30_000:] = x[30_000]
    (found,) = _faults(analog_health(x, t, channel="tor3", fs=FS), "flat line")
    assert (found.first_sample, found.last_sample) == (30_000, N - 1)


def test_spikes_at_their_samples():
    t, x = _signal(3)
    places = np.array([1234, 9000, 17_777, 25_001, 39_000])
    x[places] += np.array([1, -1, 1, -1, 1]) * 3e-5
    (found,) = _faults(analog_health(x, t, channel="str1", fs=FS), "spikes")
    assert found.indices == tuple(places)


def test_noise_over_its_stretch():
    t, x = _signal(4)
    x[12_000:24_000] += 2e-6 * np.random.default_rng(9).standard_normal(12_000)
    found = analog_health(x, t, channel="tor4", fs=FS, period_samples=FS)
    assert [f.fault for f in found] == ["noise"]
    lo, hi = found[0].first_sample, found[0].last_sample
    overlap = (min(hi, 23_999) - max(lo, 12_000)) / (max(hi, 23_999) - min(lo, 12_000))
    assert overlap >= 0.9 and 8 < found[0].value < 12


def test_zero_drift_over_the_record():
    t, x = _signal(5, drift=1.5e-5)  # 5.8 % of the span
    (found,) = _faults(analog_health(x, t, channel="tor1", fs=FS, period_samples=FS),
                       "zero drift")
    # the line through whole-revolution means: within 5 % of the ramp (noise, end effects)
    assert found.value == pytest.approx(1.5e-5, rel=0.05)


def test_count_jump_and_glitch_at_their_samples():
    t = np.arange(N) / FS
    counts = np.floor(8192 * t).astype(np.int64)
    counts[20_000:] += 40
    counts[12_345] += 25
    raw = (counts % 8192).astype(np.uint32)  # an index reload every turn, as DAQmx does
    found = counter_health(raw, t, channel="enc1", counts_per_rev=8192)
    jump, glitch = _faults(found, "count jump"), _faults(found, "count glitch")
    # sizes against the local rate (4.096 counts per sample, steps of 4 or 5): +-1 count
    assert jump[0].indices == (20_000,) and abs(jump[0].value - 40) <= 1
    assert glitch[0].indices == (12_345,) and abs(glitch[0].value - 25) <= 1
    assert jump[0].revolutions == (10,)  # 10 turns from the start


def test_pulse_width_change_from_its_pulse():
    t = np.arange(N) / FS
    x = np.zeros(N)
    for k in range(20):
        width = 0.03 * (1.3 if k >= 10 else 1.0)
        x[(t >= 0.4 + k) & (t < 0.4 + k + width)] = 1.0
    x += 1e-3 * np.random.default_rng(3).standard_normal(N)
    (found,) = pulse_health(x, t, channel="opt2")
    assert found.revolutions[0] == 10 and found.value == pytest.approx(0.3, abs=0.05)


def test_alternating_pulse_widths_are_no_change():
    """A shaft whose speed differs at its two passes (widths alternate) with a missing pulse."""
    t = np.arange(N) / FS
    x = np.zeros(N)
    for k in range(20):
        if k != 7:
            x[(t >= 0.4 + k) & (t < 0.4 + k + (0.030 if k % 2 else 0.033))] = 1.0
    assert pulse_health(x, t, channel="opt3") == []


def test_spikes_found_in_blocks_equal_the_whole_stretch_median(monkeypatch):
    """The block-wise spike search equals the running median over each whole stretch."""
    from scipy.ndimage import median_filter

    from rigval.processing import health

    monkeypatch.setattr(health, "_BLOCK", 4096)  # many block edges, some inside the gaps' runs
    rng = np.random.default_rng(11)
    n, fs, q = 60_007, 2000.0, 1e-5
    x = np.round((np.sin(np.arange(n) / fs * 7) + rng.normal(0, 1e-3, n)) / q) * q
    spikes = rng.choice(n, 30, replace=False)
    x[spikes] += rng.choice([-1, 1], 30) * rng.uniform(0.05, 0.5, 30)
    ok = np.ones(n, bool)
    ok[rng.choice(n, 50, replace=False)] = False
    found = health._spikes(x, ok, np.arange(n) / fs, health._Windows.of(x, ok, fs), "c", "V", q)

    width = max(int(health._NOISE_WINDOW_S * fs), 20)
    noise, _ = health._window_noise(x, ok, width)
    noise = np.maximum(noise, np.maximum(np.r_[noise[1:], noise[-1]], np.r_[noise[0], noise[:-1]]))
    base = np.full(n, np.nan)
    for a, b in zip(*health.runs_of(ok), strict=True):
        base[a:b] = median_filter(x[a:b], size=health._SPIKE_WINDOW, mode="nearest")
    local = noise[np.minimum(np.arange(n) // width, noise.size - 1)]
    with np.errstate(invalid="ignore"):
        expected = np.flatnonzero(np.abs(x - base) > np.maximum(health._SPIKE_SIGMAS * local,
                                                                4.0 * q))
    assert expected.size >= 25  # most injected spikes stand out (a few hit invalid samples)
    assert found and found[0].samples == expected.size
    assert found[0].indices == tuple(int(i) for i in expected[:len(found[0].indices)])
