"""Force error against the condition number near a four-bar toggle (docs/numerics.md table).

The rocker of the built-in four-bar is driven along the motion of a crank turning at 2 rad/s
through the toggle; the reference torque comes from the well-conditioned crank-driven
solve and the power balance. Run: ``python benchmarks/bench_toggle_forces.py``.
"""

from __future__ import annotations

import math
import tomllib
import warnings

import numpy as np

import rigval.model as rm

A, B, C, D = 0.1, 0.35, 0.3, 0.4
LIMIT = math.acos(((A + B) ** 2 - D * D - C * C) / (2 * D * C))
CRANK_AT_LIMIT = math.atan2(C * math.sin(LIMIT), D + C * math.cos(LIMIT))
SPEED = 2.0
CRANK0 = 0.3958851077208406   # crank guess of fourbar.toml: the laws start at the file's guesses
T_STAR = (CRANK_AT_LIMIT - CRANK0) / SPEED


def mechanism(driver: dict, guess=None) -> rm.Mechanism:
    data = tomllib.loads(rm.builtin_mechanism("fourbar").read_text())
    data["drivers"] = [driver]
    if guess is not None:
        for body, values in zip(data["bodies"], guess, strict=True):
            body["guess"] = [float(v) for v in values]
    return rm.load_mechanism(data)


def main() -> None:
    gaps = np.concatenate([[1e-2], 10.0 ** -np.arange(3, 12.5, 0.5)])
    t = T_STAR - gaps
    crank = mechanism({"name": "crank", "body": "crank", "law": "harmonic",
                       "theta0": CRANK0, "omega": SPEED})
    ref = rm.solve(crank, t, outputs=["position", "velocity", "acceleration", "driver_torque"])
    theta, omega, alpha = (ref[v].sel(coord="theta").to_numpy()[:, 2]
                           for v in ("position", "velocity", "acceleration"))
    reference = ref["driver_torque"].to_numpy()[:, 0] * SPEED / omega
    start = ref["position"].to_numpy()[0]
    rocker = mechanism({"name": "rocker", "body": "rocker", "law": "harmonic",
                        "theta0": float(start[2, 2]), "omega": 0.0}, guess=start)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = rm.solve(rocker, t, drives={"rocker": (theta, omega, alpha)}, cond_max=np.inf,
                      outputs=["driver_torque", "condition_number"])
    torque, cond = ds["driver_torque"].to_numpy()[:, 0], ds["condition_number"].to_numpy()
    eps = np.finfo(float).eps
    print(f"{'gap [s]':>9} {'condition':>10} {'cond^2 eps':>10} {'torque error':>12} refused")
    for k in range(t.size):
        error = abs(torque[k] / reference[k] - 1)
        print(f"{gaps[k]:9.2e} {cond[k]:10.3e} {cond[k] ** 2 * eps:10.2e} {error:12.2e} "
              f"{cond[k] > rm.assembly.COND_MAX}")


if __name__ == "__main__":
    main()
