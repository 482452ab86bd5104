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

from rigval.validation.metrics.thresholds import ThresholdCheck
from rigval.validation.scene import ComparisonSpec, Scene

__all__ = [
    "ComparisonResult",
    "NumericsSummary",
    "StreamAlignment",
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
class StreamAlignment:
    """How one stream's clock was mapped onto the reference timeline.

    Parameters
    ----------
    stream : str
        Stream name.
    device : str
        Device kind.
    is_reference : bool
        True for the reference stream (offset 0, drift 0 by definition).
    offset_s : float
        Clock offset in s (reference time of the stream's time zero).
    drift_ppm : float
        Clock drift in ppm, as in ``t_ref = offset + (1 + drift) t_stream``: positive when the
        stream's clock runs slow against the reference's.
    residual_rms_s : float
        RMS of the clock-fit residuals on the matched events in s.
    events_matched : int
        Reference events matched with the reference stream.
    events_missing : int
        Expected events that were not seen.
    events_spurious : int
        Events that matched nothing.
    input_delay_s : float
        Module input delay removed in s.
    segments : int
        Gap-free segments (each with its own clock fit).
    gaps : tuple of mapping
        Gaps: ``{"after_s", "duration_s", "missing_samples"}`` on the stream's own clock.
    span_s : tuple of float
        First and last sample on the reference timeline in s.
    residual_time : numpy.ndarray
        Reference-timeline times of the matched events in s.
    residual_s : numpy.ndarray
        Clock-fit residual per matched event in s.
    pulse_time : numpy.ndarray
        A short window of the raw pulse channel around one reference pulse that every stream
        recorded: times on the reference timeline in s.
    pulse_signal : numpy.ndarray
        The raw pulse signal there, in ``pulse_units``.
    pulse_units : str
        Unit of the pulse channel as read.
    edge_times : numpy.ndarray
        Detected rising edges within that stretch in s.
    offset_u95_s, drift_u95_ppm : float
        Half-widths of the 95 % intervals of the offset (s) and the drift (ppm).
    periods_decided_by : str
        What decided the whole pulse periods (``stamps``, ``data``, ``neighbour``).
    method : str
        ``pulses`` or ``stamps`` (the scene's ``alignment.pulses.<stream>.method``).
    start_time_uncertainty_s : float
        Half-width in s of the window the offset was searched in.
    coarse_offset_s : float
        Centre of that window in s.
    coarse_offset_source : str
        Where the centre came from (start stamps, the scene's coarse_offset_s, no start time).
    segment_table : tuple of mapping
        Per gap-free segment: clock offset and its 95 % interval, clock group, samples, samples
        dropped and why.
    """

    stream: str
    device: str
    is_reference: bool
    offset_s: float
    drift_ppm: float
    residual_rms_s: float
    events_matched: int
    events_missing: int
    events_spurious: int
    input_delay_s: float
    segments: int
    gaps: tuple[Mapping[str, Any], ...]
    span_s: tuple[float, float]
    residual_time: np.ndarray = field(repr=False)
    residual_s: np.ndarray = field(repr=False)
    pulse_time: np.ndarray = field(repr=False)
    pulse_signal: np.ndarray = field(repr=False)
    pulse_units: str
    edge_times: np.ndarray = field(repr=False)
    offset_u95_s: float = 0.0
    drift_u95_ppm: float = 0.0
    periods_decided_by: str = ""
    method: str = "pulses"
    start_time_uncertainty_s: float = 0.0
    coarse_offset_s: float = 0.0
    coarse_offset_source: str = ""
    segment_table: tuple[Mapping[str, Any], ...] = ()

    def summary(self) -> dict[str, Any]:
        """Return the JSON-ready summary written to ``alignment.json``."""
        return {
            "device": self.device, "reference": self.is_reference, "offset_s": self.offset_s,
            "drift_ppm": self.drift_ppm, "residual_rms_s": self.residual_rms_s,
            "events_matched": self.events_matched, "events_missing": self.events_missing,
            "events_spurious": self.events_spurious, "input_delay_s": self.input_delay_s,
            "segments": self.segments, "gaps": [dict(g) for g in self.gaps],
            "span_s": list(self.span_s), "offset_u95_s": self.offset_u95_s,
            "drift_u95_ppm": self.drift_u95_ppm, "periods_decided_by": self.periods_decided_by,
            "method": self.method, "start_time_uncertainty_s": self.start_time_uncertainty_s,
            "coarse_offset_s": self.coarse_offset_s,
            "coarse_offset_source": self.coarse_offset_source,
            "samples_dropped": sum(int(row.get("samples_dropped", 0))
                                   for row in self.segment_table),
            "segment_table": [dict(row) for row in self.segment_table],
        }


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


@dataclass
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
    outputs : list of pathlib.Path
        Files written (filled by :func:`rigval.validation.report.run_report.write_report`).
    """

    scene: Scene
    comparisons: tuple[ComparisonResult, ...]
    alignment: Mapping[str, StreamAlignment]
    predictions: xr.Dataset
    numerics: NumericsSummary
    speed_rev_s: float
    n_cycles: int
    tree: xr.DataTree
    outputs: list[Path] = field(default_factory=list)

    @property
    def passed(self) -> bool:
        """Whether every threshold of every comparison is met."""
        return all(c.passed for c in self.comparisons)

    @property
    def inputs(self) -> tuple[Path, ...]:
        """Files the validation read (data files, mechanism, note)."""
        return self.scene.input_files

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
