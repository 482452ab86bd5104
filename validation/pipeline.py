"""The validation pipeline: one scene through its stages, from the files to the result.

:func:`run_scene` validates one scene and returns a
:class:`~rigval.validation.results.ValidationResult`, from which the report is written alone
(nothing is written here; :func:`rigval.validation.run.validate.validate_scene` also writes the
report folder). :func:`run_scene` reads as the list of stages (:data:`STAGES`), each timed: a
stage takes the output of the one before and hands on only what later stages need, so what it
consumed is let go when its output replaces it, with no bookkeeping of lifetimes. The scene
reaches processing and the model as plain settings (:mod:`rigval.validation.stage_settings`),
whose errors that are problems of the scene are reported once as a
:class:`~rigval.validation.errors.SceneError`; which channels each stage needs is the read
plan's (:mod:`rigval.validation.read_plan`), so every channel is read once.

read
    The scene's mechanism, assembled at t = 0 of its drive laws (the report's sketch; the
    model stage runs it). Each stream's file, only the channels the alignment and the model
    need (pulses, the
    encoders of phi_F and of measured drives; a text file's compared channels too), one stream
    after the other, converted to physical units (:mod:`rigval.processing.sensors`) as it is
    read (small files of the other streams in a child beside this process, their clock pulses
    found there too; large ones in the align stage, once phi_F and the encoders are let go, so
    that a long record's phi_F is made without them); the main reference pulse's edges found as
    its stream is read, and its
    channel then held as the samples near them
    (:func:`rigval.processing.stream_alignment.reference_pulses`);
    the files' SHA-256 and the operator's note. With ``[output] raw`` or ``aligned`` every
    channel is read here and kept.
align
    In steps, each output replacing its input: phi_F(t) from the main encoder (smoothed,
    never differenced raw), zero at the reference pulse, on the reference stream's time axis and
    the encoder's input delay (no delayed copy), its revolution check made on the counts at the
    samples around the pulses alone (not the whole record's int64 counts); from phi_F, the whole
    revolutions, the reference times of the grids (the uniform grid's first, then the fine
    grid's a block of revolutions at a time, never the whole fine grid's angles) and the events
    each other stream's pulses are fitted on, and phi_F is let go; with measured drives, each
    driver's angle, speed and acceleration from its encoder averaged over the revolutions at
    each angle of the fine grid as the encoder is smoothed, a block of revolutions at a time
    (never held on the whole fine grid), and the encoders are let go; the other streams not read
    yet are read (timed as the read stage); each other stream's clock
    fitted on its reference pulses against its events
    (:mod:`rigval.processing.stream_alignment`), module input delays removed.
model
    Only the outputs the comparisons and predictions name, on the phi_F grid, of the
    mechanism assembled in the read stage: with measured
    drives, the mean drives of the align stage; with analytic drives, the mechanism file's
    laws. The model runs on a grid four times finer, so that the error of the chosen grid is
    measured (:mod:`rigval.validation.model_run`).
angle
    Comparison by comparison, its channels read (those not read yet), low-passed (its
    ``lowpass_hz``) within gap-free runs, then resampled at the reference times of the uniform
    phi_F grid with the anti-aliasing of :func:`rigval.processing.angle.resample_to_angle`;
    revolutions touching a gap are dropped for that channel.
numerics
    The chosen grid's error against the finer one (also the V&V 20 ``u_num``), and the power
    balance of the model on the mechanism file's law.
compare
    Metrics of the model against the measured mean (with V&V 20 on the peak and RMS features),
    the baseline of every revolution against the mean, and the scene's thresholds.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr

from rigval.acquisition.errors import DataError
from rigval.acquisition.sample_times import sample_times
from rigval.acquisition.tdms_layout import kept_layouts
from rigval.model.balance import energy_residual
from rigval.model.drives import law_angles_at_reference
from rigval.model.mechanism import load_mechanism
from rigval.model.mechanism_types import Mechanism
from rigval.model.output_values import model_values
from rigval.model.solver import solve
from rigval.processing.alignment_summary import StreamAlignment
from rigval.processing.angle import (
    AngleGrid,
    anti_alias_hz,
    cycle_angles,
    resample_to_angle,
    whole_cycles,
)
from rigval.processing.filters import zero_phase
from rigval.processing.pulses import StreamPulses
from rigval.processing.stream_alignment import (
    AlignmentSettings,
    MainAngle,
    ReferenceAngle,
    ReferenceRecord,
    align_to_reference,
    pulse_events,
    reference_angle,
)
from rigval.processing.stretch_decimation import diagnosis_signal
from rigval.validation.comparison_scores import Scored, pair, score_comparisons
from rigval.validation.model_run import (
    FINE_FACTOR,
    MeanDrives,
    drives_of,
    grid_error,
    measured_drives,
    run_model,
)
from rigval.validation.read_plan import MeasuredSignal, ReadPlan, measured_signals, read_plan
from rigval.validation.read_stage import Inputs, Read, read_later, read_streams
from rigval.validation.results import (
    Assembly,
    ComparisonResult,
    ModelledRun,
    NumericsSummary,
    ValidationResult,
)
from rigval.validation.run_tree import history_lines, run_tree
from rigval.validation.scene import load_scene
from rigval.validation.scene_types import ComparisonSpec, Scene
from rigval.validation.stage_settings import (
    ModelSettings,
    alignment_settings,
    drive_encoders,
    model_settings,
    scene_errors,
)
from rigval.validation.stopwatch import Stopwatch
from rigval.validation.verdict import carried_uncertainty

__all__ = ["STAGES", "Measurement", "run_scene", "run_scene_kept"]

logger = logging.getLogger(__name__)

#: Spline order of the scene's ``angle.interpolation``.
INTERPOLATION_ORDER = {"linear": 1, "cubic": 3}
#: Relative difference of the analytic drive law's speed from the run's that is reported.
ANALYTIC_SPEED_TOLERANCE = 0.02


# ---------------------------------------------------------------------------------------------
# align


@dataclass(frozen=True)
class _Timeline:
    """The streams on the reference timeline and the grids of phi_F.

    ``streams`` hold the channels the angle stage takes (every channel when the output keeps
    them); after the angle stage, only the streams the output keeps.
    """

    streams: dict[str, xr.Dataset]
    diagnostics: Mapping[str, StreamAlignment]
    grid: _Grid
    angle_times: AngleGrid
    history: list[str]


@dataclass(frozen=True)
class _Aligned:
    """The align stage's output: the timeline and, apart, the mean measured drives for the model."""

    inputs: Inputs
    timeline: _Timeline
    drives: MeanDrives | None


