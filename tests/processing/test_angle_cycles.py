"""Angle-domain resampling, gaps, anti-aliasing and cycle statistics against closed forms."""

from __future__ import annotations

import numpy as np
import pytest

from rigval.acquisition.errors import DataError
from rigval.processing import angle, cycles

# the shaft of `rigval bench --stage resampling`: 1 rev/s with +-8 % speed ripple, exact inverse
from rigval.sample_data.synthetic_signals import ripple_angle, ripple_time

FS = 5000.0  # Hz, the rate of `rigval bench --stage resampling`


@pytest.mark.parametrize(("f_rel", "order", "limit"), [(0.05, 5, 1e-5), (0.01, 5, 1e-9),
                                                       (0.05, 3, 2e-4), (0.1, 5, 1e-3)])
def test_resampling_error_for_content_up_to_a_twentieth_of_fs(f_rel: float, order: int,
                                                             limit: float) -> None:
    t = np.arange(0.0, 6.0, 1 / FS)
    f = f_rel * FS
    x = np.sin(2 * np.pi * f * t + 0.3)
    cyc, _, y = angle.resample_to_angle(t, x, t, ripple_angle(t), points_per_rev=8192, fs=FS,
                                        order=order)
    grid = 2 * np.pi * (cyc[:, None] + np.arange(8192)[None, :] / 8192)
    truth = np.sin(2 * np.pi * f * ripple_time(grid) + 0.3)  # the first cycle starts at t=0
    assert np.nanmax(np.abs(y - truth)) < limit
    assert np.isfinite(y).all()


def test_linear_interpolation_is_far_worse_at_a_twentieth_of_fs() -> None:
    t = np.arange(0.0, 4.0, 1 / FS)
    x = np.sin(2 * np.pi * 250 * t)
    cyc, _, y = angle.resample_to_angle(t, x, t, ripple_angle(t), points_per_rev=8192, fs=FS,
                                        order=1)
    grid = 2 * np.pi * (cyc[:, None] + np.arange(8192)[None, :] / 8192)
    assert np.max(np.abs(y - np.sin(2 * np.pi * 250 * ripple_time(grid)))) > 1e-3


def test_anti_alias_removes_content_above_the_angle_grid_nyquist() -> None:
    t = np.arange(0.0, 8.0, 1 / FS)
    low = np.sin(2 * np.pi * 5 * t)
    x = low + 0.5 * np.sin(2 * np.pi * 300 * t)                # 300 Hz > 180 orders / 2 at 1 rev/s
    cyc, _, clean = angle.resample_to_angle(t, x, t, ripple_angle(t), points_per_rev=360, fs=FS)
    _, _, raw = angle.resample_to_angle(t, x, t, ripple_angle(t), points_per_rev=360, fs=FS,
                                        anti_alias="none")
    grid = 2 * np.pi * (cyc[:, None] + np.arange(360)[None, :] / 360)
    truth = np.sin(2 * np.pi * 5 * ripple_time(grid))
    inner = slice(1, -1)                                           # filter edges: first/last cycle
    assert np.max(np.abs(clean[inner] - truth[inner])) < 1e-3
    assert np.max(np.abs(raw[inner] - truth[inner])) > 0.3


def test_interpolation_never_crosses_a_gap_and_chunks_change_nothing(monkeypatch) -> None:
    t = np.concatenate([np.arange(0, 1, 1e-3), np.arange(1.5, 2.5, 1e-3)])
    segment = (t > 1.2).astype(int)
    x = np.where(segment == 0, 1.0, 5.0)
    at = np.array([0.5, 0.999, 1.0005, 1.2, 1.5, 1.5004, 2.4985])
    y = angle.interpolate_runs(t, x, at, segment=segment)
    np.testing.assert_allclose(y, [1, 1, np.nan, np.nan, 5, 5, 5], rtol=0, atol=1e-12)
    rng = np.random.default_rng(2)
    long_t = np.arange(0, 20, 1e-3)
    signal = np.cumsum(rng.standard_normal(long_t.size))
    where = rng.uniform(0, 19.999, 5000)
    one_shot = angle.interpolate_runs(long_t, signal, where)
    monkeypatch.setattr(angle, "_CHUNK", 997)
    np.testing.assert_allclose(angle.interpolate_runs(long_t, signal, where), one_shot,
                               rtol=0, atol=1e-9 * np.abs(signal).max())


