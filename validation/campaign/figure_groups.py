"""The figure groups a drawer draws for the campaign page, by name.

As :mod:`rigval.validation.report.figure_groups` for a run's page: this process imports this
module to name the function, and a drawer calls it on the figure's plain inputs
(:mod:`rigval.validation.campaign.speed_panels`); the plotting module, which imports
matplotlib, is imported by the function.
"""

from __future__ import annotations

from collections.abc import Sequence

from rigval.validation.campaign.speed_panels import SpeedPanel
from rigval.validation.report.drawing import draw_texts

__all__ = ["SPEED_GROUP", "draw_speed_figure"]

#: The group of the figure of metrics against running speed (:func:`draw_speed_figure`).
SPEED_GROUP = "metrics against speed"


def draw_speed_figure(panels: Sequence[SpeedPanel], names: Sequence[str]) -> list[list[str]]:
    """Return the SVG text of the figure of ``panels`` (a drawer's work; ``names``: its group)."""
    from rigval.validation.campaign.speed_plot import plot_speed_panels

    return [draw_texts([plot_speed_panels(panels)])]
