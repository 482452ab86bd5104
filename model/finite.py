"""Non-finite model results: find the first one and name the input that overflowed.

Double precision ends near 1.8e308. Masses, inertias, gravity and drive speeds whose products
(``m g``, ``m omega**2 L``, ``I alpha``) pass that limit give infinite or NaN accelerations and
forces; :func:`check_finite` turns them into a :class:`~rigval.model.errors.ModelError` that
names the variable, the first time step and the inputs large enough to cause it, instead of
numpy's RuntimeWarning and a result full of NaN.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from rigval.model.errors import ModelError

if TYPE_CHECKING:
    from rigval.model.drives import DriveSamples
    from rigval.model.mechanism import Mechanism
    from rigval.model.results import Solution

__all__ = ["check_finite", "overflow_causes"]

#: Inputs whose magnitude passes this are named as causes (their square or a product with
#: ordinary values can leave double precision: sqrt(1.8e308) = 1.3e154).
_LARGE = 1e100

#: Solution arrays in the order the stages compute them, with a reader's name for each.
_STAGES = (("theta", "body angle"), ("position", "body position"),
           ("omega", "angular velocity"), ("velocity", "velocity"),
           ("alpha", "angular acceleration"), ("acceleration", "acceleration"),
           ("joint", "joint force"), ("driver", "driver torque"))


def overflow_causes(mechanism: Mechanism, motion: DriveSamples) -> list[str]:
    """Return the inputs of a solve large enough to overflow its products (may be empty).

    Parameters
    ----------
    mechanism : Mechanism
        The mechanism (masses in kg, inertias in kg m2, gravity in m/s2).
    motion : DriveSamples
        The driven angles, speeds (rad/s) and accelerations (rad/s2).
    """
    causes = [f"mass {body.mass:.3g} kg of body {body.name!r}"
              for body in mechanism.bodies if abs(body.mass) > _LARGE]
    causes += [f"inertia {body.inertia:.3g} kg m2 of body {body.name!r}"
               for body in mechanism.bodies if abs(body.inertia) > _LARGE]
    gravity = math.hypot(*mechanism.gravity)
    if gravity > _LARGE:
        causes.append(f"gravity {gravity:.3g} m/s2")
    for label, unit, values in (("drive speed", "rad/s", motion.omega),
                                ("drive acceleration", "rad/s2", motion.alpha)):
        for k, driver in enumerate(mechanism.drivers):
            peak = float(np.max(np.abs(values[:, k]))) if values.size else 0.0
            if peak > _LARGE:
                causes.append(f"{label} {peak:.3g} {unit} of driver {driver.name!r}")
    return causes


def check_finite(mechanism: Mechanism, motion: DriveSamples, solution: Solution) -> None:
    """Raise a ModelError at the first non-finite value of the computed stages.

    Parameters
    ----------
    mechanism : Mechanism
        The mechanism solved.
    motion : DriveSamples
        Its drive motion.
    solution : Solution
        The arrays computed (stages not computed are None and skipped).

    Raises
    ------
    ModelError
        Names the variable, the first time (s) and the inputs that overflow.
    """
    for attribute, label in _STAGES:
        values = getattr(solution, attribute)
        if values is None:
            continue
        with np.errstate(over="ignore", invalid="ignore"):
            total = np.sum(values)
        if np.isfinite(total):  # one pass, no temporaries: NaN and inf reach the sum
            continue
        finite = np.isfinite(values).reshape(values.shape[0], -1).all(axis=1)
        if finite.all():
            continue
        step = int(np.argmin(finite))
        time_s = float(solution.times[step])
        causes = overflow_causes(mechanism, motion)
        because = ("; inputs beyond double precision's range in their products: "
                   + ", ".join(causes)) if causes else ""
        raise ModelError(
            f"{mechanism.name}: the {label} is not finite from t = {time_s:.9g} s on (overflow "
            f"past 1.8e308 or NaN){because}",
            where={"file": mechanism.source, "time_s": time_s, "variable": label},
            hint="check the units and magnitudes of masses, inertias, gravity and drive speeds "
                 "(SI: kg, kg m2, m/s2, rad/s)")