def test_zero_at_reference_and_cycle_grid() -> None:
    t = np.arange(0, 10, 1e-3)
    phi = ripple_angle(t) + 0.7
    events = ripple_time(2 * np.pi * np.arange(1, 9))
    offset, scatter = angle.zero_at_reference(t, phi, events)
    assert offset == pytest.approx(0.7, abs=1e-6)
    assert scatter < 1e-6
    cyc, grid = angle.cycle_grid(0.1, 4 * np.pi + 0.2, 4)
    np.testing.assert_array_equal(cyc, [1])
    np.testing.assert_allclose(grid, [[2 * np.pi, 2.5 * np.pi, 3 * np.pi, 3.5 * np.pi]])
    with pytest.raises(DataError):
        angle.resample_to_angle(t, t, t, -phi, points_per_rev=8, fs=1000.0)


def test_cycle_statistics_match_numpy_and_find_the_outlier() -> None:
    rng = np.random.default_rng(3)
    base = np.sin(np.linspace(0, 2 * np.pi, 64, endpoint=False))
    y = base + 0.01 * rng.standard_normal((40, 64))
    y[17] += 0.5
    y[3, 10] = np.nan
    stats = cycles.statistics_array(y)
    np.testing.assert_allclose(stats[0], np.nanmean(y, axis=0))
    np.testing.assert_allclose(stats[1], np.nanstd(y, axis=0, ddof=1))
    np.testing.assert_allclose(stats[2:4], np.nanpercentile(y, [5, 95], axis=0))
    assert stats[6, 10] == 39 and stats[6, 0] == 40
    flags = cycles.outlier_cycles(y)
    assert np.flatnonzero(flags).tolist() == [17]


def test_a_gap_in_the_angle_record_leaves_its_grid_points_empty() -> None:
    t = np.arange(0.0, 6.0, 1 / FS)
    keep = (t < 2.3) | (t > 2.6)                                   # the reference has a gap
    x = np.sin(2 * np.pi * 3 * t)
    cyc, _, y = angle.resample_to_angle(t, x, t[keep], ripple_angle(t[keep]),
                                        points_per_rev=360, fs=FS)
    grid = 2 * np.pi * (cyc[:, None] + np.arange(360)[None, :] / 360)
    in_gap = (ripple_time(grid) > 2.3 + 1 / FS) & (ripple_time(grid) < 2.6 - 1 / FS)
    assert np.isnan(y[in_gap]).all()
    truth = np.sin(2 * np.pi * 3 * ripple_time(grid))
    assert np.nanmax(np.abs(y - truth)) < 1e-6


def test_cycle_statistics_dataset_excludes_invalid_and_outlier_cycles() -> None:
    import xarray as xr

    rng = np.random.default_rng(8)
    values = np.sin(np.linspace(0, 2 * np.pi, 32, endpoint=False)) + 0.01 * rng.standard_normal(
        (30, 32))
    values[4] += 1.0                                              # an outlier cycle
    valid = np.ones(30, dtype=bool)
    valid[7] = False
    data = xr.Dataset({"tor1_torque": (("cycle", "angle"), values, {"units": "N m"}),
                       "cycle_valid": ("cycle", valid)},
                      coords={"cycle": np.arange(30), "angle": np.linspace(0, 2 * np.pi, 32,
                                                                           endpoint=False)})
    kept = cycles.cycle_statistics(data)
    cleaned = cycles.cycle_statistics(data, exclude_outliers=True)
    assert kept["tor1_torque"].attrs["cycles_used"] == 29
    assert cleaned["tor1_torque"].attrs["cycles_used"] == 28
    assert kept["tor1_torque_outlier"].to_numpy().nonzero()[0].tolist() == [4]
    expected = values[np.delete(np.arange(30), [4, 7])].mean(axis=0)
    np.testing.assert_allclose(cleaned["tor1_torque"].sel(statistic="mean"), expected)
    assert cleaned["tor1_torque"].sel(statistic="n").to_numpy().tolist() == [28] * 32
    assert cleaned["tor1_torque"].attrs["units"] == "N m"


