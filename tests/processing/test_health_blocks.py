"""The analog health checks without whole-record temporaries equal the whole-record formulas.

Each part that now works a block (or a window) at a time is checked against the formula it
replaced, computed here on the whole record, with blocks small enough that clipped runs, flat
stretches and gaps cross their edges.
"""

from __future__ import annotations

import numpy as np
import pytest

from rigval.processing import health

FS = 2000.0


@pytest.fixture
def small_blocks(monkeypatch: pytest.MonkeyPatch) -> None:
    """Blocks of 997 samples: many block edges, some inside the runs below."""
    monkeypatch.setattr(health, "_BLOCK", 997)


def _channel(seed: int, n: int = 30_011, clip: bool = True
             ) -> tuple[np.ndarray, np.ndarray, float]:
    """A quantised sine with noise, clipped at both ends, a flat stretch and invalid samples."""
    rng = np.random.default_rng(seed)
    q = 1e-4
    x = np.round((np.sin(np.arange(n) / FS * 9.0) + rng.normal(0.0, 2e-3, n)) / q) * q
    if clip:
        x = np.clip(x, -0.9, 0.95)
    x[12_000:12_400] = x[12_000]  # flat across a block edge (997 * 12 = 11_964 ... 12_961)
    ok = np.ones(n, dtype=bool)
    ok[rng.choice(n, 40, replace=False)] = False
    ok[20_930:21_020] = False  # a gap across a block edge
    return x, ok, q


@pytest.mark.usefixtures("small_blocks")
@pytest.mark.parametrize("seed", [1, 2])
def test_clipping_and_flat_lines_by_blocks_equal_the_whole_record(seed: int) -> None:
    x, ok, q = _channel(seed)
    time = np.arange(x.size) / FS
    clipped_at = []
    for level in (float(np.max(x, where=ok, initial=-np.inf)),
                  float(np.min(x, where=ok, initial=np.inf))):
        whole = ok & (np.abs(x - level) <= 0.5 * q)
        by_blocks = health._mask(x.size, lambda lo, hi, level=level: ok[lo:hi] & (
            np.abs(x[lo:hi] - level) <= 0.5 * q))
        assert np.array_equal(whole, by_blocks) and whole.sum() > 100
        a, b = health.runs_of(whole)  # the runs at the level of at least _CLIP_RUN samples
        clipped_at += [np.arange(i, j) for i, j in zip(a, b, strict=True)
                       if j - i >= health._CLIP_RUN]
    expected = np.sort(np.concatenate(clipped_at))
    still = ok[1:] & ok[:-1] & (np.abs(np.diff(x)) <= q)
    starts, stops = health.runs_of(still)
    longest = int(np.argmax(stops - starts))
    (flat,) = [f for f in health._flat(x, ok, time, FS, "c", "V", q, [])
               if f.first_sample == starts[longest]]
    assert flat.last_sample == stops[longest]  # one past the run of steps: its last sample
    (clipped,) = health._clipping(x, ok, time, "c", "V", None, q)
    assert clipped.samples == expected.size > 100
    assert (clipped.first_sample, clipped.last_sample) == (expected[0], expected[-1])


