"""Alignment sweep of ``rigval bench``: reference events and pulse quality against clock error.

Synthetic two-clock case with known truth: a shaft at about 1 rev/s (speed wandering by a few
per cent) fires one optical pulse per revolution, seen by the reference device (5 kHz) and by a
second device (NI 9237 rate 1612.9 S/s) whose clock runs ``t_ref = a + (1 + d) t_dev`` with an
offset ``a`` near 0.7 s and a drift ``d`` of +-50 ppm; 7 % of the second device's pulses are
missing. Pulse quality:

- ``analog, sinc edges``: pulses whose rising edge is band-limited (the delta-sigma channel's
  0.45 fs corner, a sine integral) and whose fall is slow, so that its ringing does not move the
  rising edge's mid crossing; 60 dB SNR; edges by band-limited reconstruction;
- ``analog, linear edges``: the same pulses, linear interpolation at the mid level;
- ``digital line``: the pulse sampled as a 0/1 logic level by each device's sample clock.

Each choice runs :func:`rigval.processing.pulses.detect_edges` on both devices and
:func:`rigval.processing.align.estimate_clock`; the error is the rms over several random runs of
the fitted offset (at the second device's first sample) and drift minus the truth; the time is
the median over the runs (edge detection on both devices plus the fit). The limit
column is the least-squares error that the per-edge timing error alone leaves:
``sigma_edge * sqrt(1/N + mean(t)**2 / S_tt)`` for the offset and ``sigma_edge / sqrt(S_tt)`` for
the drift (``S_tt`` the sum of squared event-time deviations), with ``sigma_edge`` the combined
timing error of both devices: the quantisation of a sampled logic level (``dt / sqrt(12)``), the
interpolation error of linear edges (0.032 sample rms, research note 4.1), the noise of sinc edges
(``sigma_noise / slope``, slope 0.9 per sample for a unit band-limited step). The baseline is no
alignment at all: the file start times (software time stamps, here 10 ms rms off) and no drift.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from functools import partial
from typing import Literal

import numpy as np
from scipy.special import sici

from rigval.processing import align, pulses
from rigval.processing.arrays import FloatArray
from rigval.validation.bench.rows import BenchRow, measure, with_baseline

__all__ = ["TwoClockRun", "alignment_rows", "two_clock_run"]

logger = logging.getLogger(__name__)

FS_REF = 5000.0
FS_DEV = 50_000.0 / 31  # NI 9237 at its lowest rate
PULSE_WIDTH_S = 0.03
FALL_S = 0.01
NOISE = 1e-3  # 60 dB below the unit pulse
START_STAMP_ERROR_S = 0.01
MISSING_FRACTION = 0.07
BASELINE = "no alignment: start times, no drift"
Quality = Literal["analog", "digital"]

@dataclass(frozen=True)
class TwoClockRun:
    """Pulse signals of one synthetic run on two clocks, and the truth.

    Attributes
    ----------
    t_ref, x_ref : numpy.ndarray
        Reference device sample times (s, its clock) and pulse signal.
    t_dev, x_dev : numpy.ndarray
        Second device sample times (s, its own clock) and pulse signal.
    offset_s : float
        True offset a in ``t_ref = a + (1 + drift) t_dev``, s.
    drift : float
        True drift d (1).
    coarse_offset_s : float
        The start-time estimate of the offset (software stamps), s.
    pulses_dev : numpy.ndarray
        True rise times of the pulses the second device records, s on its clock.
    """

    t_ref: FloatArray
    x_ref: FloatArray
    t_dev: FloatArray
    x_dev: FloatArray
    offset_s: float
    drift: float
    coarse_offset_s: float
    pulses_dev: FloatArray


def _pulse_signal(t: FloatArray, rises: FloatArray, fs: float, quality: Quality,
                  rng: np.random.Generator) -> FloatArray:
    """Return unit pulses rising at ``rises`` (high for PULSE_WIDTH_S) as a device records them."""
    x = np.zeros_like(t)
    start = np.searchsorted(t, rises - 0.2)
    stop = np.searchsorted(t, rises + 0.2 + PULSE_WIDTH_S)
    wc = 2 * math.pi * 0.45 * fs
    for r, i, j in zip(rises, start, stop, strict=True):
        local = t[i:j] - r
        if quality == "digital":
            x[i:j] += (local >= 0) & (local < PULSE_WIDTH_S)
        else:  # band-limited rising edge, slow (raised-cosine) fall that does not ring
            fall = np.clip((local - PULSE_WIDTH_S) / FALL_S, 0.0, 1.0)
            x[i:j] += (0.5 + sici(wc * local)[0] / math.pi) * 0.5 * (1 + np.cos(math.pi * fall))
    if quality == "analog":
        x += NOISE * rng.standard_normal(t.size)
    return x


def two_clock_run(revolutions: int, quality: Quality, seed: int) -> TwoClockRun:
    """Build one synthetic run (module docstring) with ``revolutions`` reference pulses.

    Parameters
    ----------
    revolutions : int
        Revolutions (pulses on the reference device).
    quality : {"analog", "digital"}
        Band-limited analog pulses with noise, or a sampled logic level.
    seed : int
        Random seed (speed wander, clock, missing pulses, noise).

    Returns
    -------
    TwoClockRun
        Signals and truth.
    """
    rng = np.random.default_rng(seed)
    periods = 1.0 + 0.03 * np.cumsum(rng.standard_normal(revolutions)) / math.sqrt(revolutions)
    periods += 0.02 * rng.standard_normal(revolutions)
    rises_ref = 0.5 + np.concatenate([[0.0], np.cumsum(periods[:-1])])
    duration = rises_ref[-1] + 0.5
    offset = 0.7 + 0.1 * rng.uniform()
    drift = 50e-6 * rng.choice([-1.0, 1.0])
    t_ref = np.arange(round(duration * FS_REF)) / FS_REF
    t_dev = np.arange(round((duration - offset + 1.0) * FS_DEV)) / FS_DEV
    rises_dev = (rises_ref - offset) / (1 + drift)
    keep = (rises_dev > 0.3) & (rng.uniform(size=revolutions) >= MISSING_FRACTION)
    return TwoClockRun(
        t_ref=t_ref, x_ref=_pulse_signal(t_ref, rises_ref, FS_REF, quality, rng),
        t_dev=t_dev, x_dev=_pulse_signal(t_dev, rises_dev[keep], FS_DEV, quality, rng),
        offset_s=offset, drift=drift,
        coarse_offset_s=offset + START_STAMP_ERROR_S * rng.standard_normal(),
        pulses_dev=rises_dev[keep])


def _fit(run: TwoClockRun, refine: Literal["linear", "sinc"]) -> align.ClockModel:
    ref = pulses.detect_edges(run.x_ref, run.t_ref, refine=refine, holdoff_s=0.3)
    dev = pulses.detect_edges(run.x_dev, run.t_dev, refine=refine, holdoff_s=0.3)
    return align.estimate_clock(ref, dev, coarse_offset_s=run.coarse_offset_s,
                                max_offset_error_s=0.2)


def _edge_sigma_s(label: str) -> float:
    """Return the combined per-edge timing error of both devices for a pulse quality, s."""
    if label == "digital line":
        per_sample = 1 / math.sqrt(12)
    elif label == "analog, linear edges":
        per_sample = 0.032
    else:
        per_sample = NOISE / 0.9
    return per_sample * math.hypot(1 / FS_REF, 1 / FS_DEV)


def _limits(run: TwoClockRun, sigma: float) -> tuple[float, float]:
    """Return the offset and drift error (s, 1) the edge timing alone leaves in the line fit."""
    t = run.pulses_dev
    s_tt = float(np.sum((t - t.mean()) ** 2))
    return sigma * math.sqrt(1 / t.size + t.mean() ** 2 / s_tt), sigma / math.sqrt(s_tt)


def alignment_rows(quick: bool = False) -> list[BenchRow]:
    """Offset and drift error against the number of reference events and the pulse quality.

    Parameters
    ----------
    quick : bool, default False
        Revolutions (20, 100) over 3 random runs instead of (10, 25, 100, 400) over 8.

    Returns
    -------
    list of BenchRow
        Stage ``"alignment"``, metrics offset error rms (us) and drift error rms (ppm), each
        choice next to its timing-limited bound and the start-time baseline.
    """
    counts = (20, 100) if quick else (10, 25, 100, 400)
    seeds = range(3 if quick else 8)
    choices: dict[str, tuple[Quality, Literal["linear", "sinc"]]] = {
        "analog, sinc edges": ("analog", "sinc"),
        "analog, linear edges": ("analog", "linear"),
        "digital line": ("digital", "linear")}
    rows: list[BenchRow] = []
    for revolutions in counts:
        case = f"{revolutions} revolutions at ~1 rev/s, 5 kHz and 1612.9 S/s, 7 % pulses missing"
        runs = {q: [two_clock_run(revolutions, q, 1000 * revolutions + s) for s in seeds]
                for q in ("analog", "digital")}
        stamp = [r.coarse_offset_s - r.offset_s for r in runs["analog"]]
        drifts = [r.drift for r in runs["analog"]]
        for metric, unit, error in (("offset", "us", _rms(stamp) * 1e6),
                                    ("drift", "ppm", _rms(drifts) * 1e6)):
            rows.append(BenchRow(stage="alignment", case=case, choice=BASELINE,
                                 metric=f"{metric} error rms over {len(seeds)} runs", unit=unit,
                                 error=error, bound=math.inf, time_s=0.0, cpu_s=0.0,
                                 n=revolutions))
        for label, (quality, refine) in choices.items():
            rows.extend(_choice_rows(label, case, runs[quality], refine, revolutions))
    return with_baseline(rows, BASELINE)


def _rms(values: list[float]) -> float:
    return float(np.sqrt(np.mean(np.square(values))))


def _choice_rows(label: str, case: str, runs: list[TwoClockRun],
                 refine: Literal["linear", "sinc"], revolutions: int) -> list[BenchRow]:
    offsets, drifts, limit_offsets, limit_drifts = [], [], [], []
    walls, cpus = [], []
    sigma = _edge_sigma_s(label)
    for run in runs:
        result = measure(partial(_fit, run, refine), 1)
        clock = result.value
        walls.append(result.time_s)
        cpus.append(result.cpu_s)
        offsets.append(clock.offsets_s[0] - run.offset_s)
        drifts.append(clock.drift - run.drift)
        limit_offset, limit_drift = _limits(run, sigma)
        limit_offsets.append(limit_offset)
        limit_drifts.append(limit_drift)
    out = []
    for metric, unit, errors, limits in (("offset", "us", offsets, limit_offsets),
                                         ("drift", "ppm", drifts, limit_drifts)):
        limit = _rms(limits) * 1e6
        out.append(BenchRow(stage="alignment", case=case, choice=label,
                            metric=f"{metric} error rms over {len(runs)} runs", unit=unit,
                            error=_rms(errors) * 1e6, bound=4 * limit, limit=limit,
                            time_s=float(np.median(walls)), cpu_s=float(np.median(cpus)),
                            n=revolutions))
    return out
