"""The compare stage of a run: each comparison's model scored against its measured revolutions.

:func:`score_comparisons` pairs each comparison's measured revolutions with its model
(:func:`pair`: the revolutions without gaps, their mean, the model scaled and offset as the
scene asks), rates the periodic ISO/TS 18571 ratings of all of them in shared DTW sweeps
(:func:`rigval.validation.metrics.compare.periodic_ratings`), scores the model against the mean
(with V&V 20 on the peak and RMS features), every revolution against the mean (the baseline) and
the scene's thresholds, and states the common gain across them. The baseline depends on the
measurement alone: validating the same measurement against another mechanism
(:meth:`rigval.validation.pipeline.Measurement.against`) takes it from the first result and
rates the models alone.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from rigval.acquisition.errors import DataError
from rigval.validation.metrics.compare import (
    IsoScores,
    baseline,
    check_thresholds,
    compare,
    periodic_ratings,
)
from rigval.validation.metrics.iso18571 import iso18571_periodic_sets
from rigval.validation.results import ComparisonResult
from rigval.validation.scene_types import ComparisonSpec, Scene
from rigval.validation.verdict import with_common_gain

__all__ = ["Pair", "Scored", "pair", "score_comparisons"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class Pair:
    """A comparison's measured side and model, as its metrics take them.

    Attributes
    ----------
    whole : numpy.ndarray
        The revolutions without gaps, ``(n_cycles, n)``, the signal's unit (read only: the
        resampled cycles themselves when none has a gap).
    mean : numpy.ndarray
        Their mean over one revolution.
    model : numpy.ndarray
        The model on the same grid, scaled and its offset added.
    offset : float
        The offset added to the model (0 unless the scene removes it).
    """

    whole: np.ndarray
    mean: np.ndarray
    model: np.ndarray
    offset: float


def pair(comparison: ComparisonSpec, cycles: np.ndarray, model: np.ndarray) -> Pair:
    """Return the whole revolutions, their mean, the model scaled and offset as the scene asks.

    Raises
    ------
    DataError
        When fewer than 2 revolutions are without gaps.
    """
    finite = np.all(np.isfinite(cycles), axis=1)
    # every revolution whole (no gaps): the cycles themselves, not their copy (memory); read
    # only either way, as the scores take them
    whole = cycles.view() if finite.all() else cycles[finite]
    whole.flags.writeable = False
    if whole.shape[0] < 2:
        raise DataError(f"{comparison.name}: only {whole.shape[0]} whole revolutions without "
                        "gaps", where={"key": comparison.key, "channel": str(comparison.measured)},
                        hint="record longer or check the stream's gaps")
    mean = whole.mean(axis=0)
    model = model * comparison.scale
    offset = float(mean.mean() - model.mean()) if comparison.remove_offset else 0.0
    return Pair(whole, mean, model + offset, offset)


@dataclass(frozen=True)
class Scored:
    """What the compare stage takes of one comparison besides the scene.

    Attributes
    ----------
    pair : Pair
        Its measured revolutions and model (:func:`pair`).
    units, long_name : str
        The measured signal's unit and long name.
    u_num : float
        The model's numerical uncertainty, the signal's unit (V&V 20).
    carried : mapping of str to float
        The uncertainties carried from alignment and drives (``u_time`` s, ``speed`` rad/s,
        ``u_drive_angle`` rad; :func:`rigval.validation.metrics.vv20.vv20_curve`).
    """

    pair: Pair
    units: str
    long_name: str
    u_num: float
    carried: Mapping[str, float]


def score_comparisons(scene: Scene, scored: Mapping[str, Scored], angle: np.ndarray,
                      like: tuple[ComparisonResult, ...] | None = None
                      ) -> tuple[ComparisonResult, ...]:
    """Score every comparison of ``scene``; the common-gain statement across them.

    Parameters
    ----------
    scene : Scene
        The scene (its comparisons, metrics and thresholds).
    scored : mapping of str to Scored
        Per comparison name, what it is scored on.
    angle : numpy.ndarray
        The grid's angles over one revolution, rad.
    like : tuple of ComparisonResult, optional
        The results of the same measurement against another mechanism: their baselines (and
        the revolutions' ISO ratings in them) are this one's, so only the models are rated.

    Returns
    -------
    tuple of ComparisonResult
        In the scene's order.
    """
    rated = [c.name for c in scene.comparisons if "iso18571_periodic" in c.metrics]
    pairs = [scored[name].pair for name in rated]
    if like is None:
        ratings = dict(zip(rated, periodic_ratings([(p.mean, p.model, p.whole) for p in pairs]),
                           strict=True))
        models = {name: model for name, (model, _) in ratings.items()}
        bases = {c.name: _baseline(c, scored[c.name].pair, angle,
                                   ratings[c.name][1] if c.name in ratings else None)
                 for c in scene.comparisons}
    else:
        rows = iso18571_periodic_sets([(p.mean, p.model[np.newaxis]) for p in pairs])
        models = {name: row[0] for name, row in zip(rated, rows, strict=True)}
        bases = {result.name: result.baseline for result in like}
    return with_common_gain(scene, [_score(c, scored[c.name], angle, models.get(c.name),
                                           bases[c.name]) for c in scene.comparisons])


def _baseline(comparison: ComparisonSpec, found: Pair, angle: np.ndarray,
              iso: list[IsoScores] | None) -> Mapping[str, Mapping[str, float]]:
    """Score every revolution against the mean: the median and the worst of each score.

    ``iso``: the revolutions' periodic ISO ratings, rated beforehand with the model's.
    """
    scores = baseline(found.whole, found.mean, angle=angle, metrics=comparison.metrics,
                      normaliser=comparison.nrmse_normaliser, iso=iso)
    return {"median": scores.median, "worst": scores.worst}


def _score(comparison: ComparisonSpec, scored: Scored, angle: np.ndarray,
           iso: IsoScores | None, base: Mapping[str, Mapping[str, float]]
           ) -> ComparisonResult:
    """Score the model against the measured mean and the thresholds, with the given baseline."""
    found = scored.pair
    scores = compare(found.mean, found.model, angle, metrics=(*comparison.metrics, "vv20"),
                     normaliser=comparison.nrmse_normaliser, cycles=found.whole,
                     uncertainty={"u_num": scored.u_num, **dict(scored.carried),
                                  **comparison.uncertainty},
                     iso=iso)
    checks = check_thresholds(scores, comparison.thresholds,
                              key_path=f"{comparison.key}.thresholds")
    return ComparisonResult(spec=comparison, units=scored.units, long_name=scored.long_name,
                            angle=angle, cycles=found.whole, model=found.model,
                            offset=found.offset, scores=scores, baseline=dict(base),
                            checks=tuple(checks))
