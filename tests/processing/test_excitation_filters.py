"""Drive-angle derivatives, zero-phase filters and encoder decoding against known truth."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.signal import sosfiltfilt

from rigval.acquisition.errors import DataWarning
from rigval.processing import encoder, excitation, filters

FS = 5000.0
CPR = 8192
W = 2 * np.pi * 1.0
HARMONICS = [(1, 0.05, 0.3), (2, 0.02, 1.1), (3, 0.01, 2.0), (4, 0.005, 0.7)]


def _drive(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    theta = W * t + sum(a * np.sin(k * W * t + p) for k, a, p in HARMONICS)
    omega = W + sum(a * k * W * np.cos(k * W * t + p) for k, a, p in HARMONICS)
    alpha = -sum(a * (k * W) ** 2 * np.sin(k * W * t + p) for k, a, p in HARMONICS)
    return theta, omega, alpha


@pytest.fixture(scope="module")
def quantised_drive() -> dict[str, np.ndarray]:
    t = np.arange(0.0, 20.0, 1 / FS)
    theta, omega, alpha = _drive(t)
    counts = np.floor(theta / (2 * np.pi) * CPR).astype(np.int64)
    return {"t": t, "raw": encoder.counts_to_angle(counts, CPR), "omega": omega, "alpha": alpha}


@pytest.mark.parametrize("method", ["butterworth", "fourier"])
def test_second_derivative_within_a_hundredth_rad_per_s2(quantised_drive, method: str) -> None:
    """Done-when: 8192 counts/rev, 5 kHz, 1 rev/s."""
    d = quantised_drive
    result = excitation.drive_angle(d["t"], d["raw"], fs=FS, step_rad=2 * np.pi / CPR,
                                    method=method)
    error = result.acceleration - d["alpha"]
    inner = (d["t"] > 0.25) & (d["t"] < 19.75)
    assert np.sqrt(np.mean(error**2)) < 0.01
    assert np.max(np.abs(error[inner])) < 0.015
    assert np.sqrt(np.mean((result.velocity - d["omega"]) ** 2)) < 5e-4
    assert result.residual_rms == pytest.approx(2 * np.pi / CPR / np.sqrt(12), rel=0.1)


def test_differencing_raw_counts_is_useless(quantised_drive) -> None:
    d = quantised_drive
    raw_alpha = np.gradient(np.gradient(d["raw"], 1 / FS), 1 / FS)
    assert np.sqrt(np.mean((raw_alpha - d["alpha"]) ** 2)) > 100.0
    _, _, predicted = excitation.quantisation_noise(2 * np.pi / CPR, FS)
    assert predicted > 1000.0


def test_noise_estimate_is_conservative(quantised_drive) -> None:
    d = quantised_drive
    result = excitation.drive_angle(d["t"], d["raw"], fs=FS, step_rad=2 * np.pi / CPR)
    actual = np.sqrt(np.mean((result.acceleration - d["alpha"]) ** 2))
    assert actual < result.acceleration_noise < 5 * actual


def test_each_gap_free_run_is_processed_on_its_own() -> None:
    t = np.arange(0.0, 12.0, 1 / FS)
    theta, _, alpha = _drive(t)
    counts = np.floor(theta / (2 * np.pi) * CPR)
    segment = (t >= 6.0).astype(int)
    counts[segment == 1] += 123_457                    # a restart: the count jumps
    raw = encoder.counts_to_angle(counts, CPR)
    result = excitation.drive_angle(t, raw, fs=FS, step_rad=2 * np.pi / CPR, segment=segment)
    assert np.all(np.isfinite(result.acceleration))
    assert np.sqrt(np.mean((result.acceleration - alpha) ** 2)) < 0.02


def test_zero_phase_matches_scipy_in_one_run_and_in_chunks() -> None:
    rng = np.random.default_rng(4)
    x = np.cumsum(rng.standard_normal(50_000))
    sos = filters.butter_sos(20.0, FS)
    pad = filters.default_padlen(20.0, FS)
    reference = sosfiltfilt(sos, x, padlen=pad)
    np.testing.assert_allclose(filters.zero_phase(x, FS, 20.0), reference, rtol=0, atol=1e-9)
    chunked = filters.zero_phase(x, FS, 20.0, chunk_samples=7000)
    np.testing.assert_allclose(chunked, reference, rtol=0, atol=1e-9 * np.abs(x).max())


def test_zero_phase_long_padding_keeps_a_ramp_exact_at_the_edges() -> None:
    t = np.arange(0, 2, 1 / FS)
    ramp = 0.3 + 2.0 * t                                          # span 4
    y = filters.zero_phase(ramp, FS, 20.0)
    assert np.max(np.abs(y - ramp)) < 4e-8
    short = sosfiltfilt(filters.butter_sos(20.0, FS), ramp)       # scipy's default padding
    assert np.max(np.abs(short - ramp)) > 1e-2


def test_zero_phase_never_crosses_a_gap_or_invalid_sample() -> None:
    x = np.concatenate([np.full(3000, 1.0), np.full(3000, 7.0)])
    segment = np.repeat([0, 1], 3000)
    y = filters.zero_phase(x, FS, 50.0, segment=segment)
    np.testing.assert_allclose(y, x, rtol=0, atol=1e-12)
    valid = np.ones(x.size, dtype=bool)
    valid[10:15] = False                                  # leaves a 10-sample run in front
    with pytest.warns(DataWarning, match="too short"):
        z = filters.zero_phase(x, FS, 50.0, segment=segment, valid=valid)
    assert np.isnan(z[:15]).all() and np.isfinite(z[15:]).all()


def test_counter_wrap_and_quadrature_decoding() -> None:
    raw = (np.array([2**32 - 3, 2**32 - 1, 1, 4, 2]) % 2**32).astype(np.uint32)
    np.testing.assert_array_equal(encoder.unwrap_counts(raw), [2**32 - 3, 2**32 - 1, 2**32 + 1,
                                                               2**32 + 4, 2**32 + 2])
    position = np.concatenate([np.arange(0, 40), np.arange(40, 20, -1)])   # quarter steps
    state = np.array([0, 2, 3, 1])[position % 4]
    a, b = state >> 1, state & 1
    for decoding, per_cycle in (("x4", 4), ("x2", 2), ("x1", 1)):
        counts, illegal = encoder.decode_quadrature(a, b, decoding)
        assert not illegal.any()
        assert counts[39] == pytest.approx(39 * per_cycle / 4, abs=1)
        assert counts[-1] == pytest.approx(21 * per_cycle / 4, abs=1)
    skipped = np.delete(state, 10)                                       # a missed state
    _, illegal = encoder.decode_quadrature(skipped >> 1, skipped & 1)
    assert np.flatnonzero(illegal).tolist() == [10]


def test_revolution_check_flags_glitches_and_gross_errors() -> None:
    t = np.arange(0.0, 10.0, 1 / FS)
    counts = np.floor(t * CPR).astype(np.int64)
    counts[t > 3.5] += 2                      # two spurious counts in revolution 3
    counts[t > 6.5] -= 600                    # a large loss in revolution 6
    check = encoder.revolution_check(t, counts, np.arange(1.0, 10.0), CPR)
    assert np.flatnonzero(check.glitch).tolist() == [2]
    assert np.flatnonzero(check.gross).tolist() == [5]


def test_index_reloads_are_undone_and_located() -> None:
    t = np.arange(0.0, 5.0, 1 / FS)
    cumulative = np.floor(t * 1.3 * CPR).astype(np.int64) + 100
    reloaded = (cumulative - 100) % CPR                      # Z reloads 0 at every index
    restored, resets = encoder.remove_index_resets(reloaded, CPR)
    np.testing.assert_array_equal(restored - restored[0], cumulative - cumulative[0])
    expected = np.flatnonzero(np.diff((cumulative - 100) // CPR)) + 1
    np.testing.assert_array_equal(resets, expected)


def test_pieces_and_sampling_at_times_equal_the_whole_record(monkeypatch) -> None:
    # A run smoothed in pieces equals one piece to rounding; drive_excitation_at equals the
    # whole-record excitation interpolated at the times (clamped ends, gaps bridged linearly).
    import xarray as xr
    t = 100.0 + np.arange(0.0, 60.0, 1 / FS)
    theta = _drive(t)[0]
    counts = np.floor(theta / (2 * np.pi) * CPR)
    segment = (t > 130.0).astype(np.int32)
    valid = np.ones(t.size, dtype=bool)
    valid[10_000:10_030] = False
    valid[200_000:200_040] = False                                # a short run between two gaps
    valid[200_060:200_100] = False
    ds = xr.Dataset({"enc": ("time", counts, {"input_delay_s": 3e-4}),
                     "segment": ("time", segment), "valid": ("time", valid)},
                    coords={"time": t}, attrs={"fs_nominal": FS})
    whole = excitation.drive_excitation(ds, "enc", counts_per_rev=CPR)
    monkeypatch.setattr(excitation, "_PIECE", 37_000)
    pieces = excitation.drive_excitation(ds, "enc", counts_per_rev=CPR)
    for name in ("theta", "theta_dot", "theta_ddot"):
        a, b = pieces[name].to_numpy(), whole[name].to_numpy()
        np.testing.assert_array_equal(np.isnan(a), np.isnan(b))
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-9 * np.nanmax(np.abs(b)), err_msg=name)
    rng = np.random.default_rng(3)
    at = np.concatenate([[50.0, 99.0, 100.0, 100.0003, 170.0], rng.uniform(100, 160, 20_000),
                         t[199_990:200_110] - 3e-4]).reshape(-1, 25)
    sampled = excitation.drive_excitation_at(ds, "enc", at, counts_per_rev=CPR)
    at_sample = t - 3e-4
    for name, got in zip(("theta", "theta_dot", "theta_ddot"), sampled, strict=True):
        values = whole[name].to_numpy()
        ok = np.isfinite(values)
        expected = np.interp(at, at_sample[ok], values[ok])
        assert got.shape == at.shape
        np.testing.assert_allclose(got, expected, rtol=0,
                                   atol=1e-9 * np.abs(expected).max(), err_msg=name)
    # and the truth: the smoothed acceleration within 0.01 rad/s^2 away from the run ends
    inner = (at > 103.0) & (at < 129.0)                          # a second from run ends
    assert np.max(np.abs(sampled[2][inner] - _drive(at[inner] + 3e-4)[2])) < 0.01


def test_grid_times_in_order_sampled_without_the_sort_equal_the_sorted_path(monkeypatch
                                                                            ) -> None:
    # a phi_F grid's times come row after row in time order: taken as they are, the samples
    # equal those through the stable sort's index, bit for bit
    import xarray as xr
    t = np.arange(0.0, 30.0, 1 / FS)
    counts = np.floor(_drive(t)[0] / (2 * np.pi) * CPR)
    valid = np.ones(t.size, dtype=bool)
    valid[70_000:70_050] = False                                  # a gap to bridge
    ds = xr.Dataset({"enc": ("time", counts), "segment": ("time", np.zeros(t.size, np.int32)),
                     "valid": ("time", valid)}, coords={"time": t}, attrs={"fs_nominal": FS})
    grid = np.linspace(-1.0, 31.0, 40 * 360).reshape(40, 360)     # ends clamped
    grid[5, 7] = grid[5, 6]                                       # equal times keep their order
    in_order = excitation.drive_excitation_at(ds, "enc", grid, counts_per_rev=CPR)

    def sorted_always(flat):
        index = np.argsort(flat, kind="stable")
        return flat[index], lambda a, b: index[a:b]

    monkeypatch.setattr(excitation, "_in_time_order", sorted_always)
    through_sort = excitation.drive_excitation_at(ds, "enc", grid, counts_per_rev=CPR)
    for got, expected in zip(in_order, through_sort, strict=True):
        assert np.array_equal(got, expected) and np.isfinite(got).all()


@pytest.mark.parametrize("chunk_samples", [1 << 20, 7000, 500])  # 500: shorter than the overlap
def test_zero_phase_into_its_input_equals_a_new_output(chunk_samples: int) -> None:
    # a channel with a segment change, invalid samples, a NaN and a run too short to filter:
    # written into the input, piece by piece, the output equals the one of a new array to the bit
    rng = np.random.default_rng(9)
    x = np.cumsum(rng.standard_normal(60_000))
    x[20_000] = np.nan
    segment = (np.arange(x.size) >= 41_000).astype(np.int32)
    valid = np.ones(x.size, dtype=bool)
    valid[:30] = False
    valid[30_000:30_200] = False
    valid[30_210:30_300] = False                          # leaves a 10-sample run
    with pytest.warns(DataWarning, match="too short"):
        expected = filters.zero_phase(x, FS, 20.0, segment=segment, valid=valid,
                                      chunk_samples=chunk_samples)
    own = x.copy()
    with pytest.warns(DataWarning, match="too short"):
        result = filters.zero_phase(own, FS, 20.0, segment=segment, valid=valid,
                                    chunk_samples=chunk_samples, overwrite=True)
    assert result is own
    assert np.isnan(expected[30_200:30_300]).all() and np.isfinite(expected[30:20_000]).all()
    assert result.tobytes() == expected.tobytes()


@pytest.mark.parametrize("block", [1, 7, 1000, 1 << 20])
def test_contiguous_runs_by_blocks_equal_the_whole_record_comparison(monkeypatch,
                                                                     block: int) -> None:
    # neighbours compared a block at a time: the runs of the whole record's comparison
    rng = np.random.default_rng(3)
    n = 5003
    valid = rng.random(n) > 0.02
    segment = np.cumsum(rng.random(n) > 0.999).astype(np.int32)

    def whole(valid, segment):
        ok = np.ones(n, dtype=bool) if valid is None else valid
        change = ok[1:] != ok[:-1]
        if segment is not None:
            change |= segment[1:] != segment[:-1]
        bounds = np.concatenate(([0], np.flatnonzero(change) + 1, [n])).tolist()
        return [(a, b) for a, b in itertools.pairwise(bounds) if b > a and ok[a]]

    monkeypatch.setattr(filters, "_RUN_BLOCK", block)
    for v, s in ((valid, segment), (valid, None), (None, segment), (None, None)):
        runs = filters.contiguous_runs(n, s, v)
        assert runs == whole(v, s)
        assert len(runs) > 1 or (v is None and s is None)
    assert filters.contiguous_runs(1, None, np.array([True])) == [(0, 1)]
    assert filters.contiguous_runs(0) == []
