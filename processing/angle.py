"""The angle domain: phi_F zeroed at the optical reference, cycles, resampling onto an angle grid.

phi_F(t) comes from the main-shaft encoder (dense: it follows the speed variation inside a
revolution), smoothed (:mod:`rigval.processing.excitation`) and zeroed so that the optical
reference pulses fall on multiples of 2 pi (:func:`zero_at_reference`). A cycle is one revolution
``[2 pi k, 2 pi (k + 1))``.

Resampling (computed order tracking, [Fyfe-Munck] and [Blough] in docs/references.md): the times of
the grid angles follow from a cubic spline through the inverse of the increasing phi_F(t)
(``np.interp`` alone limits the accuracy to 4e-6 at 0.05 fs); each channel is evaluated at those
times (minus its module input delay) with an interpolating spline of the chosen order (quintic by
default), per gap-free run and in overlapping chunks (bounded memory); grid points that fall in a
gap or an invalid stretch are NaN, never filled. When the angle grid is coarser in time than the
samples (``points_per_rev * f_rot < fs``) the channel is first low-passed (zero phase, per run) at
0.4 times the grid rate at the lowest speed, so nothing aliases.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike
from scipy.interpolate import make_interp_spline
from scipy.ndimage import map_coordinates, spline_filter1d

from rigval.acquisition.errors import ConfigError, DataError
from rigval.acquisition.sample_times import SampleTimes, sample_times, times_of
from rigval.acquisition.schema import append_history
from rigval.processing.arrays import FloatArray, IntArray
from rigval.processing.block_median import exact_median
from rigval.processing.clock_fit import channel_time
from rigval.processing.encoder import (
    counter_revolution_check,
    increasing_angle,
    interp_minus,
)
from rigval.processing.excitation import Method, drive_excitation
from rigval.processing.filters import contiguous_runs, zero_phase
from rigval.processing.pulses import StreamPulses
from rigval.processing.selection import merged_history, selected_channels

#: Low-pass before resampling to the angle grid: zero-phase Butterworth, or none.
AntiAlias = Literal["butterworth", "none"]

__all__ = [
    "AngleGrid",
    "angle_domain",
    "angle_grid",
    "anti_alias_hz",
    "cycle_angles",
    "cycle_grid",
    "interpolate_runs",
    "phi_f",
    "resample_to_angle",
    "whole_cycles",
    "zero_at_reference",
]

logger = logging.getLogger(__name__)


#: Samples per spline chunk and the overlap on each side (spline end effects decay by ~0.27 per
#: sample for a cubic and ~0.43 for a quintic, so 64 samples put them far below rounding).
_CHUNK = 1 << 17
_OVERLAP = 64
#: Largest departure of a chunk's sample times from a uniform step, as a fraction of the step,
#: for which the uniform (cardinal) spline is used: an offset of this size moves a value by
#: ``2 pi f/fs * 1e-6`` of its amplitude (3e-7 at 0.05 fs), far below the cubic spline's own
#: error there (1.4e-4); clock-mapped times of an hour's record depart by about 1e-8.
_UNIFORM_TOLERANCE = 1e-6


def zero_at_reference(time: ArrayLike | SampleTimes, angle: ArrayLike, event_times: ArrayLike,
                      *, events_per_rev: int = 1) -> tuple[float, float]:
    """Return the angle offset that puts the reference events on multiples of 2 pi.

    Parameters
    ----------
    time : array_like or SampleTimes
        Sample times in s (a lazy axis's computed where read).
    angle : array_like
        Unwrapped drive angle in rad (smoothed); NaN samples are skipped.
    event_times : array_like
        Reference pulse times in s on the same clock (spurious pulses removed).
    events_per_rev : int, default 1
        Reference pulses per revolution.

    Returns
    -------
    offset : float
        Subtract from ``angle`` to get phi_F (rad).
    scatter : float
        Rms scatter of the events about the reference position in rad (pulse jitter, encoder
        errors).
    """
    t = times_of(time)
    phi = np.asarray(angle, dtype=np.float64)
    finite = np.isfinite(phi)
    if not finite.all():  # no copies of a record that is finite throughout (memory)
        t, phi = t[finite], phi[finite]
    events = np.asarray(event_times, dtype=np.float64)
    events = events[(events >= t[0]) & (events <= t[-1])]
    if events.size == 0:
        raise DataError("no reference event lies inside the angle record",
                        hint="check that the pulse and encoder channels come from the same run")
    step = 2.0 * np.pi / events_per_rev
    at_events = interp_minus(events, t, phi)  # np.interp's values, no copy of a read-only t
    phase = np.angle(np.mean(np.exp(1j * at_events * events_per_rev))) / events_per_rev
    deviation = np.mod(at_events - phase + step / 2, step) - step / 2
    return float(phase + np.mean(deviation)), float(np.std(deviation))


def cycle_grid(angle_start: float, angle_stop: float, points_per_rev: int,
               ) -> tuple[IntArray, FloatArray]:
    """Return the whole cycles inside an angle span and their grid angles.

    Parameters
    ----------
    angle_start, angle_stop : float
        First and last phi_F of the record in rad.
    points_per_rev : int
        Grid points per revolution.

    Returns
    -------
    cycles : numpy.ndarray of int
        Cycle numbers k (phi_F from 2 pi k to 2 pi (k + 1)).
    grid : numpy.ndarray
        Grid angles in rad, shape (n_cycles, points_per_rev), unwrapped.
    """
    cycles = whole_cycles(angle_start, angle_stop)
    return cycles, cycle_angles(cycles, points_per_rev)


def whole_cycles(angle_start: float, angle_stop: float) -> IntArray:
    """Return the numbers k of the whole cycles (2 pi k to 2 pi (k + 1), rad) in an angle span."""
    first = int(np.ceil(angle_start / (2 * np.pi)))
    last = int(np.floor(angle_stop / (2 * np.pi)))
    return np.arange(first, last, dtype=np.int64)


def cycle_angles(cycles: IntArray, points_per_rev: int) -> FloatArray:
    """Return the grid angles of some cycles, (n_cycles, points_per_rev), rad, unwrapped.

    A block of cycles' angles equal those rows of the whole grid's (:func:`cycle_grid`).

    Raises
    ------
    ConfigError
        When ``points_per_rev`` is less than 2.
    """
    if points_per_rev < 2:
        raise ConfigError(f"points_per_rev must be at least 2, got {points_per_rev}",
                          where={"key": "points_per_rev"})
    fraction = np.arange(points_per_rev) / points_per_rev
    return 2 * np.pi * (cycles[:, None] + fraction[None, :])


def interpolate_runs(time: ArrayLike | SampleTimes, values: ArrayLike | SampleTimes,
                     at: ArrayLike, *, order: int = 3,
                     segment: ArrayLike | None = None, valid: ArrayLike | None = None,
                     offset: float = 0.0, time_offset: float = 0.0) -> FloatArray:
    """Evaluate a sampled signal at arbitrary times without crossing gaps.

    Parameters
    ----------
    time : array_like or SampleTimes
        Sample times in s, increasing (a lazy axis's are computed a chunk at a time).
    values : array_like or SampleTimes
        Samples (NaN counts as invalid); a lazy time axis's (phi_F's inverse) computed a chunk
        at a time, every one finite.
    at : array_like
        Times in s to evaluate at (any order).
    order : int, default 3
        Spline degree: 1 linear, 3 cubic (not-a-knot), 5 quintic.
    segment, valid : array_like, optional
        Stream ``segment`` and ``valid`` variables.
    offset : float, default 0
        Subtracted from ``values``, a chunk at a time (a time axis as values, a channel's input
        delay taken off without a whole-record copy); the same values as subtracted first.
    time_offset : float, default 0
        Subtracted from ``time`` (s), a chunk at a time: a channel's module input delay taken
        off its reference times without a whole-record copy (memory); the same times as
        subtracted first.

    Returns
    -------
    numpy.ndarray
        Values at ``at``; NaN outside every run (in gaps, beyond the ends, at invalid samples).
    """
    t = times_of(time)  # a lazy axis's times computed a chunk at a time as read below (memory)
    x = times_of(values)
    targets = np.asarray(at, dtype=np.float64)
    if order not in (1, 3, 5):
        raise ConfigError(f"interpolation order must be 1, 3 or 5, got {order}",
                          where={"key": "order"})
    if isinstance(x, SampleTimes):  # times are finite
        ok = None if valid is None else np.asarray(valid, dtype=bool)
    else:
        ok = np.isfinite(x) if valid is None else np.asarray(valid, dtype=bool) & np.isfinite(x)
    out = np.full(targets.shape, np.nan)
    flat = targets.ravel()
    result = out.ravel()
    order_index = np.argsort(flat, kind="stable")
    sorted_targets = flat[order_index]
    for start, stop in contiguous_runs(t.size, segment, ok):
        if stop - start <= order:
            continue
        for lo in range(start, stop - 1, _CHUNK):
            hi = min(lo + _CHUNK, stop - 1)
            t_lo, t_hi = t[lo] - time_offset, t[hi] - time_offset
            a, b = np.searchsorted(sorted_targets, [t_lo, t_hi], side="left")
            if hi == stop - 1:
                b = np.searchsorted(sorted_targets, t_hi, side="right")
            if b <= a:
                continue
            read_lo, read_hi = max(start, lo - _OVERLAP), min(stop, hi + 1 + _OVERLAP)
            result[order_index[a:b]] = _chunk_spline(
                t, x, sorted_targets[a:b], read_lo, read_hi, order,
                at_start=read_lo == start, at_stop=read_hi == stop, offset=offset,
                time_offset=time_offset)
    return result.reshape(targets.shape)


def _chunk_spline(t: FloatArray | SampleTimes, x: FloatArray | SampleTimes, at: FloatArray,
                  lo: int, hi: int, order: int, *, at_start: bool, at_stop: bool,
                  offset: float = 0.0, time_offset: float = 0.0) -> FloatArray:
    """Evaluate the interpolating spline of the samples ``lo:hi`` at sorted times ``at``.

    Samples at uniform times (clock-mapped records; :data:`_UNIFORM_TOLERANCE`) take the
    cardinal B-spline: coefficients by the recursive prefilter of ``scipy.ndimage``, values
    by ``map_coordinates`` at the targets' fractional sample indices, about 20 times cheaper
    than ``make_interp_spline``. Inside a run it is the same spline (the two differ only by
    the end conditions, whose effect decays by 0.27 (cubic) or 0.43 (quintic) per sample);
    within :data:`_OVERLAP` samples of a run's ends the not-a-knot spline of the end's
    ``3 * _OVERLAP`` samples is used, so the result equals the whole run's not-a-knot
    spline to rounding everywhere (``tests/processing/test_angle_cycles.py``). ``offset`` is
    subtracted from the samples ``x`` first, ``time_offset`` from their times ``t`` (s).
    """
    tt = t[lo:hi] - time_offset if time_offset else t[lo:hi]
    xx = x[lo:hi] - offset if offset else x[lo:hi]
    n = tt.size
    if n < 4 * _OVERLAP:
        return make_interp_spline(tt, xx, k=order)(at)
    step = (tt[-1] - tt[0]) / (n - 1)
    if np.max(np.abs(np.diff(tt) - step)) > _UNIFORM_TOLERANCE * step:
        return make_interp_spline(tt, xx, k=order)(at)
    out = np.empty(at.size)
    first = np.searchsorted(at, tt[_OVERLAP], side="left") if at_start else 0
    last = np.searchsorted(at, tt[n - 1 - _OVERLAP], side="right") if at_stop else at.size
    if first > 0:
        end = slice(0, 3 * _OVERLAP)
        out[:first] = make_interp_spline(tt[end], xx[end], k=order)(at[:first])
    if last < at.size:
        end = slice(n - 3 * _OVERLAP, n)
        out[last:] = make_interp_spline(tt[end], xx[end], k=order)(at[last:])
    if last > first:
        inner = at[first:last]
        index = np.clip(((inner - tt[0]) / step).astype(np.int64), 0, n - 2)
        index -= (inner < tt[index]) & (index > 0)
        index += (inner >= tt[index + 1]) & (index < n - 2)
        # fractional index by the actual times: exact at every sample despite rounding
        position = index + (inner - tt[index]) / (tt[index + 1] - tt[index])
        coefficients = xx if order == 1 else spline_filter1d(xx, order=order, mode="mirror")
        out[first:last] = map_coordinates(coefficients, position[None, :], order=order,
                                          prefilter=False, mode="mirror")
    return out


def resample_to_angle(time: ArrayLike | SampleTimes, values: ArrayLike,
                      angle_time: ArrayLike | None,
                      angle: ArrayLike | None, *, points_per_rev: int, fs: float, order: int = 5,
                      anti_alias: AntiAlias = "butterworth", segment: ArrayLike | None = None,
                      valid: ArrayLike | None = None, grid: AngleGrid | None = None,
                      delay_s: float = 0.0) -> tuple[IntArray, FloatArray, FloatArray]:
    """Resample one channel onto a uniform phi_F grid, cycle by cycle.

    Parameters
    ----------
    time : array_like or SampleTimes
        The channel's sample times in s on the reference clock (``delay_s`` not yet removed;
        a lazy axis's computed a chunk at a time).
    values : array_like
        The channel's samples.
    angle_time, angle : array_like or None
        phi_F(t): reference-clock times in s and the increasing angle in rad (None with
        ``grid``).
    points_per_rev : int
        Grid points per revolution.
    fs : float
        The channel's sampling rate in Hz (for the anti-alias filter).
    order : int, default 5
        Interpolation spline degree (1, 3, 5): at 0.05 fs the largest error is 1.2e-2, 1.4e-4
        (2.6e-5 away from the run ends) and 7.5e-6 of the amplitude.
    anti_alias : {"butterworth", "none"}
        Low-pass (order 8, zero phase, per run) at 0.4 times the slowest grid rate when the grid
        is coarser than the samples.
    segment, valid : array_like, optional
        The channel's stream ``segment`` and ``valid``.
    grid : AngleGrid, optional
        :func:`angle_grid` of ``angle_time, angle, points_per_rev``, computed once for many
        channels (it is the same for all); default: computed here.
    delay_s : float, default 0
        The channel's module input delay in s: its samples were taken at ``time - delay_s``,
        taken off a chunk at a time without a copy of the times (memory).

    Returns
    -------
    cycles : numpy.ndarray of int
        Cycle numbers.
    cycle_time : numpy.ndarray
        Time in s at which each cycle starts (phi_F = 2 pi k), shape (n_cycles,).
    resampled : numpy.ndarray
        Values on the grid, shape (n_cycles, points_per_rev); NaN where the channel has no data.
    """
    if grid is None:
        if angle_time is None or angle is None:
            raise ConfigError("resample_to_angle needs phi_F(t) (angle_time, angle) or a grid",
                              where={"key": "grid"})
        grid = angle_grid(angle_time, angle, points_per_rev)
    x = np.asarray(values, dtype=np.float64)
    if anti_alias == "butterworth":
        cutoff = anti_alias_hz(grid, points_per_rev)
        if cutoff < 0.45 * fs:
            x = zero_phase(x, fs, cutoff, order=8, segment=segment, valid=valid)
    elif anti_alias != "none":
        raise ConfigError(f"anti_alias must be 'butterworth' or 'none', got {anti_alias!r}",
                          where={"key": "anti_alias"})
    resampled = interpolate_runs(time, x, grid.times, order=order, segment=segment, valid=valid,
                                 time_offset=delay_s)
    return grid.cycles, grid.times[:, 0], resampled


def anti_alias_hz(grid: AngleGrid, points_per_rev: int) -> float:
    """Return the corner in Hz of :func:`resample_to_angle`'s anti-alias low-pass.

    0.4 times the slowest grid rate (``points_per_rev`` points per revolution at the grid's
    slowest speed); the filter (order 8, zero phase) applies when it lies below 0.45 ``fs``.
    """
    return 0.4 * points_per_rev * grid.slowest / (2 * np.pi)


@dataclass(frozen=True)
class AngleGrid:
    """The uniform phi_F grid of a record: whole cycles and the reference time of each point.

    Attributes
    ----------
    cycles : numpy.ndarray of int
        Cycle numbers k.
    times : numpy.ndarray
        Reference time in s of each grid angle, (n_cycles, points_per_rev); NaN in gaps of the
        angle record.
    slowest : float
        Lowest speed of phi_F between two samples in rad/s (for the anti-alias corner).
    """

    cycles: IntArray
    times: FloatArray
    slowest: float


def angle_grid(angle_time: ArrayLike | SampleTimes, angle: ArrayLike, points_per_rev: int, *,
               delay_s: float = 0.0) -> AngleGrid:
    """Return the reference times of a uniform phi_F grid over the record's whole cycles.

    The times come from a cubic spline through the inverse of the increasing phi_F(t)
    (``np.interp`` alone limits the accuracy to 4e-6 at 0.05 fs); gaps in the angle record
    (time steps over 1.5 median steps) are not bridged: grid angles that fall in one are NaN.

    Parameters
    ----------
    angle_time, angle : array_like
        phi_F(t): reference-clock times in s (a lazy axis's :class:`SampleTimes`, computed a
        chunk at a time) and the increasing angle in rad.
    points_per_rev : int
        Grid points per revolution.
    delay_s : float, default 0
        phi_F was sampled at ``angle_time - delay_s`` (the encoder's input delay, s): taken off
        a chunk at a time, with the results of the shifted times, without their copy (memory).

    Returns
    -------
    AngleGrid
        Cycles, grid times and the slowest speed.

    Raises
    ------
    DataError
        When phi_F does not increase strictly or spans no whole revolution.
    """
    phi_t, phi = increasing_angle(angle_time, angle, use="to be inverted (phi_F)")
    cycles, grid = cycle_grid(phi[0], phi[-1], points_per_rev)
    if cycles.size == 0:
        raise DataError(f"phi_F spans {phi[0]:.4g} to {phi[-1]:.4g} rad: no whole revolution",
                        hint="record at least two revolutions")
    # chunk by chunk, no whole-record temporary (memory): the time steps' median exactly as
    # np.median of them all (a time axis's steps take few distinct values)
    chunk = 1 << 20
    pieces = range(0, phi_t.size - 1, chunk)

    def steps(lo: int) -> FloatArray:
        return np.diff(phi_t[lo:lo + chunk + 1] - delay_s)

    slowest = min(float(np.min(np.diff(phi[lo:lo + chunk + 1]) / steps(lo))) for lo in pieces)
    median = exact_median(steps(lo) for lo in pieces)
    gaps = np.concatenate([lo + np.flatnonzero(steps(lo) > 1.5 * median) for lo in pieces])
    map_segment = None
    if gaps.size:
        map_segment = np.zeros(phi_t.size, dtype=np.int32)
        map_segment[gaps + 1] = 1
        np.cumsum(map_segment, out=map_segment)
    times = interpolate_runs(phi, phi_t, grid, order=3, segment=map_segment, offset=delay_s)
    return AngleGrid(cycles, times, slowest)


def angle_domain(aligned: Mapping[str, xr.Dataset], angle_time: ArrayLike, angle: ArrayLike,
                 *, points_per_rev: int = 360,
                 channels: Mapping[str, Sequence[str]] | None = None, order: int = 5,
                 anti_alias: AntiAlias = "butterworth",
                 invalid_cycles: ArrayLike | None = None) -> xr.Dataset:
    """Resample channels of aligned streams onto a common phi_F grid.

    Parameters
    ----------
    aligned : mapping of str to xarray.Dataset
        Aligned streams by name (:func:`~rigval.processing.clock_fit.align_stream`).
    angle_time, angle : array_like
        phi_F(t) on the reference clock: times in s and increasing angle in rad, zero at the
        optical reference (:func:`zero_at_reference`).
    points_per_rev : int, default 360
        Grid points per revolution.
    channels : mapping of str to list of str, optional
        Channels to resample per stream; default all data variables except ``valid``/``segment``.
        Output variables are named by channel; a name used in two streams gets the stream prefix.
    order : int, default 5
        Interpolation spline degree (:func:`resample_to_angle`).
    anti_alias : {"butterworth", "none"}
        As in :func:`resample_to_angle`.
    invalid_cycles : array_like of int, optional
        Cycle numbers to mark invalid (encoder glitches, pulse problems).

    Returns
    -------
    xarray.Dataset
        Dims ``cycle`` and ``angle`` (rad, phi_F in [0, 2 pi)); coords ``cycle_start_time`` (s),
        ``mean_speed`` (rad s-1); variable ``cycle_valid`` (all channels complete and not listed
        in ``invalid_cycles``); one variable per channel with its attributes plus ``stream``; a
        history line.
    """
    phi_t = np.asarray(angle_time, dtype=np.float64)
    phi = np.asarray(angle, dtype=np.float64)
    data_vars: dict[str, tuple[tuple[str, str], FloatArray, dict[str, object]]] = {}
    cycles = np.zeros(0, dtype=np.int64)
    start_time = np.zeros(0)
    grid_times = None
    for stream_name, var, out_name in selected_channels(aligned, channels):
        ds = aligned[stream_name]
        grid_times = grid_times or angle_grid(phi_t, phi, points_per_rev)
        cycles, start_time, values = resample_to_angle(
            channel_time(ds, var), ds[var].to_numpy(), phi_t, phi,
            points_per_rev=points_per_rev, fs=float(ds.attrs["fs_nominal"]), order=order,
            anti_alias=anti_alias, segment=ds["segment"].to_numpy(),
            valid=ds["valid"].to_numpy(), grid=grid_times)
        attrs = {**ds[var].attrs, "stream": stream_name,
                 "resampling": f"spline order {order}, anti-alias {anti_alias}"}
        data_vars[out_name] = (("cycle", "angle"), values, attrs)
    if not data_vars:
        raise ConfigError("no channels selected for the angle domain", where={"key": "channels"})
    complete = np.ones(cycles.size, dtype=bool)
    for _, values, _ in data_vars.values():
        complete &= np.all(np.isfinite(values), axis=1)
    if invalid_cycles is not None:
        complete &= ~np.isin(cycles, np.asarray(invalid_cycles))
    grid = 2 * np.pi * np.arange(points_per_rev) / points_per_rev
    period = np.diff(np.interp(2 * np.pi * np.append(cycles, cycles[-1] + 1), phi, phi_t))
    out = xr.Dataset(
        {name: (dims, values, attrs) for name, (dims, values, attrs) in data_vars.items()}
        | {"cycle_valid": ("cycle", complete, {"long_name": "cycle is complete and usable",
                                               "units": "1"})},
        coords={
            "cycle": ("cycle", cycles, {"long_name": "revolution number of phi_F",
                                        "units": "1"}),
            "angle": ("angle", grid, {"long_name": "main shaft angle phi_F from the optical "
                                                   "reference", "units": "rad"}),
            "cycle_start_time": ("cycle", start_time, {"long_name": "time of phi_F = 2 pi k",
                                                       "units": "s"}),
            "mean_speed": ("cycle", 2 * np.pi / period, {"long_name": "mean speed of the cycle",
                                                         "units": "rad s-1"}),
        },
        attrs={"points_per_rev": points_per_rev, "interpolation_order": order,
               "anti_alias": anti_alias, "history": merged_history(aligned, channels or aligned)},
    )
    append_history(out, f"processing.angle_domain {points_per_rev} points/rev, order {order}, "
                        f"anti-alias {anti_alias}, {cycles.size} cycles")
    return out


def phi_f(stream: xr.Dataset, encoder_channel: str, reference: StreamPulses, *,
          counts_per_rev: float, direction: float = 1.0, method: Method = "butterworth",
          cutoff_hz: float | None = None, order: int = 8, harmonics: int = 8,
          glitch_tolerance: float = 4.0, index_reset: bool = False, derivatives: bool = True
          ) -> xr.Dataset:
    """Return phi_F(t): the smoothed main-shaft angle, zero at the optical reference.

    Parameters
    ----------
    stream : xarray.Dataset
        The (aligned) reference stream with the main-shaft encoder.
    encoder_channel : str
        Counter channel of the main-shaft encoder.
    reference : StreamPulses
        The optical reference pulses of the same stream (:func:`~rigval.processing.pulses.
        stream_pulses`); their good edges define phi_F = 0.
    counts_per_rev : float
        Encoder counts per revolution (8192 for 2048 lines X4).
    direction : float, default 1
        -1 if the encoder counts down when the shaft turns the model's positive way.
    method, cutoff_hz, order, harmonics
        As in :func:`~rigval.processing.excitation.drive_angle`.
    glitch_tolerance : float, default 4
        Counts per revolution off CPR still called a glitch (see
        :func:`~rigval.processing.encoder.revolution_check`).
    index_reset : bool, default False
        The counter reloads at the Z index (see
        :func:`~rigval.processing.encoder.remove_index_resets`).
    derivatives : bool, default True
        False: without ``phi_F_dot`` and ``phi_F_ddot`` (memory).

    Returns
    -------
    xarray.Dataset
        On the stream's ``time``: ``phi_F`` (rad, unwrapped, 2 pi k at the reference),
        ``phi_F_dot`` (rad s-1), ``phi_F_ddot`` (rad s-2); attributes ``zero_offset_rad``,
        ``reference_scatter_rad`` (rms scatter of the pulses about phi_F = 0) and
        ``suspect_cycles`` (int64 array of cycle numbers whose count between reference pulses is
        off a whole number of revolutions by more than one count: glitches or missed counts;
        missing pulses alone do not make a cycle suspect) and a history line.
    """
    exc = drive_excitation(stream, encoder_channel, counts_per_rev=counts_per_rev,
                           name="phi_F", direction=direction, method=method,
                           cutoff_hz=cutoff_hz, order=order, harmonics=harmonics,
                           index_reset=index_reset, derivatives=derivatives)
    # Whole-record arrays are neither copied nor masked when every sample is finite, and a
    # lazy time axis stays lazy (memory).
    time = sample_times(exc)
    angle = exc["phi_F"].to_numpy()
    finite = np.isfinite(angle)
    if finite.all():
        t_ok, phi_ok = time, angle
    else:
        t_ok, phi_ok = time[finite], angle[finite]
    offset, scatter = zero_at_reference(t_ok, phi_ok, reference.good)
    angle -= offset  # in place: phi_ok is a view of it or a copy, shifted below
    if phi_ok is not angle:
        phi_ok -= offset
    exc["phi_F"].attrs.update({"long_name": "main shaft angle phi_F from the optical reference",
                               "zero_offset_rad": offset})
    # the counts at the pulses alone, not the whole record's int64 counts (memory)
    check = counter_revolution_check(time, stream[encoder_channel].to_numpy(), reference.good,
                                     counts_per_rev, direction=direction,
                                     index_reset=index_reset, tolerance=glitch_tolerance)
    # An interval of m whole revolutions is m - 1 missing pulses, not an encoder fault; what is
    # left over beyond one count (quantisation) marks every cycle the interval spans.
    whole = np.maximum(np.round(check.residual / counts_per_rev), 0.0)
    fault = np.abs(check.residual - whole * counts_per_rev) > 1
    at_pulse = interp_minus(check.event_times[:-1], t_ok, phi_ok)  # as np.interp, no copy
    first = np.round(at_pulse / (2 * np.pi)).astype(int)
    suspect = {int(k) for i in np.flatnonzero(fault)
               for k in range(first[i], first[i] + int(whole[i]) + 1)}
    exc.attrs.update({"zero_offset_rad": offset, "reference_scatter_rad": scatter,
                      "reference_channel": reference.channel,
                      "suspect_cycles": np.array(sorted(suspect), dtype=np.int64)})
    append_history(exc, f"processing.phi_f zero at {reference.channel} ({offset:.6f} rad, "
                        f"scatter {scatter:.2e} rad), {len(suspect)} suspect cycles")
    return exc
