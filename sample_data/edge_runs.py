"""Pulse runs of many edge shapes on a drifting device clock, with the exact truth.

Small synthetic runs for the coverage of the clock fit's 95 % intervals
(``benchmarks/bench_alignment_coverage.py``, ``tests/processing/test_edge_intervals.py``): a
shaft fires one pulse per revolution; a device sampling at 1.6-5 kHz on its own clock
``t_ref = offset + (1 + drift) t_dev`` records the pulses; the reference events are the true
pulse times on the reference clock with 2 us rms jitter (as the encoder angle gives them).

Edge classes (the truth of an edge is the moment the sensor starts to switch):

- ``digital``: a logic level sampled by the device clock (sample-switched);
- ``band-limited``: a step through the delta-sigma filter's ideal low-pass at 0.45 fs (a sine
  integral; its mid crossing is the truth), with noise;
- ``first-order``: ``1 - exp(-(t - t0) / tau)`` sampled without an anti-alias filter, ``tau``
  0.05-2 sample periods, with noise (an optical sensor on a SAR or wireless module).

Drive periods are drawn near a whole number of samples (the sampling phase then beats slowly
from pulse to pulse: the hard case) or far from one, with or without a slow speed wander.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.special import sici

from rigval.processing.arrays import FloatArray

__all__ = ["EDGE_CLASSES", "STAMP_WINDOW_S", "EdgeRun", "edge_run", "edge_runs"]

#: The edge classes, in the order :func:`edge_runs` cycles through them.
EDGE_CLASSES = ("digital", "band-limited", "first-order")
EdgeClass = Literal["digital", "band-limited", "first-order"]
#: Start stamps' error (rms, s) and the window searched around them (s): narrower than half the
#: shortest period, so the stamps decide the whole periods.
STAMP_RMS_S = 0.01
STAMP_WINDOW_S = 0.05
#: Rms jitter of the reference events, s.
REFERENCE_JITTER_S = 2e-6
#: Share of the period a pulse stays high.
DUTY = 0.3


@dataclass(frozen=True)
class EdgeRun:
    """One synthetic pulse run and its truth.

    Attributes
    ----------
    ref : numpy.ndarray
        Reference events, s on the reference clock.
    t_dev, x_dev : numpy.ndarray
        Device sample times (s, its own clock) and pulse signal (0 low, 1 high).
    fs : float
        Device sampling rate, Hz.
    offset_s, drift : float
        True clock: ``t_ref = offset_s + (1 + drift) t_dev`` (s, 1).
    coarse_offset_s : float
        The start stamps' offset, s.
    edge : str
        Edge class (:data:`EDGE_CLASSES`).
    rise_samples : float
        First-order time constant in sample periods (0 for the other classes).
    label : str
        Class, drive, rate, pulses and noise, for tables.
    """

    ref: FloatArray
    t_dev: FloatArray
    x_dev: FloatArray
    fs: float
    offset_s: float
    drift: float
    coarse_offset_s: float
    edge: str
    rise_samples: float
    label: str


def _edge(u: FloatArray, edge: EdgeClass, fs: float, tau_s: float) -> FloatArray:
    """Response 0..1 of one edge at times u (s) after its true time."""
    if edge == "digital":
        return (u >= 0).astype(np.float64)
    if edge == "band-limited":
        return 0.5 + sici(2 * math.pi * 0.45 * fs * u)[0] / math.pi
    return -np.expm1(-np.clip(u, 0.0, None) / tau_s)


def edge_run(rng: np.random.Generator, *, edge: EdgeClass, n: int, near: bool,
             fs: float | None = None, period_samples: float | None = None,
             rise_samples: float | None = None, noise: float | None = None,
             wander: bool | None = None) -> EdgeRun:
    """Return one run with ``n`` pulses whose period is ``near`` a whole number of samples or not.

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of every random choice.
    edge : {"digital", "band-limited", "first-order"}
        Edge class.
    n : int
        Pulses the device records.
    near : bool
        Drive period within 0.005 sample of a whole number of device samples.
    fs, period_samples, rise_samples, noise, wander : optional
        Fixed instead of drawn: the rate in Hz, the drive period in device samples, the
        first-order time constant in samples, the noise rms (1) and whether the speed wanders.

    Returns
    -------
    EdgeRun
        Signals and truth.
    """
    fs = float(rng.uniform(1600.0, 5000.0)) if fs is None else fs
    whole = int(rng.integers(int(0.12 * fs), int(0.6 * fs)))
    fraction = rng.uniform(-0.005, 0.005) if near else rng.uniform(0.05, 0.95)
    period = (whole + fraction if period_samples is None else period_samples) / fs  # device
    offset = float(rng.uniform(-1.5, 1.5))
    drift = float(rng.uniform(-50e-6, 50e-6))
    k = np.arange(n, dtype=np.float64)
    wander = bool(rng.uniform() < 0.5) if wander is None else wander
    times = 0.3 + k * period
    if wander:  # a slow speed wander of 0.2 %
        omega = 2 * math.pi / (period * rng.uniform(20.0, 60.0))
        times = times + 0.002 / omega * np.sin(omega * k * period + rng.uniform(0, 2 * math.pi))
    rise = (float(np.exp(rng.uniform(math.log(0.05), math.log(2.0))))
            if rise_samples is None else rise_samples)
    tau_s = rise / fs if edge == "first-order" else 0.0
    drawn = 0.0 if edge == "digital" else float(rng.choice([0.0, 1e-3, 5e-3]))
    noise = drawn if noise is None else noise
    t_dev = np.arange(round((times[-1] + 0.3 + period) * fs)) / fs
    x = np.zeros(t_dev.size)
    half = max(int(0.45 * period * fs), 1)
    for rise in times:
        i = int(np.ceil(rise * fs))
        rows = slice(max(i - half, 0), min(i + half, t_dev.size))
        u = t_dev[rows] - rise
        x[rows] += _edge(u, edge, fs, tau_s) - _edge(u - DUTY * period, edge, fs, tau_s)
    x += noise * rng.standard_normal(x.size)
    ref = offset + (1.0 + drift) * times + REFERENCE_JITTER_S * rng.standard_normal(n)
    label = (f"{edge} {'near' if near else 'far'}{' wander' if wander else ''} "
             f"fs={fs:.0f} n={n} tau={tau_s * fs:.2f} noise={noise:g}")
    return EdgeRun(ref, t_dev, x, fs, offset, drift,
                   offset + STAMP_RMS_S * float(rng.standard_normal()), edge, tau_s * fs, label)


def edge_runs(count: int, seed: int) -> list[EdgeRun]:
    """Return ``count`` runs cycling through the edge classes and near/far drive periods.

    Pulses per run are log-uniform from 6 to 400 (6 and 400 included for each class).
    """
    rng = np.random.default_rng(seed)
    runs = []
    for i in range(count):
        edge = EDGE_CLASSES[i % len(EDGE_CLASSES)]
        near = bool(i // len(EDGE_CLASSES) % 2)
        block = i // (2 * len(EDGE_CLASSES))
        n = (6 if block == 0 else 400 if block == 1
             else int(np.round(np.exp(rng.uniform(math.log(6), math.log(400))))))
        runs.append(edge_run(rng, edge=edge, n=n, near=near))
    return runs
