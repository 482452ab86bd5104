"""The campaign page's figure of metrics against running speed (numpy and matplotlib alone).

Draws the panels of :mod:`rigval.validation.campaign.speed_panels`.
"""

from __future__ import annotations

from collections.abc import Sequence

from matplotlib.figure import Figure

from rigval.validation.campaign.speed_panels import SpeedPanel
from rigval.validation.report.plots import PLAIN_TITLE_PAD

__all__ = ["plot_speed_panels"]

#: The figure's fixed margins in inches (a layout engine would draw it twice): left, bottom,
#: above each row (a title of up to two lines), and the legend's column at the right.
_LEFT_IN, _BOTTOM_IN, _TITLE_IN, _LEGEND_IN = 0.7, 0.55, 0.55, 1.5


def plot_speed_panels(panels: Sequence[SpeedPanel], *, ax_width: float = 3.6) -> Figure:
    """Plot metrics against running speed, one panel per metric and one line per comparison.

    Parameters
    ----------
    panels : sequence of SpeedPanel
        The metrics (:func:`~rigval.validation.campaign.speed_panels.speed_panels`).
    ax_width : float
        Width of one panel in inches.

    Returns
    -------
    matplotlib.figure.Figure
        Markers show runs, joined by lines unless several runs share a speed; a hollow red ring
        marks a run that missed that metric's threshold, a dashed line shows the threshold
        when all comparisons share one.
    """
    n = max(len(panels), 1)
    columns = min(n, 3)
    rows = -(-n // columns)
    width, height = ax_width * columns + _LEGEND_IN, 2.8 * rows + _TITLE_IN
    fig = Figure(figsize=(width, height))
    fig.subplots_adjust(left=_LEFT_IN / width, right=1.0 - _LEGEND_IN / width,
                        bottom=_BOTTOM_IN / height, top=1.0 - _TITLE_IN / height,
                        wspace=0.3, hspace=0.55)
    axes = fig.subplots(rows, columns, squeeze=False).ravel()
    for ax in axes[len(panels):]:
        ax.set_visible(False)
    for ax, panel in zip(axes, panels, strict=False):
        for series in panel.series:
            ax.plot(series.speed, series.value, marker="o", label=series.comparison,
                    linestyle="none" if series.repeated else "-",
                    alpha=0.7 if series.repeated else 1.0)
            ax.plot(series.missed_speed, series.missed_value, linestyle="none", marker="o",
                    markersize=11, markerfacecolor="none", color="tab:red")  # keeps the cycle
        if panel.threshold is not None:
            ax.axhline(panel.threshold, color="0.4", linestyle="--", linewidth=1)
        ax.set_title(panel.title, fontsize="medium", y=1.0, pad=PLAIN_TITLE_PAD)
        ax.set_xlabel("running speed [rev/s]")
        ax.grid(alpha=0.3)
    if len(panels):
        handles, labels = axes[0].get_legend_handles_labels()
        fig.legend(handles, labels, loc="upper left", fontsize="small", title="comparison",
                   title_fontsize="small",
                   bbox_to_anchor=(1.0 - (_LEGEND_IN - 0.15) / width, 1.0 - _TITLE_IN / height))
    return fig
