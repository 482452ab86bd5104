"""The diagnosis's and the verdict's quantiles are scipy.stats' values to the bit.

The attribution's selection penalty, the pair share's coverage factor and the family's ``k``
take their quantiles from ``scipy.special`` (the functions ``scipy.stats`` calls, without its
distribution machinery); each must equal the ``scipy.stats`` value it replaced.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.stats

from rigval.validation.diagnosis.attribution import ALPHA, _penalty
from rigval.validation.diagnosis.symmetry import pair_shares
from rigval.validation.verdict import family_k
from tests.validation.revolution_grid import PHI


@pytest.mark.parametrize("rows", [2, 10, 57, 400])
def test_selection_penalty_is_the_bic_or_the_chi2_quantile(rows: int) -> None:
    for candidates in range(1, 120):
        expected = max(math.log(rows), float(scipy.stats.chi2.isf(ALPHA / candidates, 1)))
        assert _penalty(rows, candidates) == expected


@pytest.mark.parametrize("seed", range(6))
def test_pair_share_coverage_is_the_t_quantile(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n_cycles = 3 + 5 * seed
    load = 500.0 * np.sin(PHI) * (1.0 + 0.02 * rng.standard_normal((n_cycles, 1)))
    a = 0.5 * load + rng.standard_normal(load.shape)
    b = 0.5 * load + rng.standard_normal(load.shape)
    out = pair_shares(a, b, u_first=0.01 * seed, u_second=0.01)
    dof = out.u_share**4 / (out.u_scatter**4 / (out.n_cycles - 1))
    assert out.k == float(scipy.stats.t.ppf(0.975, dof))


@pytest.mark.parametrize("level", [0.5, 0.9, 0.95, 0.99])
def test_family_k_is_the_normal_quantile(level: float) -> None:
    for tests in range(1, 40):
        each = 1.0 - level ** (1.0 / tests)
        assert family_k(tests, level) == float(scipy.stats.norm.isf(each / 2.0))