@dataclass(frozen=True)
class _Others:
    """The streams other than the reference as read, and their clocks' pulses found as read.

    ``clock_pulses``: where the read stage found them (beside it); the align stage finds the
    others'. ``later``: the streams the read stage left to be read when they are aligned.
    """

    streams: Mapping[str, xr.Dataset]
    clock_pulses: Mapping[str, StreamPulses]
    later: tuple[str, ...]


@dataclass(frozen=True)
class _PhiF:
    """The align stage's first step: the reference stream on its timeline with phi_F(t).

    The other streams are as read.
    """

    inputs: Inputs
    others: _Others
    reference: ReferenceAngle


@dataclass(frozen=True)
class _Predicted:
    """What the align stage takes from phi_F, which is then let go.

    The grids, the fine grid's reference times (for the measured drives) and each other
    stream's reference events as phi_F predicts them; the other streams are as read.
    """

    inputs: Inputs
    others: _Others
    reference: xr.Dataset
    record: ReferenceRecord
    events: Mapping[str, np.ndarray]
    grid: _Grid
    fine_times: np.ndarray
    angle_times: AngleGrid


@dataclass(frozen=True)
class _Driven:
    """:class:`_Predicted` with the mean measured drives for the fine times and the encoders.

    The reference stream holds only the channels later stages take.
    """

    inputs: Inputs
    others: _Others
    reference: xr.Dataset
    record: ReferenceRecord
    events: Mapping[str, np.ndarray]
    grid: _Grid
    angle_times: AngleGrid
    drives: MeanDrives | None


