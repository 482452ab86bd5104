"""Measured drives averaged as they are smoothed, a block of revolutions at a time (memory).

The block-wise path hands on whole grid rows as the encoder's pieces are smoothed; its rows
and means must equal the whole grid's (:func:`drive_excitation_at`, then ``numpy.mean``) bit
for bit, on a record with gaps, a segment change, a run too short to smooth and revolutions of
uneven length, its grid running off both ends of the record.
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from rigval.processing import excitation
from rigval.processing.row_mean import RowMean

FS = 1000.0
CPR = 8192
N_ANGLE = 36


def _angle(t: np.ndarray) -> np.ndarray:
    """A drive speeding up from 1 to 1.3 rev/s, with harmonics: revolutions of uneven length."""
    return 2 * np.pi * (t + 0.005 * t**2) + 0.05 * np.sin(2 * np.pi * t + 0.3) \
        + 0.02 * np.sin(4 * np.pi * t + 1.1)


def _record() -> xr.Dataset:
    t = 50.0 + np.arange(0.0, 60.0, 1 / FS)
    counts = np.floor(-_angle(t - 50.0) / (2 * np.pi) * CPR)          # counting down
    valid = np.ones(t.size, dtype=bool)
    valid[12_000:12_030] = False                                      # a short gap, bridged
    valid[30_000:30_800] = False                                      # a run too short ...
    valid[30_820:31_900] = False                                      # ... between two gaps
    segment = (t > 90.0).astype(np.int32)                             # a dropout restart
    return xr.Dataset({"enc": ("time", counts, {"input_delay_s": 4e-4}),
                       "segment": ("time", segment), "valid": ("time", valid)},
                      coords={"time": t}, attrs={"fs_nominal": FS})


def _grid() -> np.ndarray:
    """Reference times of a uniform grid of the drive's angle, a row per revolution, s.

    It starts a revolution before the record and ends after it (values clamped there).
    """
    fine = np.arange(-2.0, 62.0, 1e-3)
    angles = 2 * np.pi * (np.arange(-1, 75)[:, None] + np.arange(N_ANGLE)[None, :] / N_ANGLE)
    return 50.0 + np.interp(angles, _angle(fine), fine)


def _whole_mean(ds: xr.Dataset, times: np.ndarray, angle_at_reference: float):
    """The mean cycle from the whole grid's samples, as before the block-wise path."""
    theta, omega, alpha = excitation.drive_excitation_at(ds, "enc", times, counts_per_rev=CPR,
                                                         direction=-1.0)
    theta = theta - theta[0, 0] + angle_at_reference
    theta -= 2.0 * np.pi * np.round((theta[:, :1] - theta[0, 0]) / (2.0 * np.pi))
    return theta.mean(axis=0), omega.mean(axis=0), alpha.mean(axis=0)


def _same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and np.array_equal(a.view(np.uint64), b.view(np.uint64))


@pytest.fixture()
def small_pieces(monkeypatch) -> None:
    """Pieces of 7000 samples: each run is smoothed in many, rows handed on in many blocks."""
    monkeypatch.setattr(excitation, "_PIECE", 7_000)


def _sample_grid() -> np.ndarray:
    """A grid of every sample's time, a row a second: times at every piece's ends too."""
    ds = _record()
    return (ds["time"].to_numpy() - ds["enc"].attrs["input_delay_s"]).reshape(60, 1000)


@pytest.mark.usefixtures("small_pieces")
@pytest.mark.parametrize("grid", [_grid, _sample_grid])
def test_rows_handed_on_in_blocks_equal_the_whole_grid_samples(grid) -> None:
    ds, times = _record(), grid()
    whole = np.array(excitation.drive_excitation_at(ds, "enc", times, counts_per_rev=CPR,
                                                    direction=-1.0))
    assert excitation._streamable(ds, times)
    blocks = list(excitation._drive_rows(ds, "enc", times, counts_per_rev=CPR, direction=-1.0,
                                         index_reset=False))
    assert len(blocks) > 5 and max(block.shape[1] for block in blocks) < times.shape[0] / 3
    assert _same_bits(np.concatenate(blocks, axis=1), whole)
    # the grid's times in the skipped short run and before and after the record are bridged
    # and clamped, not left NaN
    assert np.isfinite(whole).all()


