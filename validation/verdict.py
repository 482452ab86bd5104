"""The ASME V&V 20 verdict of a validation: one statement per comparison and one per run.

Every comparison carries :class:`~rigval.validation.metrics.vv20.VV20Curve` scores (``vv20.curve``):
the model error ``E`` of the whole curve over phi_F against its validation uncertainty ``u_val``.
This module supplies the parts of ``u_val`` that the pipeline carries from earlier stages
(:func:`carried_uncertainty`) and turns the scores into the headline every report, console
summary, ``metrics.json`` and campaign summary starts with (:func:`run_verdict`). How ``u_val`` is
built and what it can detect: ``docs/metrics.md``.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping
from typing import Any

from rigval.validation.metrics.vv20 import CURVE_PARTS, error_ratio
from rigval.validation.results import ComparisonResult, StreamAlignment, ValidationResult
from rigval.validation.scene import Scene

__all__ = ["carried_uncertainty", "comparison_verdict", "run_verdict"]

logger = logging.getLogger(__name__)


def carried_uncertainty(scene: Scene, alignment: StreamAlignment, speed_rev_s: float
                        ) -> dict[str, float]:
    """Return the uncertainties a comparison inherits from the alignment and the drives.

    Parameters
    ----------
    scene : Scene
        The scene (its drive encoders).
    alignment : StreamAlignment
        The compared channel's stream: its clock-fit residual RMS is taken as the standard
        uncertainty of the channel's time on the reference clock (the reference stream: 0; a
        stream aligned by its start stamps: their 95 % bound / 1.96).
    speed_rev_s : float
        Mean main-shaft speed, rev/s.

    Returns
    -------
    dict of str to float
        ``u_time`` (s), ``speed`` (rad/s) and ``u_drive_angle`` (rad): with measured drives the
        quantisation of each driver's encoder, ``(2 pi / counts) / sqrt(12)``, combined in
        quadrature over the drivers; 0 with analytic drives.

    Notes
    -----
    The residual RMS is the scatter of single matched events about the fitted clock, larger
    than the fitted clock's own uncertainty; it is used as is, so that unmodelled delays of a
    few tenths of it are covered too.
    """
    u_time = 0.0 if alignment.is_reference else float(alignment.residual_rms_s)
    if not math.isfinite(u_time):
        u_time = 0.0
    if alignment.method == "stamps":
        # aligned by its start stamps alone: their stated bound (a 95 % half-width) is the
        # time uncertainty of every sample (docs/scene.md, alignment.pulses.<stream>.method)
        u_time = max(u_time, float(alignment.offset_u95_s) / 1.96)
    u_drive = 0.0
    if scene.model.drives == "measured":
        for driver in scene.model.drivers.values():
            counts = float(scene.channel(driver.encoder).params["counts_per_rev"])
            u_drive += (2.0 * math.pi / counts) ** 2 / 12.0
    return {"u_time": u_time, "speed": 2.0 * math.pi * float(speed_rev_s),
            "u_drive_angle": math.sqrt(u_drive)}


def comparison_verdict(comparison: ComparisonResult) -> dict[str, Any]:
    """Return the V&V 20 curve verdict of one comparison as plain values.

    Parameters
    ----------
    comparison : ComparisonResult
        With ``vv20.curve.*`` scores.

    Returns
    -------
    dict
        ``comparison``, ``detected`` (bool), ``E``, ``u_val``, ``k``, ``ratio`` (``E / (k
        u_val)``), ``units``, ``dominant`` (largest part) and ``parts`` (name -> value, signal
        units).
    """
    scores = comparison.scores
    error, u_val, k = (float(scores["vv20.curve.error"]), float(scores["vv20.curve.u_val"]),
                       float(scores["vv20.curve.k"]))
    ratio = error_ratio(error, k * u_val)
    return {"comparison": comparison.name, "detected": bool(scores["vv20.curve.detected"]),
            "E": error, "u_val": u_val, "k": k, "ratio": ratio, "units": comparison.units,
            "dominant": str(scores["vv20.curve.dominant"]),
            "parts": {part: float(scores[f"vv20.curve.{part}"]) for part in CURVE_PARTS}}


def run_verdict(result: ValidationResult) -> dict[str, Any]:
    """Return the run's verdict: detected on any comparison, with the numbers.

    Parameters
    ----------
    result : ValidationResult
        The validation.

    Returns
    -------
    dict
        ``detected`` (bool: a model error is detected on at least one comparison),
        ``statement`` (the headline, one line), ``detected_on`` (comparison names),
        ``worst`` (the comparison with the largest ``E / (k u_val)``) and ``comparisons`` (one
        :func:`comparison_verdict` each, comparisons without ``vv20.curve`` scores left out).
        The ISO rating is the similarity score beside it.
    """
    rows = [comparison_verdict(c) for c in result.comparisons
            if "vv20.curve.error" in c.scores]
    if not rows:
        return {"detected": False, "statement": "V&V 20 not computed (no vv20.curve scores)",
                "detected_on": [], "worst": None, "comparisons": []}
    detected = [row for row in rows if row["detected"]]
    worst = max(rows, key=lambda row: row["ratio"])
    return {"detected": bool(detected), "statement": _statement(rows, detected, worst),
            "detected_on": [row["comparison"] for row in detected], "worst": worst["comparison"],
            "comparisons": rows}


def _statement(rows: list[Mapping[str, Any]], detected: list[Mapping[str, Any]],
               worst: Mapping[str, Any]) -> str:
    """One line: the verdict, where, and the numbers of the decisive comparison."""
    numbers = (f"{worst['comparison']}: E = {worst['E']:.4g} {worst['units']}, u_val = "
               f"{worst['u_val']:.4g} {worst['units']}, k = {worst['k']:g}, |E|/(k u_val) = "
               f"{worst['ratio']:.2f}; largest part of u_val: {worst['dominant']}")
    if detected:
        names = ", ".join(row["comparison"] for row in detected)
        return f"Model error detected (|E| > k u_val) on {names}; worst {numbers}"
    return (f"Model error not detected (|E| <= k u_val) on any of {len(rows)} comparisons; "
            f"closest {numbers}")
