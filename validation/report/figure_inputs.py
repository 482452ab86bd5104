"""What a run report's figures show: small, whatever the record's length.

The figures are drawn in other processes (:mod:`rigval.validation.report.drawing`), to which
their inputs travel pickled: a comparison's figure draws at most :data:`MAX_DRAWN_CYCLES`
revolutions and statistics of all (:class:`ComparisonCurves`). This module imports no
matplotlib.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr

from rigval.validation.results import ComparisonResult

__all__ = ["MAX_DRAWN_CYCLES", "ComparisonCurves", "shown_points"]

#: Most revolutions a comparison's figure draws as light lines, evenly chosen; its band and mean
#: are of all of them. A four-hour record has 14,400: every one drawn made a page of 360 MB.
MAX_DRAWN_CYCLES = 100


@dataclass(frozen=True)
class ComparisonCurves:
    """What a comparison's figure shows: some of its revolutions and statistics of all of them.

    Small whatever the record's length, so that it travels to a drawing process quickly
    (:mod:`rigval.validation.report.drawing`). Build it with :meth:`of`.
    """

    name: str
    model_name: str
    units: str
    angle: np.ndarray
    drawn: np.ndarray
    n_cycles: int
    peak: float
    mean: np.ndarray
    low: np.ndarray
    high: np.ndarray
    model: np.ndarray
    offset: float

    @classmethod
    def of(cls, result: ComparisonResult, max_drawn: int = MAX_DRAWN_CYCLES
           ) -> ComparisonCurves:
        """Return the curves of a comparison, at most ``max_drawn`` revolutions drawn.

        Parameters
        ----------
        result : ComparisonResult
            The comparison.
        max_drawn : int
            Most revolutions drawn (evenly chosen, the first and the last among them).
        """
        count = result.cycles.shape[0]
        chosen = np.unique(np.round(np.linspace(0, count - 1, min(count, max_drawn))).astype(int))
        low, high = result.band
        return cls(result.name, str(result.spec.model), result.units, result.angle,
                   result.cycles[chosen], count, float(np.max(np.abs(result.cycles))),
                   result.mean, low, high, result.model, result.offset)


def shown_points(predictions: xr.Dataset) -> tuple[str, ...]:
    """Return the points whose kinematics the report shows (red in the sketch).

    Parameters
    ----------
    predictions : xarray.Dataset
        The run's predictions (:attr:`~rigval.validation.results.ValidationResult.predictions`).
    """
    return tuple(str(p) for p in predictions.coords.get("point", xr.DataArray([])).values)
