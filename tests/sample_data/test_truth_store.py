"""A long record's truth computed in pieces (filter state carried) equals the whole-record truth.

The expectation is always the whole record in one call: :func:`scipy.signal.lsim` and
:func:`rigval.processing.accelerometer.charge_chain_voltage` over the whole input, and the rig's
one-window path (the whole truth grid in memory). The pieces repeat the whole record's recursion
step for step (same coefficients, same state), so they agree to the last bit; the tolerance
1e-12 of a signal's range leaves room for a BLAS that rounds a short matrix product differently
from a long one, and for the model solved in pieces (1e-14 of the range, test_rig_long).
"""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest
from scipy.signal import lsim

import rigval.sample_data.simulate as simulate
from rigval.acquisition import read
from rigval.processing.accelerometer import charge_chain_voltage
from rigval.sample_data import RigSettings, RunFiles
from rigval.sample_data.carried_filters import CarriedHighPass, CarriedLsim
from rigval.sample_data.rig import draw_rig
from rigval.sample_data.streams import SAMPLED_QUANTITIES, sampled_truth
from rigval.sample_data.truth import TruthGrid, model_truth
from rigval.sample_data.truth_store import UniformGrid, store_truth
from tests.sample_data.run_pairs import runs_with_and_without

#: Cuts of a 5000-point record into pieces of uneven length, one of a single point.
CUTS = (0, 1, 2, 777, 778, 2500, 4999, 5000)


def _pieces(values: np.ndarray) -> list[np.ndarray]:
    return [values[a:b] for a, b in itertools.pairwise(CUTS)]


def _signal() -> tuple[np.ndarray, np.ndarray]:
    t = 3.0 + np.arange(5000) / 1000.0
    rng = np.random.default_rng(4)
    return t, 200.0 * np.sin(2 * np.pi * 1.3 * t) + 50.0 * rng.normal(size=t.size) + 30.0


def test_lsim_in_pieces_equals_one_call_and_needs_the_carried_state() -> None:
    t, force = _signal()
    wn = 2 * np.pi * 22.0
    system = ([1.0 / 900.0, 0.0, 0.0], [1.0, 2 * 0.03 * wn, wn**2])
    _, whole, _ = lsim(system, force, t - t[0])
    carried = CarriedLsim(system, t[1] - t[0])
    pieces = np.concatenate([carried.step(p) for p in _pieces(force)])
    np.testing.assert_allclose(pieces, whole, rtol=0, atol=1e-12 * np.ptp(whole))
    # restarting a piece at rest instead leaves a seam far above that tolerance
    _, restarted, _ = lsim(system, force[2500:], t[2500:] - t[2500])
    assert np.abs(restarted - whole[2500:]).max() > 1e-3 * np.ptp(whole)


def test_highpass_in_pieces_equals_the_charge_chain_over_the_record() -> None:
    _, acc = _signal()
    whole = charge_chain_voltage(acc, charge_sensitivity=10.0, amplifier_gain=10.0, fs=1000.0,
                                 highpass_hz=0.1)
    volts = charge_chain_voltage(acc, charge_sensitivity=10.0, amplifier_gain=10.0)
    carried = CarriedHighPass(1000.0, 0.1)
    pieces = np.concatenate([carried.step(p) for p in _pieces(volts)])
    np.testing.assert_allclose(pieces, whole, rtol=0, atol=1e-12 * np.ptp(whole))


def test_uniform_grid_index_is_searchsorted_on_the_grid() -> None:
    grid = UniformGrid(-12.345678, 1000.0, 40000)
    t = grid.times(0, grid.n)
    probes = np.concatenate([t[[0, 1, 17, 39998, 39999]], t[[5, 900]] + 1e-13,
                             np.random.default_rng(0).uniform(t[0], t[-1], 200)])
    assert [grid.index(p) for p in probes] == list(np.searchsorted(t, probes))
    assert grid.rate == float((t.size - 1) / (t[-1] - t[0]))


def test_stored_truth_windows_equal_the_whole_grids(tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """The store against the whole grid in memory with the model solved in the same pieces (as
    a long record was before the store), so that only the filters' pieces differ."""
    settings = RigSettings(duration=6.0, seed=9)
    mechanism = simulate.default_mechanism()
    draw = draw_rig(settings, simulate.mechanism_drivers(mechanism))
    grid = UniformGrid(-13.0, 1000.0, 21000)

    def solve(t: np.ndarray) -> TruthGrid:
        return model_truth(mechanism, draw.drive, t)

    monkeypatch.setattr(simulate, "TRUTH_POINTS", 1234)
    solved = simulate._truth_grid(lambda _, t: solve(t), draw.drive, grid.times(0, grid.n))
    whole = sampled_truth(draw, TruthGrid(solved.t, {k: v for k, v in solved.values.items()
                                                     if k in SAMPLED_QUANTITIES}))
    store = store_truth(solve, draw, grid, 1234, tmp_path)
    for t_from, t_to in ((-13.0, -12.0), (-1.3, 2.7), (1.2335, 1.2345), (6.0, 8.0)):
        part, expected = store.window(t_from, t_to), whole.window(t_from, t_to)
        for name in ("grid", "physical", "volts"):
            got, want = getattr(part, name), getattr(expected, name)
            np.testing.assert_array_equal(got.t, want.t)
            assert got.values.keys() == want.values.keys()
            for key, values in want.values.items():
                scale = np.ptp(getattr(whole, name).values[key])
                np.testing.assert_allclose(got.values[key], values, rtol=0,
                                           atol=1e-12 * scale, err_msg=f"{name}.{key}")


@pytest.fixture(scope="module")
def stored_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[RunFiles, RunFiles]:
    """A 10 s run with its truth in memory, and the same seed with the truth stored in pieces."""
    return runs_with_and_without(tmp_path_factory.mktemp("stored"), "TRUTH_POINTS", 2000)


def test_run_with_stored_truth_equals_the_one_window_run(stored_run) -> None:
    """Same samples, codes and counts: the truth differs by the model's rounding only."""
    whole, stored = stored_run
    assert not list(stored.folder.glob(".truth-*"))  # the temporary files are gone
    for suffix in ("cdaq.tdms", "wls1.tdms", "wls2.csv"):
        a, b = read(whole.path(suffix)), read(stored.path(suffix))
        for group in a:
            for name in a[group].data_vars:
                np.testing.assert_array_equal(a[group][name].values, b[group][name].values,
                                              err_msg=f"{suffix} {name}")
    with np.load(whole.path("truth.npz")) as x, np.load(stored.path("truth.npz")) as y:
        assert x.files == y.files
        for key in x.files:  # float32: a rounding of the model may move a last bit
            np.testing.assert_allclose(y[key], x[key], rtol=0, atol=1e-6 * np.ptp(x[key]))
