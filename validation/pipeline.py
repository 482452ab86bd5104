"""The validation pipeline: scene -> read -> convert -> align -> model -> angle domain -> compare.

:func:`run_scene` validates one scene and returns a
:class:`~rigval.validation.results.ValidationResult` (nothing written;
:func:`rigval.validation.report.validate.validate_scene` also writes the report folder). Stages,
timed one by one:

read
    Each stream's file, only the channels the alignment needs (pulses, the encoders of phi_F
    and of measured drives; a text file's compared channels too)
    (:func:`rigval.acquisition.channel_map.load_stream`). The compared channels of a TDMS
    file are read in the angle stage, one stream after the other, and dropped after use, so
    memory holds the alignment's channels and one stream's compared channels, not every
    stage of every channel (docs/performance.md, long records). With ``[output] raw`` or
    ``aligned`` every channel is read here and kept.
convert
    Raw channels to physical units (:mod:`rigval.processing.sensors`).
align
    phi_F(t) from the main encoder (smoothed, never differenced raw), zero at the reference
    pulse; each other stream's clock fitted on its reference pulses against the events the
    encoder angle predicts (:mod:`rigval.processing.stream_alignment`), module input delays removed.
model
    Before the angle stage, so that the encoders can be dropped. Only the outputs the
    comparisons and predictions name, on the phi_F grid: with measured drives, each driver's
    angle, speed and acceleration from its encoder averaged over the revolutions at each grid
    angle; with analytic drives, the mechanism file's laws. The model runs on a grid four times
    finer, so that the error of the chosen grid is measured.
angle
    Whole revolutions; each compared channel low-passed (its ``lowpass_hz``) within gap-free
    runs, then resampled at the reference times of the uniform phi_F grid with the
    anti-aliasing of :func:`rigval.processing.angle.resample_to_angle`; revolutions touching a
    gap are dropped for that channel.
numerics
    The chosen grid's error against the finer one (also the V&V 20 ``u_num``), and the power
    balance of the model on the mechanism file's law.
compare
    Metrics of the model against the measured mean (with V&V 20 on the peak and RMS features),
    the baseline of every revolution against the mean, and the scene's thresholds.
"""

from __future__ import annotations

import dataclasses
import datetime
import logging
import math
import time
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np
import xarray as xr

from rigval.acquisition.channel_map import StreamSpec, load_stream
from rigval.acquisition.errors import DataError
from rigval.model.balance import energy_residual
from rigval.model.mechanism import load_mechanism
from rigval.processing.alignment_summary import StreamAlignment
from rigval.processing.angle import (
    AngleGrid,
    angle_grid,
    anti_alias_hz,
    cycle_grid,
    resample_to_angle,
)
from rigval.processing.clock_fit import input_delay
from rigval.processing.encoder import compact_counts
from rigval.processing.filters import zero_phase
from rigval.processing.stream_alignment import AlignmentSettings, MainAngle, align_streams
from rigval.validation.alignment import alignment_settings
from rigval.validation.convert import convert_stream
from rigval.validation.diagnosis.decimate import diagnosis_signal
from rigval.validation.metrics.compare import baseline, check_thresholds, compare
from rigval.validation.model_run import (
    FINE_FACTOR,
    grid_error,
    model_request,
    model_values,
    run_model,
)
from rigval.validation.results import ComparisonResult, NumericsSummary, ValidationResult
from rigval.validation.scene import load_scene
from rigval.validation.scene_rates import check_sample_rates, encoder_scale_errors
from rigval.validation.scene_types import ComparisonSpec, Scene
from rigval.validation.verdict import carried_uncertainty, with_common_gain

__all__ = ["read_streams", "run_scene"]

logger = logging.getLogger(__name__)

#: Spline order of the scene's ``angle.interpolation``.
INTERPOLATION_ORDER = {"linear": 1, "cubic": 3}
#: Relative difference of the analytic drive law's speed from the run's that is reported.
ANALYTIC_SPEED_TOLERANCE = 0.02


