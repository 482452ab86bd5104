"""The edge-shape fit's candidate grid against a direct evaluation of every (edge, time, sample).

:func:`rigval.processing.edge_shape._grid` evaluates each shape once per point of a lattice of
distances and reads the (sample, candidate) pairs through a strided view; here each pair's
model value is computed from the shape's closed form on its own distance, sample minus candidate
time, with the candidates placed off the lattice's centre (random guesses). The two differ only
by the rounding of the distances: 1e-12 of the largest misfit (about 1e-15 is seen).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.lib.stride_tricks import sliding_window_view
from scipy.special import erf, sici

from rigval.processing import edge_shape


def _direct(y: np.ndarray, times: np.ndarray, width: float, shape: str) -> np.ndarray:
    """Misfit per (edge, candidate): each sample's model value from its own distance."""
    misfit = np.zeros(times.shape)
    for e in range(times.shape[0]):
        for j in range(times.shape[1]):
            total = 0.0
            for k in range(y.shape[1]):
                u = (k - edge_shape._BEFORE) - times[e, j]
                if shape == "first-order":
                    value = 1.0 - math.exp(-max(u, 0.0) / width)
                elif shape == "band-limited":
                    value = 0.5 + float(sici(u / width)[0]) / math.pi
                else:
                    value = 0.5 * (1.0 + math.erf(u / (width * math.sqrt(2.0))))
                total += (y[e, k] - value) ** 2
            misfit[e, j] = total
    return misfit


@pytest.mark.parametrize("shape", ["first-order", "symmetric", "band-limited"])
@pytest.mark.parametrize("width", [0.01, 0.37, 3.9])
def test_grid_misfits_equal_the_pairwise_evaluation(shape, width):
    rng = np.random.default_rng(7)
    n_samples = edge_shape._BEFORE + edge_shape._AFTER + 1
    y = rng.uniform(-0.1, 1.1, (3, n_samples))
    guess = rng.uniform(-1.0, 1.0, 3)
    candidates, grid = edge_shape._grid(y, guess, width, shape)
    assert candidates.shape == grid.shape == (3, edge_shape._OFFSETS.size)
    centre = guess - (width * math.log(2.0) if shape == "first-order" else 0.0)
    np.testing.assert_allclose(candidates, centre[:, None] + edge_shape._OFFSETS[None, :],
                               rtol=0, atol=0)
    expected = _direct(y, candidates, width, shape)
    np.testing.assert_allclose(grid, expected, rtol=0, atol=1e-12 * expected.max())


def test_symmetric_shape_equals_the_full_error_function_to_the_bit():
    # the error function is evaluated only where it is not +-1: the values are those of the
    # full evaluation, on both sides of the saturation and across the widths scanned
    rng = np.random.default_rng(3)
    x = np.concatenate([rng.normal(0.0, 4.0, 200_000), rng.uniform(-1e4, 1e4, 20_000),
                        np.linspace(-7.0, 7.0, 100_001), [0.0, -0.0, 6.0, -6.0, np.inf, -np.inf]])
    full = 0.5 * (1.0 + erf(x))
    assert edge_shape._symmetric(x).tobytes() == full.tobytes()
    u = edge_shape._DISTANCES[None, :] - rng.uniform(-1.0, 1.0, 5)[:, None]
    for width in edge_shape._WIDTHS:
        expected = 0.5 * (1.0 + erf(u / (width * np.sqrt(2.0))))
        assert edge_shape._shape(u, width, "symmetric").tobytes() == expected.tobytes()


def test_error_function_is_one_beyond_the_saturation():
    x = np.concatenate([np.linspace(edge_shape._ERF_SATURATED, 40.0, 1_000_001),
                        np.geomspace(40.0, 1e300, 10_001)])
    assert np.all(erf(x) == 1.0)
    assert np.all(erf(-x) == -1.0)


@pytest.mark.parametrize("shape", ["first-order", "symmetric", "band-limited"])
def test_grid_reads_the_lattice_either_way_to_the_bit(shape):
    # the lattice decreasing, each sample's candidates read forward, gives the misfits of the
    # lattice increasing read backward
    rng = np.random.default_rng(5)
    y = rng.uniform(-0.1, 1.1, (7, edge_shape._BEFORE + edge_shape._AFTER + 1))
    guess = rng.uniform(-1.0, 1.0, 7)
    increasing = edge_shape._DISTANCES[::-1]
    for width in (0.013, 0.37, 3.9):
        centre = guess - (width * np.log(2.0) if shape == "first-order" else 0.0)
        model = edge_shape._shape(increasing[None, :] - centre[:, None], width, shape)
        pairs = sliding_window_view(model, edge_shape._OFFSETS.size, axis=1)[
            :, ::edge_shape._STEPS_PER_SAMPLE, ::-1]
        expected = ((y[:, :, None] - pairs) ** 2).sum(axis=1)
        assert edge_shape._grid(y, guess, width, shape)[1].tobytes() == expected.tobytes()


@pytest.mark.parametrize("shape", ["first-order", "symmetric", "band-limited"])
def test_grid_in_shared_work_arrays_equals_its_own_to_the_bit(shape):
    # one channel's evaluations share their lattice and residual arrays: edge counts that grow
    # and shrink, widths across the scan, and arrays left dirty by the last evaluation
    rng = np.random.default_rng(11)
    n_samples = edge_shape._BEFORE + edge_shape._AFTER + 1
    work = edge_shape._Work()
    for edges, width in ((5, 0.02), (9, 0.4), (3, 3.7), (9, 0.011)):
        y = rng.uniform(-0.1, 1.1, (edges, n_samples))
        guess = rng.uniform(-1.0, 1.0, edges)
        alone = edge_shape._grid(y, guess, width, shape)
        shared = edge_shape._grid(y, guess, width, shape, work)
        assert shared[0].tobytes() == alone[0].tobytes()
        assert shared[1].tobytes() == alone[1].tobytes()


@pytest.mark.parametrize("shape", ["first-order", "symmetric", "band-limited"])
def test_shapes_are_the_closed_forms_to_the_bit_and_leave_their_input(shape):
    rng = np.random.default_rng(13)
    u = np.concatenate([rng.normal(0.0, 3.0, 5000), [0.0, -0.0, 1e-300, -50.0, 50.0]])
    before = u.copy()
    for width in (0.01, 0.3, 4.0):
        if shape == "first-order":
            expected = -np.expm1(-np.clip(u, 0.0, None) / width)
        elif shape == "band-limited":
            expected = 0.5 + sici(u / width)[0] / np.pi
        else:
            expected = 0.5 * (1.0 + erf(u / (width * np.sqrt(2.0))))
        assert edge_shape._shape(u, width, shape).tobytes() == expected.tobytes()
        assert u.tobytes() == before.tobytes()