def _phi_f(scene: Scene, settings: AlignmentSettings, read: Read) -> _PhiF:
    """Put the reference stream on its timeline and find phi_F(t) on it."""
    # the device clocks go into the output only with [output] aligned
    reference = reference_angle(settings, read.converted[settings.reference],
                                device_time=scene.output.aligned, found=read.reference)
    others = {name: ds for name, ds in read.converted.items() if name != settings.reference}
    return _PhiF(read.inputs, _Others(others, read.clock_pulses, read.later), reference)


def _predict(scene: Scene, settings: AlignmentSettings, phi: _PhiF) -> _Predicted:
    """Take from phi_F the grids and the events the other streams are aligned on; let it go.

    The uniform grid's times (a spline's, with its temporaries) are found before the fine
    grid's, so that the two are not held beside each other's making (memory).
    """
    main = phi.reference.main
    events = pulse_events(settings, main)
    turns = _revolutions(scene, main)
    angle_times = main.grid(scene.angle.points_per_revolution)
    grid, fine_times = _grid(scene, main, turns)
    return _Predicted(phi.inputs, phi.others, phi.reference.stream, phi.reference.record, events,
                      grid, fine_times, angle_times)


def _drives(scene: Scene, plan: ReadPlan, settings: AlignmentSettings, predicted: _Predicted
            ) -> _Driven:
    """Average the measured drives on the fine grid; its times and the encoders are let go.

    Each driver's revolutions are averaged as its encoder is smoothed
    (:func:`rigval.validation.model_run.measured_drives`): its outputs are never held on the
    whole fine grid.

    The reference stream keeps the channels later stages take and its pulse channel, if there,
    for the alignment figure's window.
    """
    drives = (measured_drives(drive_encoders(scene), predicted.reference,
                              predicted.fine_times) if plan.drives else None)
    reference = _kept(plan, settings.reference, predicted.reference,
                      settings.reference_pulse.name)
    return _Driven(predicted.inputs, predicted.others, reference, predicted.record,
                   predicted.events, predicted.grid, predicted.angle_times, drives)


def _read_others(scene: Scene, plan: ReadPlan, driven: _Driven, watch: Stopwatch) -> _Driven:
    """Read the streams the read stage left for later, now that phi_F and the encoders are gone.

    Timed as the read stage (:func:`rigval.validation.read_stage.read_later`).
    """
    others = driven.others
    if not others.later:
        return driven
    inputs, read = read_later(scene, plan, others.later, driven.inputs, watch)
    return dataclasses.replace(driven, inputs=inputs, others=_Others(
        {**others.streams, **read}, others.clock_pulses, ()))


def _kept(plan: ReadPlan, name: str, stream: xr.Dataset, *also: str) -> xr.Dataset:
    """Return a stream with the channels later stages take (every channel when all are kept).

    ``also``: channels kept too when the stream holds them.
    """
    if plan.whole:
        return stream
    names = set(plan.kept_after_alignment(name)) | {c for c in also if c in stream}
    return stream[[*sorted(names), "valid", "segment"]]


def _align(scene: Scene, plan: ReadPlan, settings: AlignmentSettings, driven: _Driven
           ) -> _Aligned:
    """Put the other streams on the reference timeline; keep only the channels later stages take.

    The compared channels stay in the streams (every channel when the output keeps them);
    pulses and device clocks are let go.
    """
    aligned, diagnostics = align_to_reference(
        settings, driven.reference, driven.others.streams, driven.record, driven.events,
        device_time=scene.output.aligned, found=driven.others.clock_pulses)
    history = [line for ds in aligned.values()
               for line in str(ds.attrs.get("history", "")).splitlines()]
    aligned = {name: _kept(plan, name, ds) for name, ds in aligned.items()}
    timeline = _Timeline(aligned, diagnostics, driven.grid, driven.angle_times, history)
    return _Aligned(driven.inputs, timeline, driven.drives)


