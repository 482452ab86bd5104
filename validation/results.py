"""What a validation produces: plain records that the report, the plots and the CLI read.

:func:`rigval.validation.pipeline.run_scene` fills these; nothing here computes physics. The records
hold numpy arrays on the phi_F grid (rad) and the metric scores by name, so that a report, a
notebook or a campaign can use them without re-running anything.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from rigval.model.mechanism_types import Mechanism
from rigval.processing.alignment_summary import StreamAlignment
from rigval.processing.health import Finding
from rigval.validation.metrics.thresholds import ThresholdCheck
from rigval.validation.scene_types import ComparisonSpec, Scene

__all__ = [
    "Assembly",
    "ComparisonResult",
    "ModelledRun",
    "NumericsSummary",
    "ValidationResult",
]


@dataclass(frozen=True)
class ComparisonResult:
    """One measured channel against its model counterpart over phi_F.

    Parameters
    ----------
    spec : ComparisonSpec
        The comparison as the scene defines it.
    units : str
        Unit of both sides (the measured channel's converted unit).
    long_name : str
        Label of the measured channel.
    angle : numpy.ndarray
        The phi_F grid in rad, shape (n_angle,).
    cycles : numpy.ndarray
        Measured signal per revolution, shape (n_cycle, n_angle).
    model : numpy.ndarray
        Model value times ``scale`` plus ``offset``, shape (n_angle,).
    offset : float
        Constant added to the model (``remove_offset``: measured mean minus model mean), else 0.
    scores : mapping
        The model-against-mean metrics by name (:func:`rigval.validation.metrics.compare.compare`).
    baseline : mapping of str to mapping
        The same metrics for each cycle against the measured mean: ``{"median": {...},
        "worst": {...}}`` (the noise floor no model can beat).
    checks : tuple of rigval.validation.metrics.thresholds.ThresholdCheck
        The scene's thresholds applied to ``scores``.
    """

    spec: ComparisonSpec
    units: str
    long_name: str
    angle: np.ndarray
    cycles: np.ndarray
    model: np.ndarray
    offset: float
    scores: Mapping[str, Any]
    baseline: Mapping[str, Mapping[str, Any]]
    checks: tuple[ThresholdCheck, ...]

    @property
    def name(self) -> str:
        """The comparison's name."""
        return self.spec.name

    @property
    def mean(self) -> np.ndarray:
        """Measured mean over cycles, per angle."""
        return np.mean(self.cycles, axis=0)

    @property
    def band(self) -> tuple[np.ndarray, np.ndarray]:
        """Measured 5th and 95th percentiles over cycles, per angle."""
        low, high = np.percentile(self.cycles, [5.0, 95.0], axis=0)
        return low, high

    @property
    def passed(self) -> bool:
        """Whether every threshold of this comparison is met (True without thresholds)."""
        return all(check.passed for check in self.checks)


@dataclass(frozen=True)
class NumericsSummary:
    """How far the numbers can be trusted.

    Parameters
    ----------
    stage_seconds : mapping of str to float
        Wall time per pipeline stage in s, in order.
    model_residuals : mapping of str to float
        Largest constraint residuals of the model solution (position, velocity, acceleration).
    grid_error : mapping of str to float
        Per comparison: largest difference between the model on the chosen grid (interpolated
        cubically) and on a grid four times finer, relative to the model's range.
    model_points : int
        Angle points the model was evaluated at.
    """

    stage_seconds: Mapping[str, float]
    model_residuals: Mapping[str, float]
    grid_error: Mapping[str, float]
    model_points: int


@dataclass(frozen=True)
class Assembly:
    """The scene's mechanism assembled at t = 0 of its file's drive laws, before any data.

    The pipeline assembles the mechanism before it reads the data and hands this to a caller
    that asks for it (:func:`rigval.validation.pipeline.run_scene` ``after_assembly``): the
    report's sketch of the mechanism is drawn while the data are read.

    Parameters
    ----------
    mechanism : rigval.model.Mechanism
        The scene's mechanism.
    configuration : xarray.Dataset
        It solved at t = 0 of its file's drive laws (``position`` and ``point_position``).
    shown_points : tuple of str
        The points whose kinematics the run predicts (the scene's ``[predictions] points``).
    """

    mechanism: Mechanism
    configuration: xr.Dataset
    shown_points: tuple[str, ...]


@dataclass(frozen=True)
class ModelledRun:
    """What a run knows once its model is solved, before its comparisons are scored.

    The pipeline hands it to a caller that asks for it
    (:func:`rigval.validation.pipeline.run_scene` ``after_model``), so that the report's
    figures of the alignment and the model can be drawn while the comparisons are made; each
    field equals the :class:`ValidationResult` field of the same name.

    Parameters
    ----------
    alignment : mapping of str to StreamAlignment
        Per stream.
    mechanism : rigval.model.Mechanism
        The mechanism the model ran.
    configuration : xarray.Dataset
        The mechanism at t = 0 of its file's drive laws.
    predictions : xarray.Dataset
        Support forces and point kinematics on the phi_F grid.
    """

    alignment: Mapping[str, StreamAlignment]
    mechanism: Mechanism
    configuration: xr.Dataset
    predictions: xr.Dataset


@dataclass(frozen=True)
class ValidationResult:
    """Everything one validation produced; the report is written from it alone.

    Parameters
    ----------
    scene : Scene
        The scene validated.
    comparisons : tuple of ComparisonResult
        One per comparison, in scene order.
    alignment : mapping of str to StreamAlignment
        Per stream.
    predictions : xarray.Dataset
        Model outputs on the phi_F grid that were not measured: support forces and point
        kinematics (dim ``angle``).
    numerics : NumericsSummary
        Time per stage, model residuals, grid error.
    speed_rev_s : float
        Mean main-shaft speed in rev/s.
    n_cycles : int
        Whole revolutions compared.
    tree : xarray.DataTree
        The run's data: ``/angle``, ``/model``, ``/validation``, and ``/raw/<stream>`` and
        ``/aligned/<stream>`` where the scene's ``[output]`` asks for them.
    mechanism : rigval.model.Mechanism
        The mechanism the model ran (the report's sketch).
    note : str or None
        The text of the scene's operator's note (None without one).
    input_digests : tuple of (pathlib.Path, str)
        Every file the validation read (data files, mechanism, note) with its SHA-256.
    configuration : xarray.Dataset or None
        The mechanism at t = 0 of its file's drive laws (``position``, ``point_position``), for
        the report's sketch; None: the report solves it.
    drive_law_angles : mapping of str to float
        Per driver, its law angle in rad when the main driver passes its ``theta0``
        (:func:`rigval.model.drives.law_angles_at_reference`), to set beside the scene's
        ``angle_at_reference`` of measured drives.
    outputs : tuple of pathlib.Path
        Files written (:func:`rigval.validation.run.validate.validate_scene` returns them here;
        empty from :func:`rigval.validation.pipeline.run_scene`).
    health : tuple of rigval.processing.health.Finding
        Sensor health findings of the channels the run read
        (:class:`rigval.validation.health.HealthLog`).
    diagnosis : rigval.validation.diagnosis.explain.Diagnosis or None
        Why the model disagrees: each comparison's most likely cause and the symmetry pairs
        (:func:`rigval.validation.diagnosis.explain.attach_diagnosis`).
    """

    scene: Scene
    comparisons: tuple[ComparisonResult, ...]
    alignment: Mapping[str, StreamAlignment]
    predictions: xr.Dataset
    numerics: NumericsSummary
    speed_rev_s: float
    n_cycles: int
    tree: xr.DataTree
    mechanism: Mechanism
    note: str | None
    input_digests: tuple[tuple[Path, str], ...]
    configuration: xr.Dataset | None = None
    drive_law_angles: Mapping[str, float] = field(default_factory=dict)
    outputs: tuple[Path, ...] = ()
    health: tuple[Finding, ...] = ()
    diagnosis: Any = None

    @property
    def passed(self) -> bool:
        """Whether every threshold of every comparison is met."""
        return all(c.passed for c in self.comparisons)

    @property
    def inputs(self) -> tuple[Path, ...]:
        """Files the validation read (data files, mechanism, note)."""
        return tuple(path for path, _ in self.input_digests)

    def metric_rows(self) -> list[dict[str, Any]]:
        """Return one row per comparison and metric: the model scores, then the baseline.

        Each row has ``comparison``, ``row`` (``"model"``, ``"baseline median"`` or ``"baseline
        worst"``), ``metric``, ``value``, ``threshold`` (text or None) and ``passed`` (bool, or
        None without a threshold; baseline rows have neither).
        """
        rows: list[dict[str, Any]] = []
        for comparison in self.comparisons:
            checks = {c.metric: c for c in comparison.checks}
            for metric, value in comparison.scores.items():
                check = checks.get(metric)
                rows.append({"comparison": comparison.name, "row": "model", "metric": metric,
                             "value": _plain(value),
                             "threshold": check.threshold if check else None,
                             "passed": check.passed if check else None})
            for which, scores in comparison.baseline.items():
                rows.extend({"comparison": comparison.name, "row": f"baseline {which}",
                             "metric": metric, "value": _plain(value), "threshold": None,
                             "passed": None} for metric, value in scores.items())
        return rows


def _plain(value: Any) -> Any:
    """Return numpy scalars as plain Python numbers."""
    return value.item() if isinstance(value, np.generic) else value