class _Stopwatch:
    """Wall time per named stage, in the order the stages ran."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}

    @contextmanager
    def stage(self, name: str) -> Iterator[None]:
        start = time.perf_counter()
        try:
            yield
        finally:
            self.seconds[name] = self.seconds.get(name, 0.0) + time.perf_counter() - start
            logger.info("stage %s: %.3f s (process CPU %.1f s, peak memory %s)", name,
                        self.seconds[name], time.process_time(), _peak_memory())


def _peak_memory() -> str:
    """Return the process's peak resident memory so far as text (``"n/a"`` off Unix)."""
    try:
        import resource
    except ImportError:
        return "n/a"
    kib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB on Linux
    return f"{kib / 1024:.0f} MiB"


def read_streams(scene: Scene, channels: Mapping[str, Iterable[str]] | None = None, *,
                 only: str | None = None) -> dict[str, xr.Dataset]:
    """Read every stream of a scene: the mapped channels under their scene names.

    Parameters
    ----------
    scene : Scene
        The scene.
    channels : mapping of str to iterable of str, optional
        Per stream, only these scene channels; default every mapped channel.
    only : str, optional
        Read only this stream.

    Returns
    -------
    dict of str to xarray.Dataset
        Stream name -> stream as read (raw units).
    """
    names = list(scene.streams) if only is None else [only]
    if channels is None:
        return {name: load_stream(scene.streams[name]) for name in names}
    return {name: load_stream(_stream_part(scene.streams[name], channels[name]))
            for name in names}


def _stream_part(spec: StreamSpec, names: Iterable[str]) -> StreamSpec:
    """Return the stream table with only the named channels (in table order)."""
    keep = set(names)
    return dataclasses.replace(spec, channels=MappingProxyType(
        {name: channel for name, channel in spec.channels.items() if name in keep}))


def _compact_encoders(stream: xr.Dataset, spec: StreamSpec) -> None:
    """Store, in place, the stream's encoder counters as 32-bit integers where exact.

    See :func:`rigval.processing.encoder.compact_counts`: values are never altered.
    """
    for name, channel in spec.channels.items():
        if channel.sensor == "encoder" and name in stream:
            stream[name] = stream[name].copy(data=compact_counts(stream[name].to_numpy()))


def _alignment_channels(scene: Scene, settings: AlignmentSettings) -> dict[str, set[str]]:
    """Return the channels read before the alignment: pulses, encoders of phi_F and the drives.

    A stream aligned by its start stamps needs no channel; its first is read for its samples.
    A stream in a text file (CSV, LVM) brings its compared channels too: only TDMS files are
    read channel by channel.
    """
    needs: dict[str, set[str]] = {name: set() for name in scene.streams}
    needs[settings.reference] |= {settings.encoder.name, settings.reference_pulse.name}
    if scene.model.drives == "measured":
        for driver in scene.model.drivers.values():
            needs[driver.encoder.stream].add(driver.encoder.channel)
    for name, clock in settings.streams.items():
        if clock.pulse is not None:
            needs[name].add(clock.pulse.name)
    for name, names in needs.items():
        if not names:
            names.add(next(iter(scene.streams[name].channels)))
        if scene.streams[name].file.suffix.lower() != ".tdms":
            # a text file is parsed whole for any channel: its compared channels come along
            names.update(ref.channel for c in scene.comparisons for _, ref in c.terms
                         if ref.stream == name)
    return needs


def _add_channels(scene: Scene, name: str, aligned: xr.Dataset, channels: list[str]
                  ) -> xr.Dataset:
    """Read, convert and put on the reference timeline channels of an aligned stream.

    The samples are those of the alignment's read of the same file, so they take its
    reference times; each channel's module delay is scaled by the stream's clock drift as
    :func:`rigval.processing.clock_fit.align_stream` does.

    Raises
    ------
    DataError
        If the file holds another number of samples than when the stream was aligned.
    """
    spec = _stream_part(scene.streams[name], channels)
    part = convert_stream(load_stream(spec, checksum=False), spec)
    if part.sizes["time"] != aligned.sizes["time"]:
        raise DataError(f"stream {name}: {spec.file.name} gave {part.sizes['time']} samples for "
                        f"{channels} but {aligned.sizes['time']} when it was aligned",
                        where={"file": str(spec.file), "stream": name},
                        hint="the file changed during the validation: validate a finished "
                             "copy of the run")
    drift = float(aligned.attrs.get("clock_drift_ppm", 0.0)) * 1e-6
    fs = float(part.attrs["fs_nominal"])
    out = aligned.copy()
    for channel in channels:
        var = part[channel]
        out[channel] = xr.Variable("time", var.to_numpy(), {
            **var.attrs, "input_delay_s": input_delay(var.attrs, fs) * (1.0 + drift)})
    return out


