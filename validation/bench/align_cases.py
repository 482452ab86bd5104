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
:func:`rigval.processing.clock_fit.estimate_clock`; the error is the rms over several random runs of
the fitted offset (at the second device's first sample) and drift minus the truth; the time is
the median over the runs (edge detection on both devices plus the fit). The limit
column is the least-squares error that the per-edge timing error alone leaves:
``sigma_edge * sqrt(1/N + mean(t)**2 / S_tt)`` for the offset and ``sigma_edge / sqrt(S_tt)`` for
the drift (``S_tt`` the sum of squared event-time deviations), with ``sigma_edge`` the combined
timing error of both devices: the quantisation of a sampled logic level (``dt / sqrt(12)``), the
interpolation error of linear edges (0.032 sample rms, docs/processing.md), the noise of sinc edges
(``sigma_noise / slope``, slope 0.9 per sample for a unit band-limited step). The baseline is no
alignment at all: the file start times (software time stamps, here 10 ms rms off) and no drift.
"""

from __future__ import annotations

import logging
import math
from functools import partial
from typing import Literal

import numpy as np

from rigval.processing import clock_fit, pulses
from rigval.sample_data.synthetic_signals import (
    FS_DEV,
    FS_REF,
    NOISE,
    Quality,
    TwoClockRun,
    two_clock_run,
)
from rigval.validation.bench.rows import BenchRow, measure, with_baseline

__all__ = ["alignment_rows"]

logger = logging.getLogger(__name__)

BASELINE = "no alignment: start times, no drift"


def _fit(run: TwoClockRun, refine: Literal["linear", "sinc"]) -> clock_fit.ClockModel:
    ref = pulses.detect_edges(run.x_ref, run.t_ref, refine=refine, holdoff_s=0.3)
    dev = pulses.detect_edges(run.x_dev, run.t_dev, refine=refine, holdoff_s=0.3)
    return clock_fit.estimate_clock(ref, dev, coarse_offset_s=run.coarse_offset_s,
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
