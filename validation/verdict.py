"""The ASME V&V 20 verdict of a validation: one statement per comparison and one per run.

Every comparison carries :class:`~rigval.validation.metrics.vv20.VV20Curve` scores (``vv20.curve``):
the model error ``E`` of the whole curve over phi_F against its validation uncertainty ``u_val``.
This module supplies the parts of ``u_val`` that the pipeline carries from earlier stages
(:func:`carried_uncertainty`), adds the statement on the gains of comparisons whose sensors share
a calibration error (:func:`with_common_gain`) and turns the scores into the headline every
report, console summary, ``metrics.json`` and campaign summary starts with (:func:`run_verdict`).
How ``u_val`` is built and what it can detect: ``docs/metrics.md``.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Mapping, Sequence
from typing import Any

from rigval.acquisition.errors import ConfigError
from rigval.processing.alignment_summary import StreamAlignment
from rigval.processing.health import Finding
from rigval.validation.health import comparison_health
from rigval.validation.metrics.thresholds import ThresholdCheck
from rigval.validation.metrics.vv20 import CURVE_PARTS, common_gain, error_ratio
from rigval.validation.results import ComparisonResult, ValidationResult
from rigval.validation.scene_types import Scene

__all__ = ["COMMON_GAIN_SCORE", "FAMILY_LEVEL", "carried_uncertainty", "comparison_verdict",
           "failure_reasons", "family_k", "run_verdict", "with_common_gain"]

#: Probability that no statement of a run that has no model error detects one (the run's
#: family of statements together, see :func:`family_k`).
FAMILY_LEVEL = 0.95

#: The score of the common-gain statement that gets a threshold check, ``|E| / u_val <= k``.
COMMON_GAIN_SCORE = "vv20.common_gain.normalised_error"

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


def with_common_gain(scene: Scene, comparisons: Sequence[ComparisonResult]
                     ) -> tuple[ComparisonResult, ...]:
    """Add the common-gain statement to comparisons whose sensors share a calibration error.

    Comparisons stating ``uncertainty.u_measurement_rel_common`` are grouped by the sensor kind
    of their measured channels (all channels of a summed comparison must be of one kind); in a
    group of two or more, each comparison's fitted gain (``vv20.curve.gain``) is compared with
    the group's common gain (:func:`rigval.validation.metrics.vv20.common_gain`). Each gets the
    scores ``vv20.common_gain.*`` and a threshold check ``vv20.common_gain.normalised_error``
    ``abs <= k`` (the statement at its coverage factor).

    Parameters
    ----------
    scene : Scene
        The scene (channels' sensor kinds).
    comparisons : sequence of ComparisonResult
        The run's comparisons with their ``vv20.curve`` scores.

    Returns
    -------
    tuple of ComparisonResult
        The comparisons, those of a group with the added scores and check.

    Raises
    ------
    ConfigError
        When two comparisons of a group share a channel (their gains are not independent), a
        summed comparison mixes sensor kinds, or a group has a single comparison.
    """
    groups: dict[str, list[ComparisonResult]] = {}
    for comparison in comparisons:
        spec = comparison.spec
        if not spec.uncertainty.get("u_measurement_rel_common"):
            continue
        kinds = {scene.channel(ref).sensor for _, ref in spec.terms}
        if len(kinds) != 1:
            raise ConfigError(f"{spec.name}: a common calibration gain needs one sensor kind, "
                              f"got {', '.join(sorted(kinds))}",
                              where={"key": f"{spec.key}.uncertainty.u_measurement_rel_common"},
                              hint="remove u_measurement_rel_common from this comparison")
        groups.setdefault(kinds.pop(), []).append(comparison)
    added: dict[str, ComparisonResult] = {}
    for kind, members in groups.items():
        _check_group(kind, members)
        statements = common_gain({c.name: (float(c.scores["vv20.curve.gain"]),
                                           float(c.scores["vv20.curve.u_gain_own"]))
                                  for c in members},
                                 k=float(members[0].scores["vv20.curve.k"]))
        for comparison in members:
            statement = statements[comparison.name]
            scores = dict(comparison.scores) | {f"vv20.common_gain.{name}": value for name, value
                                                in statement.as_dict().items()}
            check = ThresholdCheck(COMMON_GAIN_SCORE, statement.normalised_error,
                                   f"abs <= {statement.k:g}", not statement.detected)
            added[comparison.name] = dataclasses.replace(
                comparison, scores=scores, checks=(*comparison.checks, check))
            logger.info("%s: gain %+.3g %% against the common %+.3g %% of %s (u %.3g %%)",
                        comparison.name, 100 * statement.gain, 100 * statement.group_gain, kind,
                        100 * statement.u_val)
    return tuple(added.get(c.name, c) for c in comparisons)


def _check_group(kind: str, members: Sequence[ComparisonResult]) -> None:
    """Refuse a group of one and groups whose comparisons share a channel."""
    first = members[0].spec
    key = f"{first.key}.uncertainty.u_measurement_rel_common"
    if len(members) < 2:
        raise ConfigError(f"{first.name} is the only {kind} comparison stating "
                          "u_measurement_rel_common: a common gain needs two or more",
                          where={"key": key},
                          hint="state it on the other comparisons of that sensor kind, or "
                               "remove it")
    seen: dict[str, str] = {}
    for comparison in members:
        for _, ref in comparison.spec.terms:
            other = seen.setdefault(str(ref), comparison.name)
            if other != comparison.name:
                raise ConfigError(f"{other} and {comparison.name} both measure {ref}: their gains "
                                  "are not independent", where={"key": key},
                                  hint="state u_measurement_rel_common on comparisons with "
                                       "disjoint channels (e.g. the summed drive torques only)")


def failure_reasons(comparison: ComparisonResult) -> list[str]:
    """Return one text per failed threshold check: the score, its value and what it needs.

    E.g. ``"nrmse 0.01503 (needs <= 0.01)"``; empty when every check passed. The console
    summary and the report's list of failures print these.
    """
    return [f"{check.metric} {check.value:.4g} (needs {check.threshold})"
            for check in comparison.checks if not check.passed]


def comparison_verdict(comparison: ComparisonResult, health: Sequence[Finding] = ()
                       ) -> dict[str, Any]:
    """Return the V&V 20 curve verdict of one comparison as plain values.

    Parameters
    ----------
    comparison : ComparisonResult
        With ``vv20.curve.*`` scores.
    health : sequence of Finding, optional
        Sensor health findings on the comparison's channels
        (:func:`rigval.validation.health.comparison_health`).

    Returns
    -------
    dict
        ``comparison``, ``detected`` (bool: by the curve or the common-gain statement), ``E``,
        ``u_val``, ``k``, ``ratio`` (the larger of the curve's ``E / (k u_val)`` and the
        common gain's ``|E| / (k u_val)``), ``units``, ``dominant`` (largest part of the curve's
        ``u_val``), ``parts`` (name -> value, signal units) and ``common_gain`` (None, or the
        comparison's ``gain``, the group's ``group_gain``, ``u_val``, ``ratio``, ``detected``
        and ``group``), ``health`` (the findings' verdict-line texts) and ``trusted`` (False
        when a finding can change the verdict: clipping, a flat line, spikes, count errors).
    """
    scores = comparison.scores
    error, u_val, k = (float(scores["vv20.curve.error"]), float(scores["vv20.curve.u_val"]),
                       float(scores["vv20.curve.k"]))
    ratio = error_ratio(error, k * u_val)
    detected = bool(scores["vv20.curve.detected"])
    gain = None
    if "vv20.common_gain.error" in scores:
        gain = {name: scores[f"vv20.common_gain.{name}"]
                for name in ("gain", "group_gain", "u_val", "detected", "group")}
        gain["ratio"] = error_ratio(abs(float(scores["vv20.common_gain.error"])),
                                    float(scores["vv20.common_gain.k"]) * float(gain["u_val"]))
        detected = detected or bool(gain["detected"])
        ratio = max(ratio, gain["ratio"])
    return {"comparison": comparison.name, "detected": detected,
            "E": error, "u_val": u_val, "k": k, "ratio": ratio, "units": comparison.units,
            "dominant": str(scores["vv20.curve.dominant"]),
            "parts": {part: float(scores[f"vv20.curve.{part}"]) for part in CURVE_PARTS},
            "common_gain": gain, "health": [f.line() for f in health],
            "trusted": all(f.trusted for f in health)}


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
        ``worst`` (the comparison with the largest ``E / (k u_val)``), ``comparisons`` (one
        :func:`comparison_verdict` each, comparisons without ``vv20.curve`` scores left out)
        ``why`` (per comparison with a detected error, its most likely cause in words from
        ``result.diagnosis``; the worst one's ends the statement), ``modes`` (per comparison
        without a detected error whose residual is mostly a found structural mode, the mode in
        words; named at the statement's end) and ``family``: the run's
        statements taken together (``k`` from :func:`family_k` for their number ``tests``,
        ``detected`` and ``detected_on`` at that ``k``).
        The ISO rating is the similarity score beside it.
    """
    rows = [comparison_verdict(c, comparison_health(c.spec, result.health))
            for c in result.comparisons if "vv20.curve.error" in c.scores]
    if not rows:
        return {"detected": False, "statement": "V&V 20 not computed (no vv20.curve scores)",
                "detected_on": [], "worst": None, "comparisons": []}
    detected = [row for row in rows if row["detected"]]
    worst = max(rows, key=lambda row: row["ratio"])
    causes = result.diagnosis.causes if result.diagnosis is not None else {}
    why = {row["comparison"]: causes[row["comparison"]].explanation for row in detected
           if row["comparison"] in causes}
    tests = len(rows) + sum(row["common_gain"] is not None for row in rows)
    k_family = family_k(tests)
    # each row's ratio is |E| / (k u_val) at its own k: at k_family it is ratio k / k_family
    on = [row["comparison"] for row in rows if row["ratio"] * row["k"] > k_family]
    family = {"k": k_family, "tests": tests, "detected": bool(on), "detected_on": on}
    statement = _statement(rows, detected, worst)
    statement += (f"; the {tests} statements together at {100 * FAMILY_LEVEL:g} % (k = "
                  f"{k_family:.2f}): " + (f"detected on {', '.join(on)}" if on
                                         else "not detected"))
    if worst["comparison"] in why:
        statement += f"; why {worst['comparison']}: {why[worst['comparison']]}"
    modes = {name: c for name, c in causes.items() if name not in why and c.mode_holds_residual}
    if modes:
        statement += "; a structural mode holds most of the residual in " + ", ".join(
            f"{name} ({100 * c.residual_share:.0f} % at "
            f"{c.meaning.removeprefix('structural mode at ')})" for name, c in modes.items())
    return {"detected": bool(detected), "statement": statement,
            "detected_on": [row["comparison"] for row in detected], "worst": worst["comparison"],
            "comparisons": rows, "why": why,
            "modes": {name: c.phrase for name, c in modes.items()}, "family": family}


def family_k(tests: int, level: float = FAMILY_LEVEL) -> float:
    """Return the coverage factor at which ``tests`` statements together hold at ``level``.

    Each comparison's statement ``|E| > k u_val`` with ``k = 2`` is wrong about 4.6 % of the
    time when its error is a single Gaussian part at its stated size (a calibration error drawn
    from its stated uncertainty); a run of ``m`` comparisons says "detected" somewhere far more
    often. Sidak's correction gives each statement the level ``level^(1/m)``; for independent
    or positively dependent statements the family is then right at ``level``.

    Parameters
    ----------
    tests : int
        Statements in the family (>= 1).
    level : float
        Probability that none of them detects an error that is not there.

    Returns
    -------
    float
        ``k`` with ``P(|z| > k) = 1 - level^(1/tests)`` for a standard normal ``z``.
    """
    import scipy.special

    each = 1.0 - level ** (1.0 / max(tests, 1))
    return float(-scipy.special.ndtri(each / 2.0))  # the normal's upper quantile (norm.isf)


def _statement(rows: list[Mapping[str, Any]], detected: list[Mapping[str, Any]],
               worst: Mapping[str, Any]) -> str:
    """One line: the verdict, where, and the numbers of the decisive comparison."""
    gain = worst["common_gain"]
    if gain is not None and gain["ratio"] >= error_ratio(worst["E"], worst["k"] * worst["u_val"]):
        numbers = (f"{worst['comparison']}: gain {100 * gain['gain']:+.3g} % against the common "
                   f"{100 * gain['group_gain']:+.3g} % of {gain['group']}, u_val = "
                   f"{100 * gain['u_val']:.3g} %, k = {worst['k']:g}, |E|/(k u_val) = "
                   f"{gain['ratio']:.2f}")
    else:
        numbers = (f"{worst['comparison']}: E = {worst['E']:.4g} {worst['units']}, u_val = "
                   f"{worst['u_val']:.4g} {worst['units']}, k = {worst['k']:g}, |E|/(k u_val) = "
                   f"{error_ratio(worst['E'], worst['k'] * worst['u_val']):.2f}; largest part "
                   f"of u_val: {worst['dominant']}")
    # a comparison whose channel has a fault that can change its verdict says so
    faults = "".join(f"; {row['comparison']}: {line}" for row in rows if not row["trusted"]
                     for line in row["health"])
    if detected:
        names = ", ".join(row["comparison"] for row in detected)
        return f"Model error detected (|E| > k u_val) on {names}; worst {numbers}{faults}"
    return (f"Model error not detected (|E| <= k u_val) on any of {len(rows)} comparisons; "
            f"closest {numbers}{faults}")