# ---------------------------------------------------------------------------------------------
# angle domain


def _resample_channel(scene: Scene, comparison: ComparisonSpec, aligned: dict[str, xr.Dataset],
                      grid: AngleGrid, done: list[str], diagnosis: dict[str, xr.Dataset]
                      ) -> tuple[np.ndarray, float | None]:
    """Resample a measured channel onto the phi_F grid, (n_cycle, n_angle); NaN at gaps.

    The comparison's ``lowpass_hz`` (zero phase, within gap-free runs) comes first; the
    anti-alias low-pass of :func:`rigval.processing.angle.resample_to_angle` follows.
    The channels ``done`` are dropped from the stream in ``aligned`` once their samples are
    taken, so that each filter's input is freed as its output is made (memory).
    Returns the resampled cycles and the low-pass corner applied in Hz (None: none); puts the
    signal before any low-pass, decimated, into ``diagnosis`` (docs/diagnosis.md).
    """
    stream, name = comparison.measured.stream, comparison.measured.channel
    ds = aligned[stream]
    fs = float(ds.attrs["fs_nominal"])
    delay = float(ds[name].attrs.get("input_delay_s", 0.0))
    values = np.asarray(ds[name].to_numpy(), dtype=np.float64)  # no copy (memory)
    for sign, ref in comparison.terms[1:]:  # channels of the same stream and unit, summed
        values = values + sign * ds[ref.channel].to_numpy().astype(np.float64)
    valid = ds["valid"].to_numpy() & np.isfinite(values)
    segment, time_axis = ds["segment"].to_numpy(), ds["time"]
    if done:
        aligned[stream] = ds.drop_vars(done)
    del ds
    diagnosis[comparison.name] = diagnosis_signal(time_axis.to_numpy() - delay, values, segment,
                                                  valid, fs)
    corner = comparison.lowpass_hz
    if corner is not None and corner < 0.45 * fs:
        values = zero_phase(values, fs, corner, segment=segment, valid=valid)
        valid &= np.isfinite(values)
    # resample_to_angle's anti-alias filter, here so that its input can be freed
    anti_alias = anti_alias_hz(grid, scene.angle.points_per_revolution)
    if anti_alias < 0.45 * fs:
        values = zero_phase(values, fs, anti_alias, order=8, segment=segment, valid=valid)
    _, _, cycles = resample_to_angle(
        time_axis.to_numpy() - delay, values, None, None,  # as align.channel_time
        points_per_rev=scene.angle.points_per_revolution, fs=fs,
        order=INTERPOLATION_ORDER[scene.angle.interpolation], anti_alias="none",
        segment=segment, valid=valid, grid=grid)
    return cycles, corner


# ---------------------------------------------------------------------------------------------
# model


# ---------------------------------------------------------------------------------------------
# compare


