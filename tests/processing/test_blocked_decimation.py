"""Blocked decimation against scipy's decimation of the whole stretch (bit for bit)."""

from __future__ import annotations

import functools

import numpy as np
import pytest
from scipy.signal import decimate

from rigval.processing import stretch_decimation
from rigval.processing.blocked_decimation import EDGE, decimate_stretch, line_values
from rigval.processing.stretch_decimation import diagnosis_signal


def _whole(x: np.ndarray, q: int) -> np.ndarray:
    """The stretch decimated at once, as the pipeline did before blocks."""
    line = np.linspace(x[0], x[-1], x.size)
    return (decimate(x - line, q, ftype="fir", zero_phase=True) + line[::q])[EDGE:-EDGE]


@pytest.mark.parametrize("n", [2, 3, 1000, 12_345])
def test_line_values_equal_linspace(n: int) -> None:
    rng = np.random.default_rng(n)
    first, last = rng.normal(size=2)
    index = np.arange(n)
    np.testing.assert_array_equal(line_values(first, last, n, index),
                                  np.linspace(first, last, n))
    np.testing.assert_array_equal(line_values(1.5, 1.5, n, index), np.linspace(1.5, 1.5, n))


@pytest.mark.parametrize(("q", "n", "block"), [(2, 5_000, 300), (10, 70_001, 4_096),
                                               (31, 64 * 31 + 7, 31), (31, 200_003, 10_000),
                                               (3, 40_000, 1 << 20)])
def test_blocks_equal_whole_stretch(q: int, n: int, block: int) -> None:
    rng = np.random.default_rng(q + n)
    x = np.cumsum(rng.normal(size=n)) + 5.0 * np.sin(np.arange(n) / 50.0)
    y, taken = decimate_stretch(x, q, block=block)
    np.testing.assert_array_equal(y, _whole(x, q))
    np.testing.assert_array_equal(taken, np.arange(x.size)[::q][EDGE:EDGE + y.size])


def _whole_record_signal(time: np.ndarray, values: np.ndarray, segment: np.ndarray,
                         valid: np.ndarray, fs: float, q: int) -> tuple[np.ndarray, ...]:
    """The diagnosis signal computed on whole-record arrays (stretch numbers by cumsum)."""
    usable = valid & np.isfinite(values)
    step = np.concatenate([[False], (np.diff(segment) != 0) | ~usable[1:] | ~usable[:-1]])
    stretch = np.cumsum(step)
    where = np.flatnonzero(usable)
    out, runs, at = [], [], []
    for k in np.unique(stretch[where]):
        mine = where[stretch[where] == k]
        if mine.size < 64 * q:
            continue
        y = _whole(values[mine], q)
        out.append(y)
        runs.append(np.full(y.size, k))
        at.append(mine[::q][EDGE:EDGE + y.size])
    return np.concatenate(out), np.concatenate(runs), time[np.concatenate(at)]


@pytest.mark.parametrize("small_blocks", [False, True])
def test_diagnosis_signal_equals_whole_record(small_blocks: bool,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    if small_blocks:  # stretches and stretch counts cross many block boundaries
        monkeypatch.setattr(stretch_decimation, "_COUNT_BLOCK", 7_777)
        monkeypatch.setattr(stretch_decimation, "decimate_stretch",
                            functools.partial(decimate_stretch, block=5_000))
    fs, n = 5000.0, 300_000
    rng = np.random.default_rng(7)
    time = np.arange(n) / fs
    values = np.sin(2 * np.pi * 3.0 * time) + 0.01 * rng.normal(size=n)
    segment = np.zeros(n, np.int32)
    segment[170_000:] = 1  # a gap
    valid = np.ones(n, bool)
    valid[50_000:50_010] = False  # an invalid stretch
    values[90_000] = np.nan
    values[120_000:120_500] = np.nan  # too short a stretch between two NaN runs
    values[120_800:121_000] = np.nan
    q = int(fs // 160.0)
    signal = diagnosis_signal(time, values, segment, valid, fs, delay_s=0.002)
    measured, stretch, at = _whole_record_signal(time, values, segment, valid, fs, q)
    np.testing.assert_array_equal(signal["measured"].to_numpy(), measured)
    np.testing.assert_array_equal(signal["stretch"].to_numpy(), stretch.astype(np.int32))
    np.testing.assert_array_equal(signal["time"].to_numpy(), at - 0.002)
    assert signal.attrs["fs"] == fs / q