@pytest.mark.usefixtures("small_pieces")
def test_mean_cycle_averaged_block_wise_equals_the_whole_grid_mean(monkeypatch) -> None:
    ds, times = _record(), _grid()
    expected = _whole_mean(ds, times, angle_at_reference=0.7)

    def whole_grid(*args, **kwargs):
        raise AssertionError("the grid was sampled whole")

    monkeypatch.setattr(excitation, "drive_excitation_at", whole_grid)
    got = excitation.mean_drive_cycle(ds, "enc", times, counts_per_rev=CPR, direction=-1.0,
                                      angle_at_reference=0.7)
    for name, a, b in zip(("theta", "omega", "alpha"), got, expected, strict=True):
        assert _same_bits(a, b), name


def test_a_grid_out_of_time_order_is_averaged_whole_to_the_same_mean() -> None:
    ds, times = _record(), _grid()[::-1]            # revolutions last to first
    assert not excitation._streamable(ds, times)
    got = excitation.mean_drive_cycle(ds, "enc", times, counts_per_rev=CPR, direction=-1.0)
    for a, b in zip(got, _whole_mean(ds, times, 0.0), strict=True):
        assert _same_bits(a, b)


@pytest.mark.parametrize("shape", [(2, 2), (1, 5), (700, 3), (333, 1440)])
def test_row_mean_equals_numpy_mean_over_rows(shape) -> None:
    rng = np.random.default_rng(shape[0])
    table = rng.standard_normal(shape) * 10.0 ** rng.integers(-9, 9, shape)
    table[:, 0] = -0.0                              # numpy's sum starts from +0
    mean = RowMean(shape[1])
    for lo in range(0, shape[0], 64):
        mean.add(table[lo:lo + 64])
    assert _same_bits(mean.mean(), table.mean(axis=0))


def test_row_mean_refuses_one_column() -> None:
    with pytest.raises(ValueError, match="two columns"):
        RowMean(1)


@pytest.mark.usefixtures("small_pieces")
def test_times_left_nan_within_a_run_wait_for_its_end_as_in_the_whole_grid(monkeypatch
                                                                            ) -> None:
    # a piece whose smoothed values are not finite: its times take the values between the
    # run's first and last samples, which the block-wise path knows only at the run's end
    smooth = excitation._butterworth_pieces

    def with_nan_inside(*args, **kwargs):
        for lo, hi, *values in smooth(*args, **kwargs):
            for v in values:  # the run's end samples kept finite
                v[v.size // 4:v.size // 2] = np.nan
            yield lo, hi, *values

    monkeypatch.setattr(excitation, "_butterworth_pieces", with_nan_inside)
    ds, times = _record(), _grid()
    whole = np.array(excitation.drive_excitation_at(ds, "enc", times, counts_per_rev=CPR,
                                                    direction=-1.0))
    blocks = list(excitation._drive_rows(ds, "enc", times, counts_per_rev=CPR, direction=-1.0,
                                         index_reset=False))
    assert len(blocks) > 1  # rows wait for their run's end, not for the record's
    assert _same_bits(np.concatenate(blocks, axis=1), whole)


@pytest.mark.usefixtures("small_pieces")
def test_angle_without_derivatives_equals_the_angle_with_them() -> None:
    # phi_F takes the angle alone: the pieces then skip the differences, the angle the same
    ds = _record()
    kwargs = {"counts_per_rev": CPR, "direction": -1.0}
    both = excitation.drive_excitation(ds, "enc", **kwargs)
    alone = excitation.drive_excitation(ds, "enc", derivatives=False, **kwargs)
    assert set(alone.data_vars) == {"theta"}
    assert _same_bits(alone["theta"].to_numpy(), both["theta"].to_numpy())
    assert np.isfinite(both["theta_ddot"].to_numpy()).sum() > 50_000
