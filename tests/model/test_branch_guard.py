"""Large continuation steps keep the assembly branch of the initial configuration.

Anchors farther apart than the Taylor predictor's range (a few rad of crank on the built-in
mechanisms) used to land Newton on another closure of the loops, which the old plausibility test
(corrector move below a quarter of the step) let through: with ``anchor_spacing`` 4 to 9 rad the
pendulum and the four-bar followed another branch silently. The independent reference is
:func:`rigval.model.solve_stepwise`: full coordinates, every step starting from the previous one
on a dense time grid, from the bodies' guesses.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

import rigval.model as rm
from rigval.model import assembly

T = np.linspace(0.0, 5.0, 2001)  # crank steps of 0.016 rad or less: the stepwise reference holds


@functools.cache
def _reference(name: str) -> dict[str, np.ndarray]:
    ds = rm.solve_stepwise(rm.builtin_mechanism(name), T)
    return {key: ds[key].to_numpy() for key in ("position", "joint_force", "driver_torque")}


@pytest.mark.parametrize("name", ["pendulum", "fourbar"])
@pytest.mark.parametrize("spacing", [4.0, 6.0, 9.0, 30.0])
def test_large_anchor_steps_keep_the_branch(name: str, spacing: float,
                                            monkeypatch: pytest.MonkeyPatch) -> None:
    # anchor_spacing is not an argument of solve(): change the default it builds
    monkeypatch.setattr(assembly, "Tolerances",
                        functools.partial(assembly.Tolerances, anchor_spacing=spacing))
    ds = rm.solve(rm.builtin_mechanism(name), T,
                  outputs=["position", "joint_force", "driver_torque"])
    reference = _reference(name)
    np.testing.assert_allclose(ds["position"].to_numpy(), reference["position"], rtol=0,
                               atol=1e-10)
    for key in ("joint_force", "driver_torque"):
        np.testing.assert_allclose(ds[key].to_numpy(), reference[key], rtol=0,
                                   atol=1e-9 * np.max(np.abs(reference[key])))
