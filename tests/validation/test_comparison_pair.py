"""A comparison's whole revolutions: the cycles without a gap, their mean, the model as scaled.

Independent expectations: the rows of the cycles that are finite (a boolean mask), their mean by
numpy, and the scene's scale and offset written out.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from rigval.acquisition.errors import DataError
from rigval.sample_data import runs_dir
from rigval.validation.comparison_scores import pair
from rigval.validation.scene import load_scene


def _comparison(**changes):
    comparison = load_scene(runs_dir() / "run_0p8_scene.toml").comparisons[0]
    return dataclasses.replace(comparison, **changes)


def test_without_gaps_the_cycles_are_the_whole_revolutions_read_only():
    cycles = np.random.default_rng(1).normal(size=(12, 36))
    found = pair(_comparison(), cycles, np.zeros(36))
    assert np.shares_memory(found.whole, cycles) and np.array_equal(found.whole, cycles)
    assert not found.whole.flags.writeable and cycles.flags.writeable
    with pytest.raises(ValueError, match="read-only"):
        found.whole[0, 0] = 1.0
    assert np.array_equal(found.mean, cycles.mean(axis=0))


def test_revolutions_with_a_gap_are_left_out():
    cycles = np.random.default_rng(2).normal(size=(12, 36))
    cycles[[3, 7], 5] = np.nan
    model = np.linspace(0.0, 1.0, 36)
    found = pair(_comparison(scale=2.0, remove_offset=True), cycles, model)
    kept = cycles[np.isfinite(cycles).all(axis=1)]
    assert found.whole.shape == (10, 36) and np.array_equal(found.whole, kept)
    assert not found.whole.flags.writeable
    assert np.array_equal(found.mean, kept.mean(axis=0))
    offset = kept.mean(axis=0).mean() - (2.0 * model).mean()
    assert found.offset == pytest.approx(offset, rel=1e-15)
    assert np.allclose(found.model, 2.0 * model + offset, rtol=0, atol=1e-15)


def test_fewer_than_two_whole_revolutions_are_refused():
    cycles = np.full((5, 36), np.nan)
    cycles[0] = 1.0
    with pytest.raises(DataError, match="only 1 whole revolutions"):
        pair(_comparison(), cycles, np.zeros(36))
