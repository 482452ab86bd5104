"""The model's own check of its numerics: the power balance over one revolution of the laws.

A rigid-body model without friction delivers through its drives exactly the rate of change of its
kinetic plus potential energy. :func:`energy_residual` solves one revolution of the mechanism
file's drive laws and compares the two, both derivatives spectral; what remains is the model's
numerical error (docs/numerics.md).
"""

from __future__ import annotations

import logging

import numpy as np

from rigval.acquisition.errors import ConfigError
from rigval.model.mechanism import Mechanism
from rigval.model.solver import solve_cycle

__all__ = ["energy_residual", "periodic_derivative"]

logger = logging.getLogger(__name__)


def energy_residual(mechanism: Mechanism, points: int) -> dict[str, float]:
    """Check the model's numerics by its power balance on the file's drive laws.

    Drive power against the rate of change of kinetic plus potential energy over one
    revolution, both derivatives spectral; with the conditioning and the Newton tolerance.

    Parameters
    ----------
    mechanism : rigval.model.Mechanism
        The mechanism.
    points : int
        Angle points per revolution.

    Returns
    -------
    dict of str to float
        Check name to value; empty when the drive laws do not repeat per revolution.
    """
    try:
        cycle = solve_cycle(mechanism, points, outputs=["kinetic_energy", "potential_energy",
                                                         "drive_power"])
    except ConfigError as error:  # drive laws that do not repeat per revolution
        logger.info("power balance skipped: %s", error)
        return {}
    energy = (cycle["kinetic_energy"] + cycle["potential_energy"]).to_numpy()
    power = cycle["drive_power"].sum("driver").to_numpy()
    slope = float(cycle.attrs["cycle_period_s"]) / (2 * np.pi)
    # dE/dt = (dE/dphi) / (dt/dphi); t(phi) - slope phi is periodic, so both derivatives are
    # spectral (exact to rounding for these smooth periodic signals)
    dt_dphi = periodic_derivative(cycle["time"].to_numpy() - slope * cycle["angle"].to_numpy())
    balance = power - periodic_derivative(energy) / (dt_dphi + slope)
    return {"power balance max |P - dE/dt| / max |P|":
            float(np.max(np.abs(balance)) / max(float(np.max(np.abs(power))), 1e-300)),
            "max condition number of C_e": float(cycle.attrs["max_condition_number"]),
            "Newton tolerance": float(cycle.attrs["newton_tol"])}


def periodic_derivative(values: np.ndarray) -> np.ndarray:
    """Return d/dphi of samples of a periodic function on a uniform grid over one revolution.

    Spectral: the derivative of the samples' trigonometric interpolant (the Nyquist term of an
    even count has no defined derivative and is left out).
    """
    spectrum = np.fft.rfft(values)
    order = np.arange(spectrum.size, dtype=np.float64)
    if values.size % 2 == 0:
        order[-1] = 0.0
    return np.fft.irfft(1j * order * spectrum, n=values.size)
