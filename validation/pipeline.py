"""The validation pipeline: scene -> read -> convert -> align -> angle domain -> model -> compare.

:func:`run_scene` validates one scene and returns a
:class:`~rigval.validation.results.ValidationResult` (nothing written); :func:`validate_scene`
also writes the report folder. Stages, timed one by one:

read
    Each stream's file, only the channels the scene names
    (:func:`rigval.acquisition.channel_map.load_stream`).
convert
    Raw channels to physical units (:mod:`rigval.validation.convert`).
align
    phi_F(t) from the main encoder (smoothed, never differenced raw), zero at the reference
    pulse; each other stream's clock fitted on its reference pulses against the events the
    encoder angle predicts (:mod:`rigval.processing.align`), module input delays removed.
angle
    Whole revolutions; each compared channel low-passed (its ``lowpass_hz``) within gap-free
    runs, then resampled at the reference times of the uniform phi_F grid with the
    anti-aliasing of :func:`rigval.processing.angle.resample_to_angle`; revolutions touching a
    gap are dropped for that channel.
model
    Only the outputs the comparisons and predictions name, on the phi_F grid: with measured
    drives, each driver's angle, speed and acceleration from its encoder averaged over the
    revolutions at each grid angle; with analytic drives, the mechanism file's laws. The model
    runs on a grid four times finer, so that the error of the chosen grid is measured.
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
import json
import logging
import math
import time
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import scipy.interpolate
import xarray as xr

from rigval.acquisition.channel_map import ChannelSpec, load_stream
from rigval.acquisition.errors import AlignmentError, ConfigError, DataError
from rigval.acquisition.schema import parse_start_time
from rigval.model.mechanism import Mechanism, load_mechanism
from rigval.model.solver import solve, solve_cycle
from rigval.processing.align import (
    ClockModel,
    align_stream,
    channel_time,
    estimate_clock,
    identity_clock,
    match_events,
    reference_event_times,
)
from rigval.processing.angle import cycle_grid, phi_f, resample_to_angle
from rigval.processing.excitation import drive_excitation
from rigval.processing.filters import zero_phase
from rigval.processing.pulses import StreamPulses, stream_pulses
from rigval.validation.convert import convert_stream
from rigval.validation.metrics import baseline, check_thresholds, compare
from rigval.validation.results import (
    ComparisonResult,
    NumericsSummary,
    StreamAlignment,
    ValidationResult,
)
from rigval.validation.scene import ComparisonSpec, ModelOutput, Scene, load_scene

__all__ = ["FINE_FACTOR", "MainAngle", "align_streams", "read_streams", "run_scene",
           "validate_scene"]

logger = logging.getLogger(__name__)

#: The model also runs on a grid this many times finer, to measure the chosen grid's error.
FINE_FACTOR = 4
#: How far (s) a start time written by a device may be off: software time stamps.
START_TIME_ERROR_S = 5.0
#: Start times in or before this year mean "unknown" (NI writes 1904-01-01 for relative time).
UNKNOWN_START_YEAR = 1904
#: Matched events farther than this many robust sigmas from the clock fit count as spurious.
OUTLIER_SIGMAS = 6.0
#: ... unless they are within this distance in s (a sample period of the slowest device).
MIN_EVENT_TOLERANCE_S = 1e-3
#: Spline order of the scene's ``angle.interpolation``.
INTERPOLATION_ORDER = {"linear": 1, "cubic": 3}
#: Relative difference of the analytic drive law's speed from the run's that is reported.
ANALYTIC_SPEED_TOLERANCE = 0.02
#: Hysteresis half-band of a reference pulse's ``threshold``, as a fraction of it.
PULSE_HYSTERESIS = 0.1
#: Half-width of the raw-pulse window in the alignment figure, in main-shaft periods.
PULSE_WINDOW = 0.04

_ITEM_DIM = {"position": ("body", "coord"), "velocity": ("body", "coord"),
             "acceleration": ("body", "coord"), "point_position": ("point", "axis"),
             "point_velocity": ("point", "axis"), "point_acceleration": ("point", "axis"),
             "joint_force": ("joint", "axis"), "driver_torque": ("driver", None)}


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
            logger.info("stage %s: %.3f s", name, self.seconds[name])


@dataclass(frozen=True)
class MainAngle:
    """phi_F, the main shaft angle from the reference position, on the reference timeline.

    Parameters
    ----------
    time : numpy.ndarray
        Reference-clock times in s where the encoder angle is defined.
    phi : numpy.ndarray
        phi_F in rad, increasing, multiples of 2 pi at the reference pulse.
    """

    time: np.ndarray
    phi: np.ndarray

    def times_at(self, angles: np.ndarray) -> np.ndarray:
        """Return the reference times (s) at which phi_F takes the given values (rad)."""
        return np.interp(angles, self.phi, self.time)


# ---------------------------------------------------------------------------------------------
# align


def _pulses(stream: xr.Dataset, channel: ChannelSpec) -> StreamPulses:
    """Edges of a reference-pulse channel (delay-corrected, classified) as its table says."""
    threshold = channel.params.get("threshold")
    low = high = None
    if threshold is not None:
        band = PULSE_HYSTERESIS * max(abs(threshold), float(np.finfo(float).tiny))
        low, high = threshold - band, threshold + band
    return stream_pulses(stream, channel.name, polarity=channel.params.get("edge", "rising"),
                         low=low, high=high)


def _main_angle(scene: Scene, ref: xr.Dataset) -> tuple[MainAngle, StreamPulses]:
    """Return phi_F(t) from the main encoder, zero at the reference pulse, and those pulses."""
    encoder = scene.alignment.main_encoder
    params = scene.channel(encoder).params
    directions = [d.direction for d in scene.model.drivers.values() if d.encoder == encoder]
    pulses = _pulses(ref, scene.channel(scene.alignment.main_reference_pulse))
    if pulses.good.size < scene.angle.min_cycles:
        raise DataError(f"only {pulses.good.size} reference pulses on "
                        f"{scene.alignment.main_reference_pulse}",
                        where={"key": "alignment.main_reference_pulse"},
                        hint="check the pulse channel (threshold, edge, wiring)")
    angle = phi_f(ref, encoder.channel, pulses, counts_per_rev=params["counts_per_rev"],
                  direction=float(directions[0] if directions else 1),
                  index_reset=bool(params.get("index_reset", False)))
    t = channel_time(ref, encoder.channel)
    phi = angle["phi_F"].to_numpy()
    finite = np.isfinite(phi)
    t, phi = t[finite], phi[finite]
    if phi.size < 2 or np.any(np.diff(phi) <= 0):
        raise DataError("the main shaft angle does not increase steadily (standstill, reversal "
                        "or the encoder counting down)", where={"channel": str(encoder)},
                        hint="validate runs at steady speed; set direction = -1 in the driver "
                             "table of an encoder that counts down")
    return MainAngle(t, phi), pulses


def _residuals(mapped: np.ndarray, events: np.ndarray, period: float, per_revolution: int = 1
               ) -> tuple[np.ndarray, np.ndarray]:
    """Residual of each mapped event against its nearest expected event; matched mask.

    With several pulses per revolution, each kind of pulse (its place within the revolution)
    may fire at its own angle; the median residual of each kind is removed, as the clock fit
    does.
    """
    index = np.clip(np.searchsorted(events, mapped), 1, events.size - 1)
    nearest = np.where(np.abs(mapped - events[index - 1]) <= np.abs(events[index] - mapped),
                       index - 1, index)
    residual = mapped - events[nearest]
    matched = np.abs(residual) < 0.25 * period / per_revolution
    if matched.sum() > 3:  # a spurious pulse can fall inside a quarter period: robust cut
        spread = 1.4826 * float(np.median(np.abs(residual[matched]
                                                 - np.median(residual[matched]))))
        matched &= np.abs(residual - np.median(residual[matched])) <= max(
            OUTLIER_SIGMAS * spread, MIN_EVENT_TOLERANCE_S)
    if per_revolution > 1:
        kind = nearest % per_revolution
        for k in range(per_revolution):
            chosen = matched & (kind == k)
            if chosen.any():
                residual[kind == k] -= np.median(residual[chosen])
    return residual, matched


def _recover_segments(clock: ClockModel, events: np.ndarray, edges: np.ndarray,
                      segments: np.ndarray, period: float, per_revolution: int,
                      where: Mapping[str, Any]) -> ClockModel:
    """Align segments the clock fit left out, then refit all segments with one shared drift.

    A restart (Wi-Fi dropout) starts a segment whose device time comes from a new software
    start stamp, off by milliseconds, not periods: matching it within +-0.4 of a pulse period
    around the previous segment's offset removes the whole-period ambiguity a short segment
    has on its own. Every segment's events are then matched around its offset and one least
    squares fit gives a shared drift, an offset per segment and, with several pulses per
    revolution, a constant per kind of pulse (each may fire at its own angle); events beyond
    6 robust sigma are left out. The drift so rests on the whole record.
    """
    if not clock.unaligned_segments:
        return clock
    offsets = dict(zip(clock.segments, clock.offsets_s, strict=True))
    pairs: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    for segment in sorted(set(np.unique(segments).tolist())):
        known = sorted(offsets, key=lambda s: (abs(s - segment), s > segment))
        chosen = segments == segment
        if not known or chosen.sum() < 2:
            continue
        coarse = offsets.get(segment, offsets[known[0]])
        try:
            ref_index, dev_index = match_events(
                events, edges[chosen], coarse_offset_s=coarse, max_offset_error_s=0.4 * period,
                where={**where, "segment": int(segment)})
        except AlignmentError as error:
            logger.info("segment %d stays unaligned: %s", segment, error)
            continue
        if ref_index.size >= 2:
            pairs.append((ref_index, edges[chosen][dev_index], np.full(ref_index.size, segment)))
            offsets.setdefault(int(segment), coarse)
    index, dev, seg = (np.concatenate(column) for column in zip(*pairs, strict=True))
    ref, kind = events[index], index % per_revolution
    order = sorted(set(seg.tolist()))
    columns = [(seg == s).astype(float) for s in order]
    columns += [(kind == k).astype(float) for k in range(1, per_revolution)] + [dev]
    design = np.column_stack(columns)
    keep = np.ones(ref.size, dtype=bool)
    for _ in range(2):
        solution, *_ = np.linalg.lstsq(design[keep], ref[keep] - dev[keep], rcond=None)
        residual = ref - dev - design @ solution
        spread = 1.4826 * float(np.median(np.abs(residual[keep] - np.median(residual[keep]))))
        keep = np.abs(residual) <= max(OUTLIER_SIGMAS * spread, 1e-9)
    logger.info("clock refit on %d events of segments %s: drift %.4f ppm", int(keep.sum()),
                order, solution[-1] * 1e6)
    return dataclasses.replace(
        clock, segments=tuple(int(s) for s in order),
        offsets_s=tuple(float(solution[i]) for i in range(len(order))),
        drift=float(solution[-1]), residual_rms_s=float(np.sqrt(np.mean(residual[keep] ** 2))),
        pulses_matched=int(keep.sum()),
        unaligned_segments=tuple(s for s in clock.unaligned_segments if s not in order))


def _with_pulse_window(summary: StreamAlignment, aligned: xr.Dataset, channel: str,
                       edges: np.ndarray, centre: float, half_width: float) -> StreamAlignment:
    """Attach the raw pulse signal and its edges within ``centre +- half_width`` (s)."""
    t = channel_time(aligned, channel)
    inside = np.abs(t - centre) <= half_width
    return dataclasses.replace(
        summary, pulse_time=t[inside], pulse_signal=aligned[channel].to_numpy()[inside],
        pulse_units=str(aligned[channel].attrs.get("units", "")),
        edge_times=edges[np.abs(edges - centre) <= half_width])


def _common_pulse(pulses: np.ndarray, spans: list[tuple[float, float]], margin: float) -> float:
    """Return the first reference pulse that every stream recorded (else the first pulse)."""
    start = max(span[0] for span in spans) + margin
    stop = min(span[1] for span in spans) - margin
    inside = pulses[(pulses >= start) & (pulses <= stop)]
    return float(inside[0] if inside.size else pulses[0])


def _stream_summary(name: str, aligned: xr.Dataset, clock: ClockModel, *, is_reference: bool,
                    residual_time: np.ndarray, residual: np.ndarray, matched: int,
                    missing: int, spurious: int) -> StreamAlignment:
    empty = np.zeros(0)
    delays = [float(aligned[v].attrs.get("input_delay_s", 0.0)) for v in aligned.data_vars
              if v not in ("valid", "segment")]
    times = aligned["time"].to_numpy()
    return StreamAlignment(
        stream=name, device=str(aligned.attrs.get("device", "")), is_reference=is_reference,
        offset_s=float(clock.offsets_s[0]), drift_ppm=clock.drift * 1e6,
        residual_rms_s=float(np.sqrt(np.mean(residual**2))) if residual.size else 0.0,
        events_matched=matched, events_missing=missing, events_spurious=spurious,
        input_delay_s=max(delays, default=0.0), segments=len(clock.segments),
        gaps=tuple(json.loads(aligned.attrs.get("gaps", "[]"))),
        span_s=(float(times[0]), float(times[-1])), residual_time=residual_time,
        residual_s=residual, pulse_time=empty, pulse_signal=empty, pulse_units="",
        edge_times=empty)


def _coarse_offset(stream: xr.Dataset, ref: xr.Dataset, ref_start: np.datetime64
                   ) -> tuple[float, float]:
    """Return a first guess of ``t_ref - t_dev`` in s and how far to search around it.

    From the files' start times when both are known (search +-5 s: software time stamps); a
    file without a start time (1904-01-01, e.g. a CSV with relative time) is searched over the
    whole overlap of the two records.
    """
    start = parse_start_time(stream.attrs["start_time"])
    if start.astype("datetime64[Y]").astype(int) + 1970 > UNKNOWN_START_YEAR and (
            ref_start.astype("datetime64[Y]").astype(int) + 1970 > UNKNOWN_START_YEAR):
        return float((start - ref_start) / np.timedelta64(1, "s")), START_TIME_ERROR_S
    ref_span = float(ref["time"].values[-1] - ref["time"].values[0])
    dev_span = float(stream["time"].values[-1] - stream["time"].values[0])
    logger.info("stream %s has no start time: searching offsets over the whole record",
                stream.attrs.get("stream", ""))
    return 0.5 * (ref_span - dev_span), 0.5 * (ref_span + dev_span)


def read_streams(scene: Scene) -> dict[str, xr.Dataset]:
    """Read every stream of a scene: the mapped channels under their scene names.

    Parameters
    ----------
    scene : Scene
        The scene.

    Returns
    -------
    dict of str to xarray.Dataset
        Stream name -> stream as read (raw units).
    """
    return {name: load_stream(spec) for name, spec in scene.streams.items()}


def align_streams(scene: Scene, converted: Mapping[str, xr.Dataset]
                  ) -> tuple[dict[str, xr.Dataset], dict[str, StreamAlignment], MainAngle]:
    """Put every stream on the reference timeline.

    Parameters
    ----------
    scene : Scene
        The scene (its ``[alignment]`` table).
    converted : mapping of str to xarray.Dataset
        The streams after :func:`rigval.validation.convert.convert_stream`.

    Returns
    -------
    aligned : dict of str to xarray.Dataset
        Streams with ``time`` on the reference clock (samples unchanged).
    diagnostics : dict of str to StreamAlignment
        Clock model, events and gaps per stream.
    main : MainAngle
        phi_F(t).

    Raises
    ------
    AlignmentError
        When a stream's clock cannot be fitted with confidence.
    """
    reference = scene.alignment.reference
    ref = align_stream(converted[reference], identity_clock(converted[reference]["segment"]),
                       name=reference)
    main, ref_pulses = _main_angle(scene, ref)
    pulses = ref_pulses.good[(ref_pulses.good >= main.time[0])
                             & (ref_pulses.good <= main.time[-1])]
    period = float(np.median(np.diff(pulses)))
    expected = main.times_at(2.0 * np.pi * np.arange(math.ceil(main.phi[0] / (2 * np.pi)),
                                                     math.floor(main.phi[-1] / (2 * np.pi)) + 1))
    residual, matched = _residuals(pulses, expected, period)
    aligned = {reference: ref}
    diagnostics = {reference: _stream_summary(
        reference, ref, identity_clock(), is_reference=True, residual_time=pulses,
        residual=residual[matched], matched=int(matched.sum()),
        missing=max(expected.size - int(matched.sum()), 0),
        spurious=int(ref_pulses.spurious.sum()))}
    shown = {reference: (scene.alignment.main_reference_pulse.channel, pulses)}
    ref_start = parse_start_time(ref.attrs["start_time"])
    for name, pulse in scene.alignment.pulses.items():
        stream = converted[name]
        channel = pulse.channel.channel
        found = _pulses(stream, scene.channel(pulse.channel))
        edges, segments = found.times[~found.spurious], found.segment[~found.spurious]
        events = reference_event_times(main.time, main.phi, event_angle=pulse.angle,
                                       events_per_rev=pulse.per_revolution)
        coarse, search = _coarse_offset(stream, ref, ref_start)
        where = {"stream": name, "channel": channel}
        clock = estimate_clock(events, edges, segments, coarse_offset_s=coarse,
                               max_offset_error_s=search, where=where)
        clock = _recover_segments(clock, events, edges, segments, period,
                                  pulse.per_revolution, where)
        aligned[name] = align_stream(stream, clock, name=name)
        mapped = clock.to_reference(edges, segments)
        ok = np.isfinite(mapped)
        residual, matched = _residuals(mapped[ok], events, period, pulse.per_revolution)
        inside = (events >= aligned[name]["time"].values[0]) & (
            events <= aligned[name]["time"].values[-1])
        diagnostics[name] = _stream_summary(
            name, aligned[name], clock, is_reference=False,
            residual_time=mapped[ok][matched], residual=residual[matched],
            matched=int(matched.sum()), missing=max(int(inside.sum()) - int(matched.sum()), 0),
            spurious=int((~matched).sum() + found.spurious.sum()))
        shown[name] = (channel, mapped[ok])
    half_width = PULSE_WINDOW * period
    centre = _common_pulse(pulses, [d.span_s for d in diagnostics.values()], half_width)
    diagnostics = {name: _with_pulse_window(summary, aligned[name], *shown[name], centre,
                                            half_width)
                   for name, summary in diagnostics.items()}
    return aligned, diagnostics, main


# ---------------------------------------------------------------------------------------------
# angle domain


def _resample_channel(scene: Scene, comparison: ComparisonSpec, aligned: xr.Dataset,
                      main: MainAngle) -> tuple[np.ndarray, float | None]:
    """Resample a measured channel onto the phi_F grid, (n_cycle, n_angle); NaN at gaps.

    The comparison's ``lowpass_hz`` (zero phase, within gap-free runs) comes first; the
    anti-alias low-pass of :func:`rigval.processing.angle.resample_to_angle` follows.
    Returns the resampled cycles and the low-pass corner applied in Hz (None: none).
    """
    name = comparison.measured.channel
    fs = float(aligned.attrs["fs_nominal"])
    values = aligned[name].to_numpy().astype(np.float64)
    valid = aligned["valid"].to_numpy() & np.isfinite(values)
    segment = aligned["segment"].to_numpy()
    corner = comparison.lowpass_hz
    if corner is not None and corner < 0.45 * fs:
        values = zero_phase(values, fs, corner, segment=segment, valid=valid)
        valid &= np.isfinite(values)
    _, _, cycles = resample_to_angle(
        channel_time(aligned, name), values, main.time, main.phi,
        points_per_rev=scene.angle.points_per_revolution, fs=fs,
        order=INTERPOLATION_ORDER[scene.angle.interpolation], segment=segment, valid=valid)
    return cycles, corner


# ---------------------------------------------------------------------------------------------
# model


def _model_request(scene: Scene, mechanism: Mechanism) -> dict[str, Any]:
    """Return the outputs, points and joints the comparisons and predictions need, only."""
    outputs = {c.model.quantity for c in scene.comparisons}
    points = {c.model.item for c in scene.comparisons if c.model.quantity.startswith("point_")}
    joints = {c.model.item for c in scene.comparisons if c.model.quantity == "joint_force"}
    if scene.predictions.points:
        outputs |= {"point_position", "point_velocity", "point_acceleration"}
        points |= set(scene.predictions.points)
    if scene.predictions.supports is None or scene.predictions.supports:
        outputs.add("support_force")
    request: dict[str, Any] = {"outputs": sorted(outputs)}
    if points:
        request["points"] = [p for p in mechanism.point_names if p in points]
    if joints:
        request["joints"] = [j for j in mechanism.joint_names if j in joints]
    return request


def _measured_drives(scene: Scene, ref: xr.Dataset, fine_times: np.ndarray
                     ) -> tuple[np.ndarray, dict[str, tuple[np.ndarray, ...]]]:
    """Drive angle, speed and acceleration per driver, averaged over revolutions per angle.

    Parameters
    ----------
    fine_times : numpy.ndarray
        Reference times of the fine phi_F grid, (n_cycle, n_fine).

    Returns
    -------
    times : numpy.ndarray
        Mean time since the start of the revolution per grid angle (s), for the solver.
    drives : dict
        Driver name -> (theta, omega, alpha) on the fine grid.
    """
    drives = {}
    for name, driver in scene.model.drivers.items():
        counts_per_rev = scene.channel(driver.encoder).params["counts_per_rev"]
        excitation = drive_excitation(
            ref, driver.encoder.channel, counts_per_rev=counts_per_rev, name=name,
            direction=float(driver.direction),
            index_reset=bool(scene.channel(driver.encoder).params.get("index_reset", False)))
        t = channel_time(ref, driver.encoder.channel)
        sampled = []
        for suffix in ("", "_dot", "_ddot"):
            values = excitation[f"{name}{suffix}"].to_numpy()
            finite = np.isfinite(values)
            sampled.append(np.interp(fine_times, t[finite], values[finite]))
        theta = sampled[0] - sampled[0][0, 0] + driver.angle_at_reference
        theta -= 2.0 * np.pi * np.round((theta[:, :1] - theta[0, 0]) / (2.0 * np.pi))
        drives[name] = (theta.mean(axis=0), sampled[1].mean(axis=0), sampled[2].mean(axis=0))
    times = (fine_times - fine_times[:, :1]).mean(axis=0)
    return times, drives


def _run_model(scene: Scene, mechanism: Mechanism, ref: xr.Dataset, fine_times: np.ndarray,
               fine_angle: np.ndarray) -> xr.Dataset:
    """Solve the model on the fine phi_F grid; return it with dim ``angle`` (rad)."""
    request = _model_request(scene, mechanism)
    if scene.model.drives == "analytic":
        return solve_cycle(mechanism, fine_angle.size, **request)
    times, drives = _measured_drives(scene, ref, fine_times)
    ds = solve(mechanism, times, drives=drives, **request)
    for name, (theta, omega, alpha) in drives.items():
        ds[f"drive_{name}"] = ("time", theta, {"units": "rad", "long_name": f"{name}, mean"})
        ds[f"drive_{name}_dot"] = ("time", omega, {"units": "rad s-1"})
        ds[f"drive_{name}_ddot"] = ("time", alpha, {"units": "rad s-2"})
    ds = ds.assign_coords(angle=("time", fine_angle, {"units": "rad", "long_name": "phi_F"}))
    return ds.swap_dims(time="angle")


def _model_values(model: xr.Dataset, output: ModelOutput) -> np.ndarray:
    """One model quantity as a vector over ``angle``."""
    item_dim, axis_dim = _ITEM_DIM[output.quantity]
    var = model[output.quantity].sel({item_dim: output.item})
    if axis_dim is not None:
        var = var.sel({axis_dim: output.axis})
    return var.to_numpy().astype(np.float64)


def _periodic_interp(angle: np.ndarray, values: np.ndarray, targets: np.ndarray) -> np.ndarray:
    closed = np.append(angle, angle[0] + 2.0 * np.pi)
    spline = scipy.interpolate.CubicSpline(closed, np.append(values, values[0]),
                                           bc_type="periodic")
    return spline(targets)


def _grid_error(scene: Scene, fine: xr.Dataset) -> dict[str, float]:
    """Per comparison: max |model on the grid, interpolated - model on the fine grid| / range."""
    angle = fine["angle"].to_numpy()
    errors = {}
    for comparison in scene.comparisons:
        values = _model_values(fine, comparison.model)
        coarse = _periodic_interp(angle[::FINE_FACTOR], values[::FINE_FACTOR], angle)
        span = float(np.ptp(values)) or 1.0
        errors[comparison.name] = float(np.max(np.abs(coarse - values)) / span)
    return errors


def _energy_residual(mechanism: Mechanism, points: int) -> dict[str, float]:
    """Power balance of the model on the file's drive laws: drive power against dE/dt."""
    try:
        cycle = solve_cycle(mechanism, points, outputs=["kinetic_energy", "potential_energy",
                                                         "drive_power"])
    except ConfigError as error:  # drive laws that do not repeat per revolution
        logger.info("power balance skipped: %s", error)
        return {}
    energy = (cycle["kinetic_energy"] + cycle["potential_energy"]).to_numpy()
    power = cycle["drive_power"].sum("driver").to_numpy()
    slope = float(cycle.attrs["cycle_period_s"]) / (2 * np.pi)
    # dE/dt = (dE/dphi) / (dt/dphi); t(phi) - slope phi is periodic, so both derivatives are
    # spectral (exact to rounding for these smooth periodic signals)
    dt_dphi = _periodic_derivative(cycle["time"].to_numpy() - slope * cycle["angle"].to_numpy())
    balance = power - _periodic_derivative(energy) / (dt_dphi + slope)
    return {"power balance max |P - dE/dt| / max |P|":
            float(np.max(np.abs(balance)) / max(float(np.max(np.abs(power))), 1e-300)),
            "max condition number of C_e": float(cycle.attrs["max_condition_number"]),
            "Newton tolerance": float(cycle.attrs["newton_tol"])}


