"""Steps between solved ones interpolated in time (drive rates consistent with the angles).

With drive laws (or sampled drives whose rates match their angles) the steps between the finest
layer's are interpolated by quintic Hermite polynomials in time and usually need one Newton
iteration; with rates that do not interpolate the angles they are extrapolated as before. Both
must give the forces of the step-by-step reference, and the factors each step keeps must be its
own (:meth:`BatchLU.assign`).
"""

from __future__ import annotations

from collections.abc import Hashable

import numpy as np
import pytest
import xarray as xr

import rigval.model as rm
from rigval.model.continuation import _horner, _quintic
from rigval.model.drives import drive_motion
from rigval.model.linalg import BatchLU

T = np.linspace(0.0, 2.0, 4001)
OUTPUTS = ["joint_force", "driver_torque"]


def test_quintic_hermite_reproduces_a_quintic() -> None:
    rng = np.random.default_rng(3)
    c = rng.normal(size=(6, 2))
    p = [np.polynomial.Polynomial(c[:, k]) for k in range(2)]
    t0, t1 = 0.3, 0.7
    ends = [tuple(np.array([[q.deriv(d)(t) if d else q(t) for q in p]]) for d in range(3))
            for t in (t0, t1)]
    coef = _quintic(np.array([t1 - t0]), ends[0], ends[1])
    t = np.linspace(t0, t1, 7)
    u = (t - t0) / (t1 - t0)
    got = _horner(np.repeat(coef, t.size, axis=0), u)
    want = np.stack([q(t) for q in p], axis=1)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-13)


@pytest.mark.parametrize("square", [True, False])
def test_assign_replaces_the_factors_of_some_matrices(square: bool) -> None:
    rng = np.random.default_rng(5)
    rows = 6 if square else 8
    a = rng.normal(size=(rows, 6, 40))
    b = rng.normal(size=(rows, 6, 7))
    steps = np.array([0, 3, 4, 11, 20, 38, 39])
    merged = a.copy()
    merged[:, :, steps] = b
    order = np.array([1, 4, 3, 2, 5, 0]) if square else None
    lu = BatchLU(a.copy(), order)
    lu.assign(steps, BatchLU(b.copy(), order))
    rhs = rng.normal(size=(40, rows))
    want = BatchLU(merged.copy(), order).solve(rhs)
    np.testing.assert_allclose(lu.solve(rhs), want, rtol=1e-12, atol=1e-12)
    if square:
        rhs = rng.normal(size=(40, 6))
        np.testing.assert_allclose(lu.solve_transposed(rhs),
                                   np.linalg.solve(np.moveaxis(merged, -1, 0).swapaxes(1, 2),
                                                   rhs[..., None])[..., 0], rtol=1e-10)


@pytest.mark.parametrize("name", ["pendulum", "fourbar"])
def test_interpolated_and_extrapolated_steps_match_the_reference(name: str) -> None:
    mechanism = rm.load_mechanism(rm.builtin_mechanism(name))
    reference = rm.solve_stepwise(mechanism, T[::40])
    motion = drive_motion(mechanism, T, None)
    names = [d.name for d in mechanism.drivers]
    exact = {n: (motion.theta[:, i], motion.omega[:, i], motion.alpha[:, i])
             for i, n in enumerate(names)}
    # rates off by far more than the interpolation allows: extrapolated steps, same forces
    rough = {n: (theta, omega * (1 + 1e-6), alpha) for n, (theta, omega, alpha) in exact.items()}
    for drives in (None, exact):
        ds = rm.solve(mechanism, T, outputs=OUTPUTS, drives=drives)
        for key in OUTPUTS:
            want = reference[key].to_numpy()
            got = _every_40th(ds[key], reference[key].dims)
            assert np.abs(got - want).max() <= 1e-10 * np.abs(want).max(), key
    ds = rm.solve(mechanism, T, outputs=["position"], drives=rough)
    want = reference["position"].to_numpy()
    assert np.abs(_every_40th(ds["position"], reference["position"].dims) - want).max() <= 1e-9


def _every_40th(values: xr.DataArray, dims: tuple[Hashable, ...]) -> np.ndarray:
    return values.isel(time=slice(None, None, 40)).transpose(*dims).to_numpy()