@dataclass(frozen=True)
class _Grid:
    """The phi_F grid of a run: whole revolutions, fine grid for the model, the chosen grid.

    The fine grid's reference times, which the measured drives alone take, travel apart
    (:class:`_Predicted`): the chosen grid's are a quarter of them.
    """

    turns: np.ndarray
    fine_angle: np.ndarray
    times: np.ndarray
    speed_rev_s: float

    @property
    def angle(self) -> np.ndarray:
        """The chosen grid's angles over one revolution (rad)."""
        return self.fine_angle[::FINE_FACTOR]


def _revolutions(scene: Scene, main: MainAngle) -> np.ndarray:
    """Return the numbers of phi_F's whole revolutions, as many as the scene asks for at least.

    Raises
    ------
    DataError
        When the record holds fewer than ``angle.min_cycles``.
    """
    turns = whole_cycles(main.phi[0], main.phi[-1])
    if turns.size < scene.angle.min_cycles:
        raise DataError(f"only {turns.size} whole revolutions in the record, the scene asks "
                        f"for {scene.angle.min_cycles}", where={"key": "angle.min_cycles"},
                        hint="record longer, or lower angle.min_cycles")
    return turns


def _grid(scene: Scene, main: MainAngle, turns: np.ndarray) -> tuple[_Grid, np.ndarray]:
    """Return the phi_F grid of the whole revolutions ``turns``, chosen and fine grid times.

    Returns the grid, whose ``times`` are the chosen grid's (n_cycle, n_angle), and the fine
    grid's (n_cycle, n_angle * FINE_FACTOR), s.
    """
    n = scene.angle.points_per_revolution
    fine_times = _fine_times(main, turns, n * FINE_FACTOR)
    duration = float(main.times_at(2 * np.pi * (turns[-1] + 1)) - fine_times[0, 0])
    chosen = np.ascontiguousarray(fine_times[:, ::FINE_FACTOR])
    first = cycle_angles(turns[:1], n * FINE_FACTOR)[0]
    return _Grid(turns, first - first[0], chosen, turns.size / duration), fine_times


#: Revolutions of the fine grid whose reference times :func:`_fine_times` finds at once.
_GRID_BLOCK = 256


def _fine_times(main: MainAngle, turns: np.ndarray, points: int) -> np.ndarray:
    """Return the reference times of the fine grid's revolutions, (turns.size, points), s.

    A block of revolutions at a time, each block's angles made and let go (memory: never the
    whole grid's angles, as many as its times); the times those of the whole grid's angles.
    """
    times = np.empty((turns.size, points))
    for lo in range(0, turns.size, _GRID_BLOCK):
        block = turns[lo:lo + _GRID_BLOCK]
        times[lo:lo + block.size] = main.times_at(cycle_angles(block, points))
    return times


# ---------------------------------------------------------------------------------------------
# model


@dataclass(frozen=True)
class _Model:
    """The model of the run: on the fine grid, the chosen one and at t = 0 of the drive laws.

    The chosen grid is every fourth point of the fine one; the configuration at t = 0 is what
    the report's sketch draws; the predictions are the chosen grid's outputs that were not
    measured (:func:`_predicted_outputs`).
    """

    mechanism: Mechanism
    settings: ModelSettings
    fine: xr.Dataset
    chosen: xr.Dataset
    configuration: xr.Dataset
    predictions: xr.Dataset


@dataclass(frozen=True)
class _Modelled:
    """The model stage's output: the drives' encoders are let go."""

    inputs: Inputs
    timeline: _Timeline
    model: _Model