def _periodic_derivative(values: np.ndarray) -> np.ndarray:
    """d/dphi of samples of a periodic function on a uniform grid over one revolution."""
    spectrum = np.fft.rfft(values)
    order = np.arange(spectrum.size, dtype=np.float64)
    if values.size % 2 == 0:
        order[-1] = 0.0  # the Nyquist term has no defined derivative
    return np.fft.irfft(1j * order * spectrum, n=values.size)


# ---------------------------------------------------------------------------------------------
# compare


def _compare(comparison: ComparisonSpec, units: str, long_name: str, angle: np.ndarray,
             cycles: np.ndarray, model: np.ndarray, u_num: float) -> ComparisonResult:
    """Score the model against the measured mean, the baseline and the thresholds.

    ``u_num`` is the numerical uncertainty of the model (signal units) for V&V 20.
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
                     uncertainty={"u_num": u_num, **comparison.uncertainty})
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
          results: tuple[ComparisonResult, ...], model: xr.Dataset, steps: list[str]
          ) -> xr.DataTree:
    """Build the run's DataTree; history: the streams' processing lines, then ``steps``."""
    cycle = np.arange(grid_times.shape[0])
    angle_ds = xr.Dataset(coords={
        "angle": ("angle", angle, {"units": "rad", "long_name": "main shaft angle phi_F"}),
        "cycle": ("cycle", cycle, {"long_name": "whole revolution index", "units": "1"})})
    angle_ds["time_at_angle"] = (("cycle", "angle"), grid_times, {
        "units": "s", "long_name": "reference time at each grid angle"})
    for result in results:
        name = result.name
        attrs = {"units": result.units, "long_name": result.long_name,
                 "source": str(result.spec.measured)}
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
                     if isinstance(v, int | float) and not isinstance(v, bool)})
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
    validation.attrs["thresholds"] = json.dumps({r.name: dict(r.spec.thresholds)
                                                 for r in results})
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
    lines = [line for ds in aligned.values()
             for line in str(ds.attrs.get("history", "")).splitlines()]
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


def _compare_all(scene: Scene, aligned: Mapping[str, xr.Dataset], model: xr.Dataset,
                 grid: _Grid, measured: Mapping[str, np.ndarray],
                 grid_error: Mapping[str, float]) -> tuple[ComparisonResult, ...]:
    results = []
    for comparison in scene.comparisons:
        channel = scene.channel(comparison.measured)
        long_name = str(aligned[comparison.measured.stream][channel.name].attrs.get(
            "long_name", channel.name))
        values = _model_values(model, comparison.model)
        u_num = grid_error[comparison.name] * float(np.ptp(values)) * abs(comparison.scale)
        results.append(_compare(comparison, scene.units(comparison.measured), long_name,
                                grid.angle, measured[comparison.name], values, u_num))
    return tuple(results)


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
        raw = read_streams(scene)
    with watch.stage("convert"):
        converted = {name: convert_stream(raw[name], spec) for name, spec in scene.streams.items()}
    with watch.stage("align"):
        aligned, diagnostics, main = align_streams(scene, converted)
    with watch.stage("angle"):
        grid = _grid(scene, main)
        measured, corners = {}, {}
        for comparison in scene.comparisons:
            measured[comparison.name], corners[comparison.name] = _resample_channel(
                scene, comparison, aligned[comparison.measured.stream], main)
    with watch.stage("model"):
        mechanism = load_mechanism(scene.mechanism)
        fine = _run_model(scene, mechanism, aligned[scene.alignment.reference], grid.fine_times,
                          grid.fine_angle)
        if scene.model.drives == "analytic":
            law_speed = 1.0 / float(fine.attrs["cycle_period_s"])
            if abs(law_speed / grid.speed_rev_s - 1.0) > ANALYTIC_SPEED_TOLERANCE:
                logger.warning("the mechanism's drive law turns at %.4g rev/s, the run at %.4g "
                               "rev/s: forces scale with the square of the speed; consider "
                               'drives = "measured"', law_speed, grid.speed_rev_s)
        model = fine.isel(angle=slice(None, None, FINE_FACTOR))
    with watch.stage("numerics"):
        grid_error = _grid_error(scene, fine)
    with watch.stage("compare"):
        results = _compare_all(scene, aligned, model, grid, measured, grid_error)
    with watch.stage("numerics"):
        residuals = _energy_residual(mechanism, scene.angle.points_per_revolution)
        residuals["max condition number (this run)"] = float(
            model.attrs.get("max_condition_number", math.nan))
    passed = all(r.passed for r in results)
    steps = _history(scene, grid, corners, _model_request(scene, mechanism), passed)
    tree = _tree(scene, raw, aligned, grid.angle, grid.times, measured, results, model, steps)
    tree["/angle"].attrs["lowpass_hz"] = json.dumps(corners)
    numerics = NumericsSummary(dict(watch.seconds), residuals, grid_error, grid.fine_angle.size)
    logger.info("validated %s in %.2f s: %s", scene.path.name, sum(watch.seconds.values()),
                "passed" if passed else "failed")
    return ValidationResult(scene=scene, comparisons=results, alignment=diagnostics,
                            predictions=_predictions(scene, model), numerics=numerics,
                            speed_rev_s=grid.speed_rev_s, n_cycles=int(grid.turns.size),
                            tree=tree)


def _predictions(scene: Scene, model: xr.Dataset) -> xr.Dataset:
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


def validate_scene(scene_path: str | Path, out_dir: str | Path) -> ValidationResult:
    """Validate a scene and write its report folder.

    Parameters
    ----------
    scene_path : str or pathlib.Path
        The scene file.
    out_dir : str or pathlib.Path
        The report folder (created; files in it are overwritten).

    Returns
    -------
    ValidationResult
        With ``passed``, ``metric_rows()``, ``outputs`` (files written), ``inputs`` (files read)
        and ``speed_rev_s``.
    """
    from rigval.validation.report import write_report

    result = run_scene(scene_path)
    write_report(result, out_dir)
    return result