@pytest.mark.parametrize("order", [1, 3, 5])
def test_uniform_spline_path_equals_the_not_a_knot_spline(monkeypatch, order: int) -> None:
    # clock-mapped times (offset, drift) with a gap, an invalid stretch and short runs:
    # the cardinal B-spline of uniform samples against make_interp_spline alone
    rng = np.random.default_rng(5)
    t = 1234.5 + np.arange(0, 80 * 2000) / 2000 * (1 + 3e-6)
    x = np.sin(2 * np.pi * 7 * t) + 0.3 * np.sin(2 * np.pi * 150 * t) + 0.01 * rng.standard_normal(
        t.size)
    segment = (t > 1260).astype(int)
    valid = np.ones(t.size, dtype=bool)
    valid[50_000:50_010] = False
    valid[90_000:90_100] = False                             # leaves a run of 100 samples
    valid[90_200:90_300] = False
    at = np.concatenate([rng.uniform(t[0] - 1, t[-1] + 1, 60_000), t[::97], t[89_990:90_310]])
    monkeypatch.setattr(angle, "_CHUNK", 20_000)
    fast = angle.interpolate_runs(t, x, at, order=order, segment=segment, valid=valid)
    monkeypatch.setattr(angle, "_UNIFORM_TOLERANCE", -1.0)   # every chunk: make_interp_spline
    spline = angle.interpolate_runs(t, x, at, order=order, segment=segment, valid=valid)
    np.testing.assert_array_equal(np.isnan(fast), np.isnan(spline))
    assert np.isfinite(fast).sum() > 60_000
    np.testing.assert_allclose(fast, spline, rtol=0, atol=1e-9)


@pytest.mark.parametrize("order", [1, 3, 5])
def test_input_delay_taken_off_chunk_by_chunk_equals_the_shifted_times(monkeypatch,
                                                                        order: int) -> None:
    # a channel with a gap, NaN and invalid samples and a module delay of 8 ms: the delay
    # handed over (no copy of the times) gives the resampling of the shifted times, to the bit
    rng = np.random.default_rng(11)
    t = 0.25 + np.arange(0, 12 * 2000) / 2000 * (1 + 2e-6)
    t[15_000:] += 0.5                                        # a gap of half a second
    segment = (np.arange(t.size) >= 15_000).astype(np.int32)
    x = np.sin(2 * np.pi * 3 * t) + 0.01 * rng.standard_normal(t.size)
    x[4_000:4_003] = np.nan
    valid = np.ones(t.size, dtype=bool)
    valid[9_000:9_050] = False
    delay = 8.0e-3
    grid = angle.angle_grid(t, 2 * np.pi * (t - 0.25) * 1.1, 90)
    monkeypatch.setattr(angle, "_CHUNK", 3_000)
    shifted = angle.resample_to_angle(t - delay, x, None, None, points_per_rev=90, fs=2000.0,
                                      order=order, anti_alias="none", segment=segment,
                                      valid=valid, grid=grid)[2]
    delayed = angle.resample_to_angle(t, x, None, None, points_per_rev=90, fs=2000.0,
                                      order=order, anti_alias="none", segment=segment,
                                      valid=valid, grid=grid, delay_s=delay)[2]
    assert np.isnan(shifted).any() and np.isfinite(shifted).sum() > 500
    np.testing.assert_array_equal(delayed, shifted)          # NaN where NaN, else bit for bit
    assert delayed.tobytes() == shifted.tobytes()
