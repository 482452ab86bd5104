"""The figure groups a drawer draws: a run page's and the "Why" section's, by name.

A drawer (:mod:`rigval.validation.report.drawing`) is handed a module-level function and its
plain inputs (:mod:`rigval.validation.report.figure_inputs`); it returns the SVG texts of the
named groups. This process imports this module to name the functions, never to call them
(where no drawer is forked it calls them when the page asks): the plotting modules, which
import matplotlib, are imported by the functions, and a drawer has them already
(:data:`~rigval.validation.report.drawing.DRAWING_MODULES`).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING, Any

from rigval.validation.report.drawing import draw_texts
from rigval.validation.report.figure_inputs import ResidualOrders

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["RUN_GROUPS", "WHY_GROUP", "draw_figure_groups", "draw_why_figures"]

#: A run page's figure groups, in the page's order; what each one's data is:
#: ``comparisons`` a sequence of ComparisonCurves; ``pulse_edges``, ``clock_residuals`` and
#: ``stream_coverage`` a mapping of stream name to StreamCurves; ``sketch`` a MechanismSketch
#: and the points drawn red; ``points`` a sequence of PointCurves; ``support_forces``
#: SupportCurves or None.
RUN_GROUPS = ("comparisons", "pulse_edges", "clock_residuals", "stream_coverage", "sketch",
              "points", "support_forces")
#: The "Why" section's one figure group (:func:`draw_why_figures`).
WHY_GROUP = "why"


def _figures(name: str, data: Any) -> Iterable[Figure]:
    """Return the figures of the run page's group ``name``, drawn from its data."""
    from rigval.validation.report import plots
    from rigval.validation.report.sketch import draw_sketch

    if name == "comparisons":
        return plots.plot_comparisons(data)
    if name == "sketch":
        sketch, points = data
        return [draw_sketch(sketch, highlight=points)]
    if name == "points":
        return plots.plot_point_curves(data)
    if name == "support_forces":
        return [] if data is None else [plots.plot_support_forces(data)]
    draw = {"pulse_edges": plots.plot_pulse_edges, "clock_residuals": plots.plot_clock_residuals,
            "stream_coverage": plots.plot_stream_coverage}[name]
    return [draw(data)]


def draw_figure_groups(data: Sequence[Any], names: Sequence[str]) -> list[list[str]]:
    """Return the SVG texts of the named figure groups of a run's page (a drawer's work).

    Parameters
    ----------
    data : sequence
        Each group's data (see :data:`RUN_GROUPS`).
    names : sequence of str
        The groups' names (of :data:`RUN_GROUPS`).

    Returns
    -------
    list of list of str
        Per group, in the order of ``names``, the SVG text of each of its figures.
    """
    return [draw_texts(_figures(name, one)) for name, one in zip(names, data, strict=True)]


def draw_why_figures(rows: Sequence[ResidualOrders], names: Sequence[str]) -> list[list[str]]:
    """Return the SVG text of the "Why" section's one figure (``names``: its group)."""
    from rigval.validation.report.plots import plot_residual_orders

    return [draw_texts([plot_residual_orders(rows)])]