def _assemble(scene: Scene) -> Assembly:
    """Load the scene's mechanism and assemble it at t = 0 of its file's drive laws."""
    mechanism = load_mechanism(scene.mechanism)
    return Assembly(mechanism,
                    solve(mechanism, np.zeros(1), outputs=["position", "point_position"]),
                    tuple(str(p) for p in scene.predictions.points or ()))


def _model(scene: Scene, aligned: _Aligned, assembly: Assembly,
           like: xr.Dataset | None = None) -> _Modelled:
    """Solve the mechanism on the fine phi_F grid; the chosen grid is every fourth point.

    ``like``: another mechanism's fine model of the same run, whose mean measured drives are
    taken as they are (:func:`rigval.validation.model_run.drives_of`).
    """
    grid = aligned.timeline.grid
    mechanism = assembly.mechanism
    settings = model_settings(scene, mechanism)
    drives = drives_of(like) if like is not None and settings.drives == "measured" \
        else aligned.drives
    fine = run_model(settings, mechanism, grid.fine_angle, drives=drives)
    if settings.drives == "analytic":
        law_speed = 1.0 / float(fine.attrs["cycle_period_s"])
        if abs(law_speed / grid.speed_rev_s - 1.0) > ANALYTIC_SPEED_TOLERANCE:
            logger.warning("the mechanism's drive law turns at %.4g rev/s, the run at %.4g "
                           "rev/s: forces scale with the square of the speed; consider "
                           'drives = "measured"', law_speed, grid.speed_rev_s)
    chosen = fine.isel(angle=slice(None, None, FINE_FACTOR))
    return _Modelled(aligned.inputs, aligned.timeline, _Model(
        mechanism, settings, fine, chosen, assembly.configuration,
        _predicted_outputs(scene, chosen)))


# ---------------------------------------------------------------------------------------------
# angle domain


@dataclass(frozen=True)
class _Measured:
    """The angle stage's output: the measured revolutions on the phi_F grid, by comparison.

    The timeline keeps only the streams the output keeps (``[output] aligned``).
    """

    inputs: Inputs
    timeline: _Timeline
    model: _Model
    cycles: Mapping[str, np.ndarray]
    corners: Mapping[str, float | None]
    long_names: Mapping[str, str]
    diagnosis: Mapping[str, xr.Dataset]


def _angle(scene: Scene, plan: ReadPlan, modelled: _Modelled) -> _Measured:
    """Resample every comparison's measured signal onto the phi_F grid, in the plan's order.

    Gives the resampled cycles, the low-pass corners applied and the channels' long names.
    """
    timeline = modelled.timeline
    cycles, corners, long_names, diagnosis = {}, {}, {}, {}
    for comparison, signal in measured_signals(scene, plan, timeline.streams,
                                               on_read=modelled.inputs.health.check):
        cycles[comparison.name], corners[comparison.name] = _resample(
            scene, comparison, signal, timeline.angle_times, diagnosis)
        long_names[comparison.name] = signal.long_name
    kept = timeline.streams if scene.output.aligned else {}
    cycles, corners, long_names, diagnosis = (  # in the scene's order, as the outputs list them
        {c.name: found[c.name] for c in scene.comparisons}
        for found in (cycles, corners, long_names, diagnosis))
    return _Measured(modelled.inputs, dataclasses.replace(timeline, streams=kept),
                     modelled.model, cycles, corners, long_names, diagnosis)


