"""What the campaign page's figure of metrics against running speed shows, as plain arrays.

:func:`speed_panels` takes the campaign's long-form metrics table
(:func:`rigval.validation.campaign.report.metrics_table`) apart into one
:class:`SpeedPanel` per metric; :mod:`rigval.validation.campaign.speed_plot` draws them. The
panels hold numbers, texts and numpy arrays only, so that a drawer forked before this process
imported pandas and the pipeline (:mod:`rigval.validation.report.drawing`; ``rigval demo``'s)
draws them with numpy and matplotlib alone. This module imports numpy alone.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["MAX_PLOTTED", "SpeedPanel", "SpeedSeries", "speed_panels"]

#: Most metrics the figure shows (those with thresholds first).
MAX_PLOTTED = 6


@dataclass(frozen=True)
class SpeedSeries:
    """One comparison's runs in one panel, by running speed.

    Attributes
    ----------
    comparison : str
        The comparison.
    speed, value : numpy.ndarray
        Each run's running speed (rev/s) and the metric's value, by increasing speed.
    repeated : bool
        Several runs share a speed: markers only, no line.
    missed_speed, missed_value : numpy.ndarray
        The runs that missed the metric's threshold.
    """

    comparison: str
    speed: np.ndarray
    value: np.ndarray
    repeated: bool
    missed_speed: np.ndarray
    missed_value: np.ndarray


@dataclass(frozen=True)
class SpeedPanel:
    """One metric's panel: its title, the threshold line and one series per comparison.

    Attributes
    ----------
    title : str
        The metric, with its threshold when every comparison shares one.
    threshold : float or None
        The shared threshold's value, drawn as a dashed line.
    series : tuple of SpeedSeries
        One per comparison, in the table's order.
    """

    title: str
    threshold: float | None
    series: tuple[SpeedSeries, ...]


def speed_panels(table: pd.DataFrame, metrics: Sequence[str] | None = None, *,
                 title_chars: int = 36) -> tuple[SpeedPanel, ...]:
    """Return the panels of the metrics' values against running speed.

    Parameters
    ----------
    table : pandas.DataFrame
        Long-form metrics (:func:`rigval.validation.campaign.report.metrics_table`); only the
        ``"model"`` rows with a value are shown.
    metrics : sequence of str, optional
        Metrics to show; default those with a threshold in some run, then the others, at most
        :data:`MAX_PLOTTED`.
    title_chars : int
        Longest title on one line; a longer one puts its threshold on a second line.
    """
    table = table[(table["row"] == "model") & table["value"].notna()]
    if metrics is None:
        with_threshold = table.loc[table["threshold"].notna(), "metric"].unique().tolist()
        others = [m for m in table["metric"].unique() if m not in with_threshold]
        metrics = (with_threshold + others)[:MAX_PLOTTED]
    panels = []
    for metric in metrics:
        part = table[table["metric"] == metric]
        series = []
        for comparison, group in part.groupby("comparison", sort=False):
            group = group.sort_values("speed_rev_s")
            missed = group[group["passed"].map(lambda p: p is False or p is np.False_)]
            series.append(SpeedSeries(
                str(comparison), group["speed_rev_s"].to_numpy(), group["value"].to_numpy(),
                bool(group["speed_rev_s"].duplicated().any()),
                missed["speed_rev_s"].to_numpy(), missed["value"].to_numpy()))
        thresholds = part["threshold"].dropna().unique()
        title, line = str(metric), None
        if len(thresholds) == 1:
            title = f"{metric} (pass: {thresholds[0]})"
            if len(title) > title_chars:
                title = f"{metric}\n(pass: {thresholds[0]})"
            limit = re.fullmatch(r"\s*[<>]=?\s*([-+0-9.eE]+)\s*", str(thresholds[0]))
            if limit:
                line = float(limit.group(1))
        panels.append(SpeedPanel(title, line, tuple(series)))
    return tuple(panels)
