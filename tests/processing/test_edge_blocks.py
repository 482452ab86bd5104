"""Edges found a block at a time equal the whole-record Schmitt trigger they replaced.

:func:`rigval.processing.pulses.detect_edges` runs its trigger a block of samples at a time and
times falling edges without a negated copy of the record; :func:`_whole_record_edges` below is
the former whole-record formulation (a negated copy for falling edges, the trigger's state and
index arrays over each whole run). Blocks of 997 samples split pulses, their edges and the
noise around the thresholds; a gap and invalid samples split the runs.
"""

from __future__ import annotations

import numpy as np
import pytest

from rigval.processing import pulses
from rigval.processing.filters import contiguous_runs

FS = 2000.0


def _whole_record_edges(x: np.ndarray, t: np.ndarray, low: float, high: float, polarity: str,
                        segment: np.ndarray, valid: np.ndarray, refine: str) -> np.ndarray:
    data = np.asarray(x, dtype=np.float64)
    if polarity == "falling":
        data, low, high = -data, -high, -low
    mid = 0.5 * (low + high)
    times = []
    usable = valid & np.isfinite(data)
    for start, stop in contiguous_runs(data.size, segment, usable):
        seg = data[start:stop]
        state = np.zeros(seg.size, dtype=np.int8)
        state[seg <= low] = -1
        state[seg >= high] = 1
        marked = np.flatnonzero(state)
        if marked.size < 2:
            continue
        labels = state[marked]
        fires = marked[1:][(labels[1:] == 1) & (labels[:-1] == -1)]
        ups = np.flatnonzero((seg[:-1] < mid) & (seg[1:] >= mid))
        if fires.size == 0:
            continue
        j = ups[np.searchsorted(ups, fires) - 1]
        position = j + (mid - seg[j]) / (seg[j + 1] - seg[j])
        if refine == "sinc":
            refined = pulses._sinc_crossings(seg, j, mid)
            position = np.where(np.isnan(refined), position, refined)
        i = np.minimum(position.astype(np.int64), seg.size - 2)
        times.append(t[start + i] + (position - i) * (t[start + i + 1] - t[start + i]))
    return np.concatenate(times) if times else np.zeros(0)


def _pulse_channel(seed: int) -> tuple[np.ndarray, ...]:
    """Band-limited-looking pulses (a 3-sample ramp), noise that dithers about the thresholds."""
    rng = np.random.default_rng(seed)
    n = 40_000
    t = np.arange(n) / FS
    t[25_000:] += 0.3  # a gap
    phase = (np.arange(n) % 1000) / 1000.0
    x = np.clip((phase - 0.2) * 300.0, 0.0, 1.0) - np.clip((phase - 0.5) * 300.0, 0.0, 1.0)
    x = 5.0 * x + rng.normal(0.0, 0.05, n)
    x[rng.choice(n, 20, replace=False)] = 1.5  # single samples inside the band
    segment = (np.arange(n) >= 25_000).astype(np.int32)
    valid = np.ones(n, dtype=bool)
    valid[12_190:12_230] = False  # invalid across a rising edge
    return x, t, segment, valid


@pytest.mark.parametrize("polarity", ["rising", "falling"])
@pytest.mark.parametrize("refine", ["linear", "sinc"])
@pytest.mark.parametrize("seed", [1, 2])
def test_edges_by_blocks_equal_the_whole_record_trigger(polarity: str, refine: str, seed: int,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    x, t, segment, valid = _pulse_channel(seed)
    expected = _whole_record_edges(x, t, 1.5, 3.5, polarity, segment, valid, refine)
    assert expected.size >= 35  # 40 pulses, one lost to the invalid samples
    for chunk in (1 << 20, 997, 200):  # one block; blocks splitting pulses and their edges
        monkeypatch.setattr(pulses, "_LEVEL_CHUNK", chunk)
        found = pulses.detect_edges(x, t, low=1.5, high=3.5, polarity=polarity,
                                    segment=segment, valid=valid, refine=refine)
        assert np.array_equal(found, expected), chunk


def test_trigger_carries_its_armed_state_across_blocks(monkeypatch: pytest.MonkeyPatch) -> None:
    # armed in one block, passing through the band in the next, firing in the third
    run = np.concatenate((np.zeros(10), np.full(10, 2.5), np.full(10, 5.0)))
    monkeypatch.setattr(pulses, "_LEVEL_CHUNK", 10)
    fires, ups = pulses._trigger(run, 1.5, 3.5, 2.5, negate=False)
    assert fires.tolist() == [20] and ups.tolist() == [9]
    fires, _ = pulses._trigger(run[::-1].copy(), 1.5, 3.5, 2.5, negate=False)
    assert fires.size == 0  # never armed before the high samples