def _resample(scene: Scene, comparison: ComparisonSpec, signal: MeasuredSignal, grid: AngleGrid,
              diagnosis: dict[str, xr.Dataset]) -> tuple[np.ndarray, float | None]:
    """Resample a measured signal onto the phi_F grid, (n_cycle, n_angle); NaN at gaps.

    The comparison's ``lowpass_hz`` (zero phase, within gap-free runs) comes first; the
    anti-alias low-pass of :func:`rigval.processing.angle.resample_to_angle` follows, here so
    that each filter writes its output into its input when the signal owns it, else into a
    new array that the next filter then owns (memory: one whole-record array for the values,
    not two). Returns the resampled
    cycles and the low-pass corner applied in Hz (None: none); puts the signal before any
    low-pass, decimated, into ``diagnosis`` (docs/diagnosis.md).
    """
    fs, valid, segment = signal.fs, signal.valid, signal.segment
    values, owned = signal.take_values(), signal.owned
    time = sample_times(signal.time)  # a lazy axis's times computed where read (memory)
    diagnosis[comparison.name] = diagnosis_signal(time, values, segment, valid, fs,
                                                  delay_s=signal.delay_s)
    corner = comparison.lowpass_hz
    if corner is not None and corner < 0.45 * fs:
        values = zero_phase(values, fs, corner, segment=segment, valid=valid, overwrite=owned)
        owned = True
        valid &= np.isfinite(values)
    anti_alias = anti_alias_hz(grid, scene.angle.points_per_revolution)
    if anti_alias < 0.45 * fs:
        values = zero_phase(values, fs, anti_alias, order=8, segment=segment, valid=valid,
                            overwrite=owned)
    _, _, cycles = resample_to_angle(
        time, values, None, None,
        points_per_rev=scene.angle.points_per_revolution, fs=fs,
        order=INTERPOLATION_ORDER[scene.angle.interpolation], anti_alias="none",
        segment=segment, valid=valid, grid=grid,
        delay_s=signal.delay_s)  # as clock_fit.channel_time, without a copy of the times
    return cycles, corner


# ---------------------------------------------------------------------------------------------
# numerics and compare


@dataclass(frozen=True)
class _Numerics:
    """The chosen grid's error per comparison, the model's power balance, the fine grid's size."""

    errors: Mapping[str, float]
    residuals: Mapping[str, float]
    model_points: int


def _numerics(scene: Scene, model: _Model) -> _Numerics:
    """Return the chosen grid's error per comparison and the model's power balance."""
    residuals = energy_residual(model.mechanism, scene.angle.points_per_revolution)
    residuals["max condition number (this run)"] = float(
        model.chosen.attrs.get("max_condition_number", math.nan))
    return _Numerics(grid_error(model.settings, model.fine), residuals,
                     int(model.fine.sizes["angle"]))


def _compare_all(scene: Scene, measured: _Measured, numerics: _Numerics,
                 like: tuple[ComparisonResult, ...] | None = None
                 ) -> tuple[ComparisonResult, ...]:
    """Score every comparison (:func:`~rigval.validation.comparison_scores.score_comparisons`).

    ``like``: the same measurement's results against another mechanism, whose baselines are
    taken as they are.
    """
    grid, scored = measured.timeline.grid, {}
    for comparison in scene.comparisons:
        name = comparison.name
        values = model_values(measured.model.chosen, comparison.model)
        scored[name] = Scored(
            pair(comparison, measured.cycles[name], values), scene.units(comparison.measured),
            measured.long_names[name],
            numerics.errors[name] * float(np.ptp(values)) * abs(comparison.scale),
            carried_uncertainty(scene, measured.timeline.diagnostics[comparison.measured.stream],
                                grid.speed_rev_s))
    return score_comparisons(scene, scored, grid.angle, like)


# ---------------------------------------------------------------------------------------------
# the run

#: The stages of a run, in order, as timed (``NumericsSummary.stage_seconds``; ``convert`` is
#: timed inside ``read``).
STAGES = ("read", "align", "model", "angle", "numerics", "compare")