def _compare(comparison: ComparisonSpec, units: str, long_name: str, angle: np.ndarray,
             cycles: np.ndarray, model: np.ndarray, u_num: float,
             carried: Mapping[str, float] | None = None) -> ComparisonResult:
    """Score the model against the measured mean, the baseline and the thresholds.

    ``u_num`` is the numerical uncertainty of the model (signal units) for V&V 20; ``carried``
    the uncertainties carried from alignment and drives (``u_time`` s, ``speed`` rad/s,
    ``u_drive_angle`` rad, see :func:`rigval.validation.metrics.vv20.vv20_curve`).
    """
    whole = cycles[np.all(np.isfinite(cycles), axis=1)]
    if whole.shape[0] < 2:
        raise DataError(f"{comparison.name}: only {whole.shape[0]} whole revolutions without "
                        "gaps", where={"key": comparison.key, "channel": str(comparison.measured)},
                        hint="record longer or check the stream's gaps")
    mean = whole.mean(axis=0)
    model = model * comparison.scale
    offset = float(mean.mean() - model.mean()) if comparison.remove_offset else 0.0
    model = model + offset
    scores = compare(mean, model, angle, metrics=(*comparison.metrics, "vv20"),
                     normaliser=comparison.nrmse_normaliser, cycles=whole,
                     uncertainty={"u_num": u_num, **dict(carried or {}),
                                  **comparison.uncertainty})
    base = baseline(whole, mean, angle=angle, metrics=comparison.metrics,
                    normaliser=comparison.nrmse_normaliser)
    checks = check_thresholds(scores, comparison.thresholds,
                              key_path=f"{comparison.key}.thresholds")
    return ComparisonResult(spec=comparison, units=units, long_name=long_name, angle=angle,
                            cycles=whole, model=model, offset=offset, scores=scores,
                            baseline={"median": base.median, "worst": base.worst},
                            checks=tuple(checks))


# ---------------------------------------------------------------------------------------------
# the run's data tree


def _measured_float32(ds: xr.Dataset) -> xr.Dataset:
    out = ds.copy()
    for name, var in ds.data_vars.items():
        if var.dtype.kind == "f":
            out[name] = var.astype(np.float32)
    return out


def _tree(scene: Scene, raw: Mapping[str, xr.Dataset], aligned: Mapping[str, xr.Dataset],
          angle: np.ndarray, grid_times: np.ndarray, measured: Mapping[str, np.ndarray],
          results: tuple[ComparisonResult, ...], model: xr.Dataset, steps: list[str],
          history: list[str]) -> xr.DataTree:
    """Build the run's DataTree; history: the streams' processing lines, then ``steps``.

    ``/raw`` and ``/aligned`` hold the streams given in ``raw`` and ``aligned`` (empty mappings
    when the scene's ``[output]`` does not ask for them).
    """
    cycle = np.arange(grid_times.shape[0])
    angle_ds = xr.Dataset(coords={
        "angle": ("angle", angle, {"units": "rad", "long_name": "main shaft angle phi_F"}),
        "cycle": ("cycle", cycle, {"long_name": "whole revolution index", "units": "1"})})
    angle_ds["time_at_angle"] = (("cycle", "angle"), grid_times, {
        "units": "s", "long_name": "reference time at each grid angle"})
    for result in results:
        name = result.name
        attrs = {"units": result.units, "long_name": result.long_name,
                 "source": result.spec.measured_text}
        angle_ds[name] = (("cycle", "angle"), measured[name].astype(np.float32), attrs)
        low, high = result.band
        stats = {"mean": result.mean, "std": result.cycles.std(axis=0, ddof=1), "p5": low,
                 "p95": high, "min": result.cycles.min(axis=0), "max": result.cycles.max(axis=0)}
        for stat, values in stats.items():
            angle_ds[f"{name}_{stat}"] = ("angle", values,
                                          {**attrs, "cell_methods": f"cycle: {stat}"})
        angle_ds[f"{name}_n"] = ((), result.cycles.shape[0], {"units": "1"})
    model_ds = model.copy()
    for result in results:
        model_ds[f"compared_{result.name}"] = ("angle", result.model, {
            "units": result.units, "long_name": f"{result.spec.model} x {result.spec.scale:g}"
                                                f" + {result.offset:g}"})
    scores = sorted({k for r in results for k, v in r.scores.items()
                     if isinstance(v, int | float) and not isinstance(v, bool)}
                    | {k for r in results for k in r.spec.thresholds})
    table = {row: np.array([[float(source.get(s, np.nan)) for s in scores]
                            for source in sources]) for row, sources in (
        ("model", [r.scores for r in results]),
        ("baseline_median", [r.baseline["median"] for r in results]),
        ("baseline_worst", [r.baseline["worst"] for r in results]))}
    validation = xr.Dataset(
        {f"metrics_{row}": (("comparison", "score"), values, {"units": "1"})
         for row, values in table.items()},
        coords={"comparison": [r.name for r in results], "score": scores})
    validation["passed"] = ("comparison", np.array([r.passed for r in results], dtype=np.int8),
                            {"long_name": "all thresholds met", "units": "1"})
    validation["threshold"] = (("comparison", "score"), np.array(
        [[str(r.spec.thresholds.get(s, "")) for s in scores] for r in results], dtype=object),
        {"long_name": "pass/fail rule on the score, OP LIMIT (empty: none)"})
    nodes: dict[str, xr.Dataset] = {}
    for name, ds in raw.items():
        nodes[f"/raw/{name}"] = _measured_float32(ds)
    for name, ds in aligned.items():
        nodes[f"/aligned/{name}"] = _measured_float32(ds)
    nodes["/angle"] = angle_ds
    nodes["/model"] = model_ds
    nodes["/validation"] = validation
    tree = xr.DataTree.from_dict(nodes)
    tree.attrs["title"] = scene.title
    lines = list(history)
    lines += [f"{datetime.datetime.now(datetime.UTC):%Y-%m-%dT%H:%M:%SZ} rigval {step}"
              for step in steps]
    tree.attrs["history"] = "\n".join(lines)
    return tree


# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Grid:
    """The phi_F grid of a run: whole revolutions, fine grid for the model, the chosen grid."""

    turns: np.ndarray
    fine_angle: np.ndarray
    fine_times: np.ndarray
    speed_rev_s: float

    @property
    def angle(self) -> np.ndarray:
        """The chosen grid's angles over one revolution (rad)."""
        return self.fine_angle[::FINE_FACTOR]

    @property
    def times(self) -> np.ndarray:
        """Reference times of the chosen grid, (n_cycle, n_angle), s."""
        return self.fine_times[:, ::FINE_FACTOR]


def _grid(scene: Scene, main: MainAngle) -> _Grid:
    """Whole revolutions of phi_F and the reference times of the fine and the chosen grid."""
    n = scene.angle.points_per_revolution
    turns, fine_grid = cycle_grid(main.phi[0], main.phi[-1], n * FINE_FACTOR)
    if turns.size < scene.angle.min_cycles:
        raise DataError(f"only {turns.size} whole revolutions in the record, the scene asks "
                        f"for {scene.angle.min_cycles}", where={"key": "angle.min_cycles"},
                        hint="record longer, or lower angle.min_cycles")
    fine_times = main.times_at(fine_grid)
    duration = float(main.times_at(2 * np.pi * (turns[-1] + 1)) - fine_times[0, 0])
    return _Grid(turns, fine_grid[0] - fine_grid[0, 0], fine_times, turns.size / duration)


def _compare_all(scene: Scene, long_names: Mapping[str, str], model: xr.Dataset,
                 grid: _Grid, measured: Mapping[str, np.ndarray],
                 errors: Mapping[str, float], alignment: Mapping[str, StreamAlignment]
                 ) -> tuple[ComparisonResult, ...]:
    results = []
    for comparison in scene.comparisons:
        long_name = long_names[comparison.name]
        if comparison.summed:
            long_name = comparison.measured_text
        values = model_values(model, comparison.model)
        u_num = errors[comparison.name] * float(np.ptp(values)) * abs(comparison.scale)
        carried = carried_uncertainty(scene, alignment[comparison.measured.stream],
                                      grid.speed_rev_s)
        results.append(_compare(comparison, scene.units(comparison.measured), long_name,
                                grid.angle, measured[comparison.name], values, u_num, carried))
    return with_common_gain(scene, results)