@pytest.mark.parametrize(("seed", "block"), [(1, 1 << 20), (2, 1 << 20), (1, 1700)])
def test_window_noise_from_each_window_equals_the_whole_record_differences(
        seed: int, block: int, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(health, "_BLOCK", block)  # 1700: three windows to a block of rows
    x, ok, _ = _channel(seed)
    width = 500
    d3 = np.diff(x, 3)
    use = ok[3:] & ok[2:-1] & ok[1:-2] & ok[:-3]
    starts = np.arange(0, d3.size - width + 1, width)
    expected = np.full(starts.size, np.nan)
    for n, a in enumerate(starts):
        part = d3[a:a + width][use[a:a + width]]
        if part.size >= width // 2:
            expected[n] = 1.4826 * float(np.median(np.abs(part - np.median(part)))) / np.sqrt(20)
    noise, found_starts = health._window_noise(x, ok, width)
    assert np.array_equal(found_starts, starts)
    assert np.array_equal(noise, expected, equal_nan=True)
    assert np.isnan(noise).sum() == 0  # no window loses half its samples here


def test_time_at_positions_equals_interpolation_over_every_index() -> None:
    time = np.cumsum(np.random.default_rng(4).uniform(0.9e-3, 1.1e-3, 10_001))
    time[6000:] += 0.5  # a gap
    positions = np.array([0.0, 0.5, 1999.5, 2000.0, 5999.5, 6000.0, 9999.5, 10_000.0])
    assert np.array_equal(health._time_at(positions, time),
                          np.interp(positions, np.arange(time.size), time))


@pytest.mark.usefixtures("small_blocks")
def test_first_usable_samples_equal_the_masked_record() -> None:
    x, ok, _ = _channel(3)
    for count in (1, 996, 997, 5000, x.size):
        assert np.array_equal(health._first_usable(x, ok, count), x[ok][:count])


@pytest.mark.parametrize(("clip", "fault"), [(True, "clipping"), (False, "flat line")])
def test_analog_health_by_small_blocks_equals_one_block(clip: bool, fault: str,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    x, ok, _ = _channel(1, clip=clip)
    time = np.arange(x.size) / FS
    kwargs = {"channel": "c", "fs": FS, "unit": "V", "valid": ok, "period_samples": 1396.6}
    whole = health.analog_health(x, time, **kwargs)
    monkeypatch.setattr(health, "_BLOCK", 997)
    assert health.analog_health(x, time, **kwargs) == whole
    assert fault in {f.fault for f in whole}


@pytest.mark.usefixtures("small_blocks")
@pytest.mark.parametrize("usable", [[5], [0, 996, 997], [2000, 29_000, 30_010]])
def test_first_and_last_usable_sample_equal_the_index_list(usable: list[int]) -> None:
    ok = np.zeros(30_011, dtype=bool)
    ok[usable] = True
    where = np.flatnonzero(ok)
    assert health._first_and_last(ok) == (where[0], where[-1])


@pytest.mark.usefixtures("small_blocks")
@pytest.mark.parametrize("seed", [1, 2, 3])
@pytest.mark.parametrize("percents", [(0.5, 99.5), (0.0, 100.0), (20.0,), (50.0,)])
def test_usable_percentiles_equal_numpy_on_the_masked_copy(seed: int, percents) -> None:
    # the zero drift's span without the copy x[ok]: numpy's percentiles of the copy, to the bit
    # (zeros compared by value: which of two tied signed zeros numpy's partition puts first
    # is its own choice, and a span of zero is zero either way)
    x, ok, _ = _channel(seed)
    x[:5] = [0.0, -0.0, 0.0, -0.0, 3.0]
    for n in (x.size, 1, 2, 3, 201):
        expected = np.percentile(x[:n][ok[:n]], list(percents))
        found = health._usable_percentiles(x[:n], ok[:n], percents)
        assert (found + 0.0).tobytes() == (expected + 0.0).tobytes(), n


@pytest.mark.usefixtures("small_blocks")
def test_moving_samples_equal_the_whole_record_masks() -> None:
    # the usable samples outside the findings' spans and 3 samples from each gap, made in one
    # mask: the whole-record formula ok & ~(clipped | spans) less the gaps' neighbours
    x, ok, q = _channel(4)
    time = np.arange(x.size) / FS
    segment = (np.arange(x.size) >= 17_944).astype(np.int32) + (np.arange(x.size) >= 25_000)
    clipping = health._clipping(x, ok, time, "c", "V", None, q)
    findings = [*clipping, *health._flat(x, ok, time, FS, "c", "V", q, clipping)]
    assert "clipping" in {f.fault for f in findings}
    stuck = np.zeros(x.size, dtype=bool)
    for found in findings:
        stuck[found.first_sample:found.last_sample + 1] = True
    expected = ok & ~stuck
    for b in np.flatnonzero(segment[1:] != segment[:-1]) + 1:
        expected[max(b - 3, 0):b + 3] = False
    usable = int(ok.sum())
    moving = health._moving(ok, findings, segment)  # ok handed over
    assert np.array_equal(moving, expected)
    assert not moving[17_941:17_947].any() and moving.sum() < usable


@pytest.mark.parametrize("block", [1, 2, 5, 997, 1 << 20])
def test_long_runs_found_block_by_block_equal_the_whole_masks(block: int, monkeypatch) -> None:
    """Runs crossing block edges, starting or ending a block, filling one or the whole record."""
    monkeypatch.setattr(health, "_BLOCK", block)
    rng = np.random.default_rng(block)
    for mask in (rng.random(5_000) < 0.9, np.ones(3_000, bool), np.zeros(2_000, bool),
                 np.repeat([True, False, True], [997, 997, 1994]), np.array([True])):
        starts, stops = health.runs_of(mask)
        for min_length in (0, 1, 5, 40, 997, 3_000):
            long = stops - starts >= min_length
            found = health._long_runs(mask.size, lambda lo, hi, mask=mask: mask[lo:hi],
                                      min_length)
            for got, want in zip(found, (starts[long], stops[long]), strict=True):
                assert np.array_equal(got, want) and got.dtype == np.int64, min_length


def test_clipped_share_from_spans_equals_the_mask_mean() -> None:
    rng = np.random.default_rng(3)
    for _ in range(200):
        spans = [(int(a), int(a + w)) for a, w in zip(rng.integers(0, 900, 4),
                                                    rng.integers(1, 120, 4), strict=True)]
        mask = np.zeros(1_100, dtype=bool)
        for a, b in spans:
            mask[a:b] = True
        a = int(rng.integers(0, 1_000))
        b = int(rng.integers(a + 1, 1_100))
        assert health._covered(health._merged_spans(spans), a, b) / (b - a) == mask[a:b].mean()