def run_scene(scene: Scene | str | Path, *,
              after_assembly: Callable[[Assembly], None] | None = None,
              after_model: Callable[[ModelledRun], None] | None = None) -> ValidationResult:
    """Validate one scene: read, align, model, angle domain, numerics, compare.

    :func:`run_scene_kept` does the same and keeps the measurement, to validate it against
    another mechanism without reading and aligning it again.

    Each stage takes the output of the one before and hands on what the later ones need, so
    what a stage consumed (the converted streams, phi_F, the drives' encoders, the compared
    channels) is let go as the next stage's output replaces it.

    Parameters
    ----------
    scene : Scene, str or pathlib.Path
        A parsed scene or the path of a scene file.
    after_assembly : callable, optional
        Called with the scene's :class:`~rigval.validation.results.Assembly` as soon as its
        mechanism is assembled, before the data are read (the report's drawers start on the
        mechanism's sketch).
    after_model : callable, optional
        Called with the run's :class:`~rigval.validation.results.ModelledRun` as soon as the
        model stage ends (the report's drawers start on the alignment and model figures).

    Returns
    -------
    ValidationResult
        Everything the report needs but the diagnosis
        (:func:`rigval.validation.diagnosis.explain.attach_diagnosis`, which
        :func:`rigval.validation.run.validate.validate_scene` adds); nothing is written.

    Raises
    ------
    SceneError
        For a bad scene, including channels absent from their files, units that do not fit
        the declared sensors and encoder scales the data contradict.
    RigvalError
        For data that cannot be read, aligned or modelled (``DataFileError``, ``DataError``,
        ``AlignmentError``, ``ModelError``).
    """
    with kept_layouts():  # each TDMS file's segments walked once: the scene's check, every read
        return _run(scene, keep=False, after_assembly=after_assembly,
                    after_model=after_model)[0]


@dataclass(frozen=True)
class Measurement:
    """A validated run's measurement, kept to validate it against another mechanism.

    Holds what the model, numerics and compare stages take (the timeline's grids, the measured
    revolutions, and in its model the mean measured drives) and the run's comparisons, so that
    :meth:`against` runs those three stages only, with the drive motion as averaged for this
    run and each comparison's baseline (every revolution scored against the mean) as found for
    it: the measured side does not depend on the mechanism.
    """

    scene: Scene
    measured: _Measured
    comparisons: tuple[ComparisonResult, ...]

    def against(self, mechanism: Path) -> ValidationResult:
        """Validate the same measurement against another mechanism file.

        Parameters
        ----------
        mechanism : pathlib.Path
            A mechanism of the same bodies, joints and drives (its parameters changed, as
            ``rigval identify`` writes it).

        Returns
        -------
        ValidationResult
            As :func:`run_scene` of the scene with that mechanism gives it; its stage times
            are the model, numerics and compare stages only.
        """
        scene = dataclasses.replace(self.scene, mechanism=mechanism)
        watch = Stopwatch()
        with scene_errors(scene):
            with watch.stage("model"):
                model = _model(scene, _Aligned(self.measured.inputs, self.measured.timeline,
                                               None), _assemble(scene),
                               like=self.measured.model.fine).model
            measured = dataclasses.replace(self.measured, model=model)
            with watch.stage("numerics"):
                numerics = _numerics(scene, model)
            with watch.stage("compare"):
                results = _compare_all(scene, measured, numerics, like=self.comparisons)
        return _result(scene, watch, measured, numerics, results)


def run_scene_kept(scene: Scene | str | Path, *,
                   after_assembly: Callable[[Assembly], None] | None = None,
                   after_model: Callable[[ModelledRun], None] | None = None
                   ) -> tuple[ValidationResult, Measurement]:
    """Validate one scene as :func:`run_scene` does, and keep its measurement.

    The measurement holds the measured revolutions and the mean measured drives beside the result
    (``rigval identify`` validates the identified mechanism with it).

    Returns
    -------
    result : ValidationResult
        As :func:`run_scene` returns it.
    measurement : Measurement
        For :meth:`Measurement.against`.
    """
    with kept_layouts():  # as in run_scene
        result, measurement = _run(scene, keep=True, after_assembly=after_assembly,
                                   after_model=after_model)
    assert measurement is not None
    return result, measurement