def _drop_served(scene: Scene, aligned: dict[str, xr.Dataset], *, model_done: bool) -> None:
    """Drop, in place, the channels that have served their stage.

    After the alignment: the device clocks and the pulse channels; once the model has its
    drives (``model_done``), the drives' encoders too. Compared channels stay.
    """
    needed: dict[str, set[str]] = {}
    for comparison in scene.comparisons:
        for _, ref in comparison.terms:
            needed.setdefault(ref.stream, set()).add(ref.channel)
    if not model_done and scene.model.drives == "measured":
        for driver in scene.model.drivers.values():
            needed.setdefault(driver.encoder.stream, set()).add(driver.encoder.channel)
    for stream, ds in aligned.items():
        keep = needed.get(stream, set()) | {"valid", "segment"}
        aligned[stream] = ds.drop_vars(
            [name for name in ds.data_vars if name not in keep] + ["device_time"],
            errors="ignore")


def _angle_domain(scene: Scene, aligned: dict[str, xr.Dataset], grid: AngleGrid,
                  diagnosis: dict[str, xr.Dataset], *, keep: bool
                  ) -> tuple[dict[str, np.ndarray], dict[str, float | None], dict[str, str]]:
    """Resample every comparison's measured signal onto the phi_F grid, stream by stream.

    Comparison by comparison, its channels not read yet are read, and each is dropped as soon
    as no later comparison of its stream needs it, so that memory holds about one compared
    channel at a time (``keep``: every channel was read and stays, the streams go into the
    output). Returns the resampled cycles, the low-pass corners and the channels' long
    names, by comparison; ``diagnosis`` receives each signal for the residual spectra.
    """
    by_stream: dict[str, list[ComparisonSpec]] = {}
    for comparison in scene.comparisons:
        by_stream.setdefault(comparison.measured.stream, []).append(comparison)
    measured, corners, long_names = {}, {}, {}
    for stream, comparisons in by_stream.items():
        for i, comparison in enumerate(comparisons):
            names = [ref.channel for _, ref in comparison.terms]
            missing = [name for name in dict.fromkeys(names) if name not in aligned[stream]]
            if missing:
                aligned[stream] = _add_channels(scene, stream, aligned[stream], missing)
            channel = comparison.measured.channel
            long_names[comparison.name] = str(aligned[stream][channel].attrs.get(
                "long_name", channel))
            later = {ref.channel for c in comparisons[i + 1:] for _, ref in c.terms}
            done = [] if keep else [name for name in dict.fromkeys(names) if name not in later]
            measured[comparison.name], corners[comparison.name] = _resample_channel(
                scene, comparison, aligned, grid, done, diagnosis)
    return measured, corners, long_names


def _history(scene: Scene, grid: _Grid, corners: Mapping[str, float | None],
             request: Mapping[str, Any], passed: bool) -> list[str]:
    files = ", ".join(spec.file.name for spec in scene.streams.values())
    return [
        f"validation.pipeline read+convert {files}",
        f"validation.pipeline angle: {grid.turns.size} revolutions, "
        f"{scene.angle.points_per_revolution} points per revolution, "
        f"{scene.angle.interpolation} interpolation, low-pass {dict(corners)}",
        f"validation.pipeline model {scene.mechanism.name}: drives {scene.model.drives}, "
        f"outputs {dict(request)}",
        f"validation.pipeline compare {', '.join(c.name for c in scene.comparisons)}: "
        f"{'passed' if passed else 'failed'}"]


