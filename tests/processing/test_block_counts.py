"""Counter health, index reloads and medians worked in blocks against whole-record results."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import median_filter

from rigval.processing import encoder, health_events
from rigval.processing.block_median import exact_median
from rigval.processing.encoder import remove_index_resets, unwrap_counts


@pytest.mark.parametrize("size", [1, 2, 7, 1000, 1001])
def test_exact_median_equals_numpy_median(size: int) -> None:
    rng = np.random.default_rng(size)
    ints = rng.integers(-5, 6, size)
    floats = np.round(rng.normal(size=size), 2)  # ties
    for values in (ints, floats, np.abs(floats)):
        blocks = [values[lo:lo + 97] for lo in range(0, size, 97)]
        assert exact_median(blocks) == np.median(values)
    assert np.isnan(exact_median([np.zeros(0)]))


@pytest.mark.parametrize("many", [False, True])
def test_index_resets_equal_whole_record_correction(many: bool,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    if many:
        monkeypatch.setattr(encoder, "_MANY_RESETS", 3)
    cpr = 1000
    truth = np.floor(np.linspace(0, 25.3 * cpr, 3_000_001)).astype(np.int64)
    reloaded = truth % cpr
    c = reloaded.astype(np.int64)
    steps = np.diff(c)  # the whole-record correction
    resets = np.flatnonzero(np.abs(steps) > cpr / 2) + 1
    correction = np.zeros(c.size, dtype=np.int64)
    correction[resets] = -np.round(steps[resets - 1] / cpr).astype(np.int64) * cpr
    restored, found = remove_index_resets(reloaded, cpr)
    np.testing.assert_array_equal(restored, c + np.cumsum(correction))
    np.testing.assert_array_equal(found, resets)
    np.testing.assert_array_equal(restored - restored[0], truth - truth[0])


def _whole_record_threshold(raw: np.ndarray, ok: np.ndarray, cpr: float
                            ) -> tuple[np.ndarray, float]:
    """Departures and the jump threshold from whole-record arrays (one median filter)."""
    cumulative = unwrap_counts(np.where(ok, raw, 0).astype(np.int64))
    cumulative, _ = remove_index_resets(cumulative, cpr)
    step = np.diff(cumulative)
    usable = ok[1:] & ok[:-1]
    typical = float(np.nan_to_num(np.median(step[usable])))
    rate = median_filter(np.where(usable, step, typical), size=health_events._RATE_WINDOW,
                         mode="nearest")
    departure = np.where(usable, step - rate, 0.0)
    spread = 1.4826 * float(np.median(np.abs(departure[usable])))
    return departure, max(health_events._JUMP_COUNTS, health_events._JUMP_SIGMAS * spread)


def test_counter_health_in_blocks_equals_whole_record(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(health_events, "_BLOCK", 5_000)  # many block edges
    fs, n, cpr = 2000.0, 60_001, 8192
    t = np.arange(n) / fs
    counts = np.floor(cpr * t * (1 + 0.05 * np.sin(t))).astype(np.int64)
    counts[20_000:] += 40  # a jump
    counts[4_999] += 25  # a glitch on a block edge
    counts[15_001:15_003] -= 30  # a glitch across an edge
    raw = (counts % cpr).astype(np.float64)
    ok = np.ones(n, bool)
    ok[30_000:30_050] = False
    found = health_events.counter_health(raw, t, channel="enc", counts_per_rev=cpr, valid=ok)
    monkeypatch.setattr(health_events, "_BLOCK", 1 << 20)  # one block: the whole record
    assert health_events.counter_health(raw, t, channel="enc", counts_per_rev=cpr,
                                        valid=ok) == found
    departure, threshold = _whole_record_threshold(raw, ok, cpr)
    odd = np.flatnonzero(np.abs(departure) > threshold)
    listed = sorted(i for f in found for i in f.indices)
    assert listed and set(listed) <= set((odd + 1).tolist())
    jump = next(f for f in found if f.fault == "count jump")
    assert jump.indices[0] == 20_000 and jump.value == round(departure[19_999])
    glitch = next(f for f in found if f.fault == "count glitch")
    assert glitch.indices[0] == 4_999 and glitch.value == round(departure[4_998])


def test_counter_health_same_through_wraps_and_reloads(monkeypatch: pytest.MonkeyPatch) -> None:
    """A 32-bit wrap or an index reload changes no finding; the turns are the truth's."""
    monkeypatch.setattr(health_events, "_BLOCK", 4_099)  # steps worked block by block
    fs, n, cpr = 2000.0, 40_001, 8192
    t = np.arange(n) / fs
    counts = np.floor(cpr * t * (1 + 0.05 * np.sin(t))).astype(np.int64)
    counts[12_345:] += 40  # a jump in the fourth turn
    counts[30_000] -= 25  # a glitch
    ok = np.ones(n, bool)
    ok[25_000:25_020] = False
    plain = health_events.counter_health(counts, t, channel="enc", counts_per_rev=cpr, valid=ok)
    wrapped = (counts + (1 << 32) - 50_000) % (1 << 32)  # wraps at about 6 turns, as uint32
    reloaded = counts % cpr
    for raw in (wrapped.astype(np.uint32), wrapped.astype(np.uint32).view(np.int32),
                reloaded.astype(np.int32), reloaded.astype(np.float64)):
        assert health_events.counter_health(raw, t, channel="enc", counts_per_rev=cpr,
                                            valid=ok) == plain
    jump = next(f for f in plain if f.fault == "count jump")
    assert jump.indices == (12_345,) and jump.value == 40
    assert jump.revolutions == ((counts[12_345] - counts[0]) // cpr,)
    glitch = next(f for f in plain if f.fault == "count glitch")
    assert glitch.indices == (30_000,) and glitch.value == -25
    assert glitch.revolutions == ((counts[30_000] - counts[0]) // cpr,)


def test_counter_steps_by_pieces_equal_the_cumulative_counts_steps() -> None:
    cpr = 1000
    truth = np.floor(np.linspace(0, 25.3 * cpr, 30_001)).astype(np.int64)
    raw = ((truth % cpr) + (1 << 32) - 500) % (1 << 32)  # reloads, each turn across 2**32
    whole, _ = remove_index_resets(unwrap_counts(raw.astype(np.uint32)), cpr)
    pieces = [encoder.counter_steps(raw[lo:lo + 998].astype(np.uint32), cpr)
              for lo in range(0, raw.size - 1, 997)]
    np.testing.assert_array_equal(np.concatenate(pieces), np.diff(whole))
    np.testing.assert_array_equal(np.concatenate(pieces), np.diff(truth))
