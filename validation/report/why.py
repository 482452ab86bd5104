"""The report's "Why" section: each comparison's most likely cause, its residual's orders, pairs.

Written from ``result.diagnosis`` (:mod:`rigval.validation.diagnosis.explain`): the attribution
table (cause, size with its standard uncertainty, evidence weight, the other class's best, a
cause the data cannot tell apart), the sentence of each comparison whose residual is mostly a
found mode, the residual's order spectrum of each comparison with a detected error beside what
the chosen causes explain, and the ``[[symmetry]]`` pairs. The method: docs/diagnosis.md.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from rigval.validation.diagnosis.attribution import order_coefficients
from rigval.validation.diagnosis.explain import Diagnosis
from rigval.validation.report.drawing import Drawing
from rigval.validation.report.figure_groups import WHY_GROUP, draw_why_figures
from rigval.validation.report.figure_inputs import ResidualOrders
from rigval.validation.report.page import Page
from rigval.validation.results import ComparisonResult, ValidationResult

__all__ = ["residual_orders", "start_why_figures", "why_section"]

#: Orders shown in the residual's spectrum.
ORDERS = 20
#: Comparisons with a detected error drawn at most.
MAX_DRAWN = 6


def _size(statement: Any) -> str:
    if not statement.name or not math.isfinite(statement.value):
        return ""
    return statement.phrase


def _attribution_rows(diagnosis: Diagnosis) -> list[dict[str, Any]]:
    return [{"comparison": name, "verdict": "detected" if s.detected else "not detected",
             "most likely cause": s.name or "-", "chosen": "yes" if s.significant else "no",
             "size": _size(s), "weight": round(s.weight, 3),
             "other class's best": s.alternative or "-",
             "its weight": round(s.alternative_weight, 3),
             "cannot be told from": s.confusable_with or "-"}
            for name, s in diagnosis.causes.items()]


def _pair_rows(diagnosis: Diagnosis) -> list[dict[str, Any]]:
    rows = []
    for pair in diagnosis.pairs:
        a, b = pair.spec.comparisons
        row: dict[str, Any] = {"pair": pair.spec.name, "channels": f"{a}, {b}",
                               "stated calibration": f"{100 * pair.spec.u_measurement_rel:g} %"}
        if pair.shares is not None:
            s = pair.shares
            row.update({f"share of {a}": s.share, "95 % low": s.lower, "95 % high": s.upper,
                        "u scatter": s.u_scatter, "u calibration": s.u_calibration,
                        f"{b} lags (ms)": 1e3 * s.lag_s, "u lag (ms)": 1e3 * s.u_lag_s,
                        "beyond calibration": "yes" if s.asymmetric else "no"})
        elif pair.bending is not None:
            g = pair.bending
            row.update({"axial RMS": g.axial_rms, "bending RMS": g.bending_rms,
                        "bending / axial": g.ratio, "allowed (k u)": g.k * g.u_bending,
                        "bending": "yes" if g.bending else "no"})
        rows.append(row)
    return rows


def residual_orders(comparison: ComparisonResult, diagnosis: Diagnosis) -> ResidualOrders:
    """Return a comparison's residual per order and what its diagnosis's causes explain."""
    residual = comparison.cycles - comparison.model
    orders = min(ORDERS, comparison.angle.size // 2 - 1)
    per_cycle = order_coefficients(residual, orders, False).reshape(
        residual.shape[0], orders, 2)
    mean = per_cycle.mean(axis=0)
    return ResidualOrders(
        comparison.name, comparison.units, np.hypot(mean[:, 0], mean[:, 1]),
        2.0 * np.sqrt(per_cycle.var(axis=0, ddof=1).sum(axis=1) / residual.shape[0]),
        order_coefficients(diagnosis.explained[comparison.name], orders,
                           False).reshape(orders, 2),
        diagnosis.causes[comparison.name].name)


def _detected(result: ValidationResult) -> list[ComparisonResult]:
    """Return the comparisons with a detected model error (none without a diagnosis)."""
    diagnosis = result.diagnosis
    if diagnosis is None:
        return []
    return [c for c in result.comparisons if diagnosis.causes[c.name].detected]


def start_why_figures(drawing: Drawing, result: ValidationResult) -> None:
    """Have ``drawing`` draw the section's figure, if the section has one.

    Parameters
    ----------
    drawing : rigval.validation.report.drawing.Drawing
        The page's drawing; :func:`why_section` takes the figure from it.
    result : ValidationResult
        The validation, with ``diagnosis``.
    """
    drawn = _detected(result)[:MAX_DRAWN]
    if drawn and result.diagnosis is not None:
        rows = tuple(residual_orders(c, result.diagnosis) for c in drawn)
        drawing.start(draw_why_figures, rows, (WHY_GROUP,), len(rows))


def why_section(page: Page, result: ValidationResult, drawing: Drawing | None = None) -> None:
    """Add the "Why" section to a run's report (nothing without a diagnosis).

    Parameters
    ----------
    page : Page
        The report page.
    result : ValidationResult
        The validation, with ``diagnosis``.
    drawing : rigval.validation.report.drawing.Drawing, optional
        Where :func:`start_why_figures` started the section's figure; default: drawn here.
    """
    diagnosis = result.diagnosis
    if diagnosis is None:
        return
    page.section("Why")
    page.paragraph(
        "Each comparison's residual (measured minus model) regressed, order by order of the "
        "main shaft, on what each candidate cause would add: a gain (calibration, a pair's "
        "split), an offset, a time lag, each mechanism parameter (the identification "
        "regressor) and a found mode, with the stated calibration and alignment uncertainties "
        "as noise of known size. A cause is chosen when it explains more than chance among "
        "all candidates would (docs/diagnosis.md).")
    detected = _detected(result)
    for comparison in detected:
        page.paragraph(diagnosis.causes[comparison.name].sentence, css_class="bad")
    if not detected:
        page.paragraph("No model error detected: the candidates below are listed for the record.",
                       css_class="ok")
    for comparison in result.comparisons:
        statement = diagnosis.causes[comparison.name]
        if not statement.detected and statement.mode_holds_residual:
            page.paragraph(statement.sentence)
    page.table(_attribution_rows(diagnosis), caption="attribution: the most likely cause of "
               "each comparison's residual")
    if detected:
        if drawing is None:
            drawing = Drawing()
        if WHY_GROUP not in drawing:
            start_why_figures(drawing, result)
        page.figure(drawing.texts(WHY_GROUP)[0], caption="residual per order of the main shaft, "
                    "and what the chosen causes explain")
    if diagnosis.pairs:
        page.table(_pair_rows(diagnosis), caption="symmetry pairs ([[symmetry]])")
        for pair in diagnosis.pairs:
            page.paragraph(pair.sentence)