def run_scene(scene: Scene | str | Path) -> ValidationResult:
    """Validate one scene: read, convert, align, angle domain, model, compare.

    Parameters
    ----------
    scene : Scene, str or pathlib.Path
        A parsed scene or the path of a scene file.

    Returns
    -------
    ValidationResult
        Everything the report needs; nothing is written.

    Raises
    ------
    SceneError
        For a bad scene, including channels absent from their files and units that do not
        fit the declared sensors.
    RigvalError
        For data that cannot be read, aligned or modelled (``DataFileError``, ``DataError``,
        ``AlignmentError``, ``ModelError``).
    """
    watch = _Stopwatch()
    with watch.stage("read"):
        if not isinstance(scene, Scene):
            scene = load_scene(scene)
        settings = alignment_settings(scene)
        # Streams kept in the output are read whole; otherwise only what the alignment
        # needs, and each compared channel when its comparison comes (memory: see
        # docs/performance.md, long records).
        whole = scene.output.raw or scene.output.aligned
        first = None if whole else _alignment_channels(scene, settings)
    raw: dict[str, xr.Dataset] = {}
    converted: dict[str, xr.Dataset] = {}
    for name, spec in scene.streams.items():
        # stream by stream: one stream as read beside the converted ones, not all of them
        with watch.stage("read"):
            stream = read_streams(scene, first, only=name)[name]
            check_sample_rates(scene, {name: stream})
        with watch.stage("convert"):
            converted[name] = convert_stream(stream, _stream_part(spec, stream.data_vars))
            if not whole:  # float64 counters as exact 32-bit integers (memory)
                _compact_encoders(converted[name], spec)
            if scene.output.raw:
                raw[name] = stream
            del stream
    with watch.stage("align"), encoder_scale_errors(scene):
        # the device clocks go into the output only with [output] aligned
        aligned, diagnostics, main = align_streams(settings, converted,
                                                   device_time=scene.output.aligned)
        del converted
        if not whole:
            _drop_served(scene, aligned, model_done=False)
        grid = _grid(scene, main)
        # the reference times of the comparison grid; phi_F(t) itself is not needed after
        angle_times = angle_grid(main.time, main.phi, scene.angle.points_per_revolution)
        del main
    with watch.stage("model"), encoder_scale_errors(scene):
        mechanism = load_mechanism(scene.mechanism)
        fine = run_model(scene, mechanism, aligned[scene.alignment.reference], grid.fine_times,
                          grid.fine_angle)
        if scene.model.drives == "analytic":
            law_speed = 1.0 / float(fine.attrs["cycle_period_s"])
            if abs(law_speed / grid.speed_rev_s - 1.0) > ANALYTIC_SPEED_TOLERANCE:
                logger.warning("the mechanism's drive law turns at %.4g rev/s, the run at %.4g "
                               "rev/s: forces scale with the square of the speed; consider "
                               'drives = "measured"', law_speed, grid.speed_rev_s)
        model = fine.isel(angle=slice(None, None, FINE_FACTOR))
        if not whole:
            _drop_served(scene, aligned, model_done=True)
    with watch.stage("angle"):
        diagnosis: dict[str, xr.Dataset] = {}
        measured, corners, long_names = _angle_domain(scene, aligned, angle_times, diagnosis,
                                                      keep=whole)
    with watch.stage("numerics"):
        errors = grid_error(scene, fine)
    with watch.stage("compare"):
        results = _compare_all(scene, long_names, model, grid, measured, errors, diagnostics)
    with watch.stage("numerics"):
        residuals = energy_residual(mechanism, scene.angle.points_per_revolution)
        residuals["max condition number (this run)"] = float(
            model.attrs.get("max_condition_number", math.nan))
    passed = all(r.passed for r in results)
    steps = _history(scene, grid, corners, model_request(scene, mechanism), passed)
    history = [line for ds in aligned.values()
               for line in str(ds.attrs.get("history", "")).splitlines()]
    tree = _tree(scene, raw, aligned if scene.output.aligned else {}, grid.angle, grid.times,
                 measured, results, model, steps, history)
    for name, corner in corners.items():  # absent: not low-passed
        if corner is not None:
            tree["/angle"][name].attrs["lowpass_hz"] = float(corner)
    for name, signal in diagnosis.items():  # the residual spectra's input (docs/diagnosis.md)
        tree[f"/diagnosis/{name}"] = xr.DataTree(signal)
    numerics = NumericsSummary(dict(watch.seconds), residuals, errors, grid.fine_angle.size)
    logger.info("validated %s in %.2f s: %s", scene.path.name, sum(watch.seconds.values()),
                "passed" if passed else "failed")
    return ValidationResult(scene=scene, comparisons=results, alignment=diagnostics,
                            predictions=_predicted_outputs(scene, model), numerics=numerics,
                            speed_rev_s=grid.speed_rev_s, n_cycles=int(grid.turns.size),
                            tree=tree)


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