def _run(scene: Scene | str | Path, *, keep: bool,
         after_assembly: Callable[[Assembly], None] | None = None,
         after_model: Callable[[ModelledRun], None] | None = None
         ) -> tuple[ValidationResult, Measurement | None]:
    """Run the stages of a run; with ``keep`` return its measurement too."""
    watch = Stopwatch()
    with watch.stage("read"):
        if not isinstance(scene, Scene):
            scene = load_scene(scene)
        settings = alignment_settings(scene)
        plan = read_plan(scene, settings)
    with scene_errors(scene):
        with watch.stage("read"):
            assembly = _assemble(scene)
        if after_assembly is not None:
            after_assembly(assembly)
        with watch.stage("read"):
            run = read_streams(scene, plan, settings, watch)
        with watch.stage("align"):
            run = _phi_f(scene, settings, run)
            run = _predict(scene, settings, run)
            run = _drives(scene, plan, settings, run)
            run = _read_others(scene, plan, run, watch)
            run = _align(scene, plan, settings, run)
        with watch.stage("model"):
            run = _model(scene, run, assembly)
        if after_model is not None:
            after_model(ModelledRun(run.timeline.diagnostics, run.model.mechanism,
                                    run.model.configuration, run.model.predictions))
        with watch.stage("angle"):
            run = _angle(scene, plan, run)
        with watch.stage("numerics"):
            numerics = _numerics(scene, run.model)
        with watch.stage("compare"):
            results = _compare_all(scene, run, numerics)
    result = _result(scene, watch, run, numerics, results)
    return result, Measurement(scene, run, results) if keep else None


def _result(scene: Scene, watch: Stopwatch, measured: _Measured, numerics: _Numerics,
            results: tuple[ComparisonResult, ...]) -> ValidationResult:
    """Return the run's result: everything the report needs."""
    grid, timeline, model = measured.timeline.grid, measured.timeline, measured.model
    passed = all(r.passed for r in results)
    steps = history_lines(scene, int(grid.turns.size), measured.corners, model.settings.request,
                          passed)
    tree = run_tree(scene, measured.inputs.raw, timeline.streams, grid.angle, grid.times,
                    measured.cycles, results, model.chosen, steps, timeline.history,
                    measured.corners)
    for name, signal in measured.diagnosis.items():  # the residual spectra's input
        tree[f"/diagnosis/{name}"] = xr.DataTree(signal)
    summary = NumericsSummary(dict(watch.seconds), numerics.residuals, numerics.errors,
                              numerics.model_points)
    logger.info("validated %s in %.2f s: %s", scene.path.name, sum(watch.seconds.values()),
                "passed" if passed else "failed")
    return ValidationResult(
        scene=scene, comparisons=results, alignment=timeline.diagnostics,
        predictions=model.predictions, numerics=summary,
        speed_rev_s=grid.speed_rev_s, n_cycles=int(grid.turns.size), tree=tree,
        mechanism=model.mechanism, note=measured.inputs.note,
        input_digests=measured.inputs.digests, configuration=model.configuration,
        drive_law_angles=law_angles_at_reference(model.mechanism),
        health=tuple(measured.inputs.health.findings))


def _predicted_outputs(scene: Scene, model: xr.Dataset) -> xr.Dataset:
    """Support forces and point kinematics on the phi_F grid (what was not measured)."""
    variables = {}
    if "support_force" in model:
        force = model["support_force"]
        if scene.predictions.supports is not None:
            force = force.sel(support=list(scene.predictions.supports))
        variables["support_force"] = force
    if scene.predictions.points:
        for quantity in ("point_position", "point_velocity", "point_acceleration"):
            variables[quantity] = model[quantity].sel(point=list(scene.predictions.points))
    return xr.Dataset(variables, coords={"angle": model["angle"]})
