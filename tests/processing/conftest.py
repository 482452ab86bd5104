"""Synthetic two-clock rig with known truth for the processing tests.

The main shaft turns at about 1 rev/s with slow speed wander (so pulse periods differ from
revolution to revolution) and a within-revolution ripple. The reference device (cDAQ, 5 kS/s)
sees the optical pulse opt1 at phi_F = 0 as a band-limited analog pulse and the encoder counts;
the wireless device (1612.9 S/s, own clock: offset, drift, NI 9237 input delay) sees opt2 at
phi_F = 0 and opt3 twice per revolution at phi_F = 0.3 + k pi.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.special import sici

from rigval.processing.clock_fit import ni9237_input_delay

FS_REF = 5000.0
FS_DEV = 50000.0 / 31.0
CPR = 8192
TWO_PI = 2 * np.pi


def shaft_angle(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """True phi_F(t) (rad) and its rate (rad/s) on the reference clock."""
    w = TWO_PI * 1.0
    phi = (w * t + 0.6 * np.sin(TWO_PI * 0.05 * t) + 0.08 * np.sin(TWO_PI * 0.31 * t + 1.0)
           + 0.04 * np.sin(w * t + 0.5))
    rate = (w + 0.6 * TWO_PI * 0.05 * np.cos(TWO_PI * 0.05 * t)
            + 0.08 * TWO_PI * 0.31 * np.cos(TWO_PI * 0.31 * t + 1.0)
            + 0.04 * w * np.cos(w * t + 0.5))
    return phi, rate


def crossing_times(targets: np.ndarray) -> np.ndarray:
    """Times at which the true shaft angle reaches the target angles (Newton)."""
    t = targets / TWO_PI
    for _ in range(30):
        phi, rate = shaft_angle(t)
        t = t - (phi - targets) / rate
    return t


def pulse_signal(t: np.ndarray, rises: np.ndarray, width: float, fs: float,
                 rng: np.random.Generator, noise: float = 1e-3) -> np.ndarray:
    """Analog 0..1 pulses band-limited at 0.45 fs (ideal low-pass step responses) plus noise."""
    x = np.zeros_like(t)
    wc = TWO_PI * 0.45 * fs
    for r in rises:
        near = np.abs(t - r) < 0.2
        x[near] += (sici(wc * (t[near] - r))[0] - sici(wc * (t[near] - r - width))[0]) / np.pi
    return x + noise * rng.standard_normal(t.size)


@dataclass
class Rig:
    """The synthetic run and its truth."""

    t_ref: np.ndarray
    opt1: np.ndarray
    counts: np.ndarray
    t_dev: np.ndarray
    opt2: np.ndarray
    opt3: np.ndarray
    offset: float
    drift: float
    delay: float
    opt2_true: np.ndarray
    opt1_true: np.ndarray


def build_rig(seed: int = 1, *, missing: float = 0.1, spurious: int = 2, duration: float = 20.0,
              offset: float = 2.0137, drift: float = 37e-6) -> Rig:
    """Build a synthetic run; ``missing`` is the fraction of opt2 pulses dropped."""
    rng = np.random.default_rng(seed)
    t_ref = np.arange(0.0, duration + 4.0, 1 / FS_REF)
    n_rev = int(shaft_angle(np.array([t_ref[-1]]))[0][0] / TWO_PI)
    opt1_true = crossing_times(TWO_PI * np.arange(1, n_rev + 1))
    opt1 = pulse_signal(t_ref, opt1_true, 0.03, FS_REF, rng)
    phi, _ = shaft_angle(t_ref)
    counts = np.floor((phi + 1.234) / TWO_PI * CPR).astype(np.int64) % 2**32
    delay = ni9237_input_delay(FS_DEV)
    t_dev = np.arange(0.0, duration, 1 / FS_DEV)
    physical = offset + (1 + drift) * (t_dev - delay)      # reference time sensed
    opt2_true = opt1_true[(opt1_true > physical[0] + 0.1) & (opt1_true < physical[-1] - 0.1)]
    keep = np.ones(opt2_true.size, dtype=bool)
    keep[rng.choice(opt2_true.size, max(1, round(missing * opt2_true.size)),
                    replace=False)] = False
    fake = rng.uniform(physical[0] + 0.5, physical[-1] - 0.5, spurious)
    rises = np.sort(np.concatenate([opt2_true[keep], fake]))
    opt2 = pulse_signal(physical, rises, 0.03, FS_DEV, rng)
    opt3_true = crossing_times(0.3 + np.pi * np.arange(1, 2 * n_rev))
    opt3_true = opt3_true[(opt3_true > physical[0] + 0.1) & (opt3_true < physical[-1] - 0.1)]
    opt3 = pulse_signal(physical, opt3_true, 0.03, FS_DEV, rng)
    return Rig(t_ref, opt1, counts, t_dev, opt2, opt3, offset, drift, delay, opt2_true,
               opt1_true)


@pytest.fixture(scope="session")
def make_rig() -> Callable[..., Rig]:
    """Factory of synthetic runs: ``make_rig(seed, missing=0.1, spurious=2, duration=20)``."""
    return build_rig


@pytest.fixture(scope="session")
def synth() -> SimpleNamespace:
    """The generator's constants and helpers (tests cannot import conftest directly)."""
    return SimpleNamespace(FS_REF=FS_REF, FS_DEV=FS_DEV, CPR=CPR, TWO_PI=TWO_PI,
                           shaft_angle=shaft_angle, crossing_times=crossing_times,
                           pulse_signal=pulse_signal)
