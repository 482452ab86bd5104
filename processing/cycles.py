"""Cycle statistics over the ``cycle`` dim of angle-domain data, and outlier cycles.

Synchronous averaging: per angle, the mean, standard deviation (ddof 1), 5th and 95th
percentiles, minimum, maximum and the number of cycles that contributed. Non-synchronous content
falls as 1/sqrt(n) in the mean; the spread is the cycle-to-cycle scatter band. Outlier cycles are
those whose rms distance to the median cycle exceeds a threshold in robust standard deviations
(median absolute deviation scaled by 1.4826) of that distance over all cycles.
"""

from __future__ import annotations

import logging
import warnings

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from rigval.acquisition.errors import DataError
from rigval.acquisition.schema import append_history

__all__ = ["STATISTICS", "cycle_statistics", "outlier_cycles", "statistics_array"]

logger = logging.getLogger(__name__)

#: Order of the ``statistic`` coordinate.
STATISTICS = ("mean", "std", "p5", "p95", "min", "max", "n")


def statistics_array(cycles: ArrayLike) -> NDArray[np.float64]:
    """Return the cycle statistics of a (n_cycles, n_angles) array, ignoring NaN.

    Parameters
    ----------
    cycles : array_like
        Values per cycle and angle (any unit); NaN for missing points.

    Returns
    -------
    numpy.ndarray
        Shape (7, n_angles) in the order of :data:`STATISTICS`; ``n`` is the count of finite
        values, ``std`` is NaN where fewer than 2 cycles contributed.
    """
    y = np.asarray(cycles, dtype=np.float64)
    if y.ndim != 2:
        raise DataError(f"cycle statistics need a (cycle, angle) array, got shape {y.shape}")
    n = np.sum(np.isfinite(y), axis=0)
    out = np.full((len(STATISTICS), y.shape[1]), np.nan)
    out[6] = n
    some = n > 0
    if not some.any():
        return out
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)      # all-NaN columns stay NaN
        out[0, some] = np.nanmean(y[:, some], axis=0)
        two = n >= 2
        out[1, two] = np.nanstd(y[:, two], axis=0, ddof=1)
        out[2, some], out[3, some] = np.nanpercentile(y[:, some], [5, 95], axis=0)
        out[4, some] = np.nanmin(y[:, some], axis=0)
        out[5, some] = np.nanmax(y[:, some], axis=0)
    return out


def outlier_cycles(cycles: ArrayLike, threshold: float = 3.5) -> NDArray[np.bool_]:
    """Flag cycles far from the median cycle.

    Parameters
    ----------
    cycles : array_like
        Values, shape (n_cycles, n_angles).
    threshold : float, default 3.5
        Robust standard deviations of the distance beyond which a cycle is an outlier.

    Returns
    -------
    numpy.ndarray of bool
        True for outlier cycles (and for cycles without any finite value).
    """
    y = np.asarray(cycles, dtype=np.float64)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        median = np.nanmedian(y, axis=0)
        distance = np.sqrt(np.nanmean((y - median) ** 2, axis=1))
    finite = np.isfinite(distance)
    if finite.sum() < 3:
        return ~finite
    centre = np.median(distance[finite])
    spread = 1.4826 * np.median(np.abs(distance[finite] - centre))
    if spread == 0:
        return ~finite | (distance > centre)
    return ~finite | ((distance - centre) / spread > threshold)


def cycle_statistics(angle_data: xr.Dataset, *, exclude_invalid: bool = True,
                     exclude_outliers: bool = False, threshold: float = 3.5) -> xr.Dataset:
    """Return cycle statistics of every channel of an angle-domain Dataset.

    Parameters
    ----------
    angle_data : xarray.Dataset
        Output of :func:`~rigval.processing.angle.angle_domain` (dims ``cycle``, ``angle``).
    exclude_invalid : bool, default True
        Leave out cycles with ``cycle_valid`` False.
    exclude_outliers : bool, default False
        Also leave out, per channel, cycles flagged by :func:`outlier_cycles`.
    threshold : float, default 3.5
        Outlier threshold in robust standard deviations.

    Returns
    -------
    xarray.Dataset
        Per channel a variable with dims ``statistic`` (mean, std, p5, p95, min, max, n) and
        ``angle``, with the channel's attributes plus ``cycles_used``; per channel also
        ``<name>_outlier`` (cycle) with the outlier flags.
    """
    use = np.ones(angle_data.sizes["cycle"], dtype=bool)
    if exclude_invalid and "cycle_valid" in angle_data:
        use &= angle_data["cycle_valid"].to_numpy()
    data_vars = {}
    for name, var in angle_data.data_vars.items():
        if var.dims != ("cycle", "angle"):
            continue
        values = var.to_numpy()
        outliers = outlier_cycles(values, threshold)
        chosen = use & ~outliers if exclude_outliers else use
        attrs = {**var.attrs, "cycles_used": int(chosen.sum())}
        data_vars[name] = (("statistic", "angle"), statistics_array(values[chosen]), attrs)
        data_vars[f"{name}_outlier"] = ("cycle", outliers, {
            "long_name": f"cycle of {name} is an outlier", "units": "1",
            "threshold_robust_sigma": threshold})
    out = xr.Dataset(data_vars, coords={"statistic": ("statistic", list(STATISTICS)),
                                        "angle": angle_data["angle"],
                                        "cycle": angle_data["cycle"]},
                     attrs=dict(angle_data.attrs))
    append_history(out, f"processing.cycle_statistics {int(use.sum())} cycles, outliers "
                        f"{'excluded' if exclude_outliers else 'kept'}")
    return out
