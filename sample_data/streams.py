"""Sampling stage of the virtual rig: every channel of every device at its own sample times.

For each device and each gap-free segment of its record, a channel's sample k is the sensor output
at ``t_k - delay`` (true time of the sample minus the module's input delay), plus white noise of the
sensor's ``noise_rms``, quantised by the module's ADC (counters store counts). Alongside, the
physical truth of each analog channel is kept at the sample instants ``t_k`` themselves.

Channel map (docs/references.md ([paper] section 4.1)):

========  ======  =========  ========  ==================================================
stream    chan.   module     unit      truth (physical)
========  ======  =========  ========  ==================================================
cdaq      acc1    NI 9215    Volts     point_acceleration P1 x (m s-2)
cdaq      acc2    NI 9215    Volts     point_acceleration P2 x (m s-2)
cdaq      acc3    NI 9215    Volts     frame vibration at P3 (m s-2)
cdaq      str1    NI 9237    V/V       axial stress at mid-length of rod B (Pa)
cdaq      str2    NI 9237    V/V       stress on rod B's face at +n (only with rod bending)
cdaq      str3    NI 9237    V/V       stress on the opposite face (only with rod bending)
cdaq      opt1    NI 9215    Volts     pulse edges (in the truth JSON)
cdaq      enc1    NI 9411    counts    theta_F (rad, from the drive law)
cdaq      enc2    NI 9411    counts    theta_H (rad, from the drive law)
wls1      tor1    NI 9237    V/V       share of driver_torque theta_F (N m)
wls1      tor2    NI 9237    V/V       the other share (N m)
wls1      opt2    NI 9237    V/V       pulse edges
wls2      tor3    NI 9237    V/V       share of driver_torque theta_H (N m)
wls2      tor4    NI 9237    V/V       the other share (N m)
wls2      opt3    NI 9237    V/V       pulse edges
========  ======  =========  ========  ==================================================
"""

from __future__ import annotations

import itertools
import logging
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from rigval.processing.arrays import FloatArray
from rigval.sample_data.devices import MODULES, DeviceClock, SampledChannel, Stream, StreamPiece
from rigval.sample_data.rig import RigDraw
from rigval.sample_data.sensors import PulseTrain, optical_pulses
from rigval.sample_data.truth import TruthGrid, frame_vibration

__all__ = ["DEVICE_NAMES", "SAMPLED_QUANTITIES", "SampledTruth", "TruthWindows", "sampled_truth",
           "stream_pieces"]

logger = logging.getLogger(__name__)

#: A signal as a function of true time (s).
_Signal = Callable[[FloatArray], FloatArray]

#: Device model of each stream.
DEVICE_NAMES = {"cdaq": "cDAQ-9172", "wls1": "WLS-9163", "wls2": "WLS-9163"}
#: The truth grid's quantities the channels are sampled from (:func:`stream_pieces`); the others
#: (the rod's axis, length and bending moment) serve only the departures before.
SAMPLED_QUANTITIES = frozenset({"acc_P1_x", "acc_P2_x", "frame_force_P3_x", "rod_B_axial_force",
                                "rod_B_bending_stress", "torque_theta_F", "torque_theta_H"})
#: ADC full scale by module: +-10 V (NI 9215), +-25 mV/V (NI 9237).
_FULL_SCALE = {"NI 9215": 10.0, "NI 9237": 0.025}
#: File unit of an analog channel by module.
_FILE_UNIT = {"NI 9215": "Volts", "NI 9237": "V/V"}


@dataclass(frozen=True)
class SampledTruth:
    """The truth the channels are sampled from, on the truth grid.

    Parameters
    ----------
    grid : TruthGrid
        The model's quantities (:data:`SAMPLED_QUANTITIES`, units in
        :mod:`~rigval.sample_data.truth`).
    physical : TruthGrid
        Acceleration of ``acc1``, ``acc2``, ``acc3`` in m s-2 (acc3: the frame mode).
    volts : TruthGrid
        Their charge amplifiers' outputs in V (after the high-pass).
    """

    grid: TruthGrid
    physical: TruthGrid
    volts: TruthGrid

    def window(self, t_from: float, t_to: float) -> SampledTruth:
        """Return the part from ``t_from`` to ``t_to`` (s), margin as TruthGrid.window (views)."""
        return SampledTruth(self.grid.window(t_from, t_to), self.physical.window(t_from, t_to),
                            self.volts.window(t_from, t_to))


class TruthWindows(Protocol):
    """Truth of a record too long to hold, given a window of true time at a time."""

    def window(self, t_from: float, t_to: float) -> SampledTruth:
        """Return the truth from ``t_from`` to ``t_to`` (s), margin as TruthGrid.window."""


def sampled_truth(draw: RigDraw, grid: TruthGrid) -> SampledTruth:
    """Return the sampled truth of a whole grid in memory (filters over the whole grid)."""
    physical = {
        "acc1": grid.values["acc_P1_x"],
        "acc2": grid.values["acc_P2_x"],
        "acc3": frame_vibration(grid.t, grid.values["frame_force_P3_x"], **draw.frame),
    }
    volts = {name: draw.accelerometers[name].voltage(grid.fs, values)
             for name, values in physical.items()}
    return SampledTruth(grid, TruthGrid(grid.t, physical), TruthGrid(grid.t, volts))


@dataclass(frozen=True)
class _Plan:
    """How one channel is sampled: an analog module on a signal, or an encoder's counter."""

    name: str
    module: str
    signal: _Signal
    noise_rms: float
    truth: _Signal | None
    truth_unit: str | None
    #: A counter's counts(angle, angle_at_start); None for an analog channel.
    counts: Callable[[FloatArray, float], NDArray] | None = None
    #: Undeclared lag (s) of the samples beyond the module's delay (the rig's departures).
    lag: float = 0.0


def _pulse_signal(train: PulseTrain, module: str, fs: float) -> _Signal:
    band = MODULES[module].filter_bandwidth(fs)
    return lambda t: train.value(t, band_limit=band)


def _trains(draw: RigDraw) -> tuple[dict[str, PulseTrain], dict[str, dict[str, list[float]]]]:
    """Return each optical sensor's pulse train over its device's record, and their truth."""
    drive = draw.drive
    pulse_truth = {}
    trains = {}
    for name, stream, drive_name, reference in (("opt1", "cdaq", "theta_F", drive.theta_f0),
                                                ("opt2", "wls1", "theta_F", drive.theta_f0),
                                                ("opt3", "wls2", "theta_H", drive.theta_h0)):
        # Pulses over the device's record (gaps included), with a margin for the module delay.
        clock = draw.clocks[stream]
        last = clock.segments[-1]
        t_first = clock.segments[0].true_start - 0.1
        t_last = last.true_start + last.n_samples / clock.fs_true + 0.01
        trains[name], pulse_truth[name] = optical_pulses(
            draw.optical[name], drive, drive_name, reference, t_first, t_last,
            np.random.default_rng(draw.pulse_seeds[name]), draw.missing_probability,
            draw.spurious_per_minute)
    return trains, pulse_truth


def _plans(draw: RigDraw, truth: SampledTruth,
           trains: dict[str, PulseTrain]) -> dict[str, list[_Plan]]:
    """Return the channel plans of every stream on this truth."""
    drive = draw.drive
    grid, physical, volts = truth.grid, truth.physical, truth.volts

    def angle(drive_name: str) -> _Signal:
        return lambda t: drive.angles(t)[drive_name][0]

    cdaq = draw.clocks["cdaq"]
    plans: dict[str, list[_Plan]] = {"cdaq": [
        _Plan(name, "NI 9215", lambda t, n=name: volts.at(n, t),
              draw.accelerometers[name].noise_rms, lambda t, n=name: physical.at(n, t), "m s-2")
        for name in ("acc1", "acc2", "acc3")]}
    bridge = draw.str1
    plans["cdaq"].append(_Plan(
        "str1", "NI 9237", lambda t: bridge.ratio(grid.at("rod_B_axial_force", t), t),
        bridge.noise_rms, lambda t: grid.at("rod_B_axial_force", t) / bridge.area, "Pa"))
    for name, sign in (("str2", 1.0), ("str3", -1.0)):  # the faces of rod B, if it bends
        if name in draw.bending:
            face = draw.bending[name]

            def stress(t: FloatArray, s: float = sign) -> FloatArray:
                return (grid.at("rod_B_axial_force", t) / bridge.area
                        + s * grid.at("rod_B_bending_stress", t))

            plans["cdaq"].append(_Plan(
                name, "NI 9237", lambda t, f=face, st=stress: f.ratio(st(t) * f.area, t),
                face.noise_rms, stress, "Pa"))
    plans["cdaq"].append(_Plan("opt1", "NI 9215",
                               _pulse_signal(trains["opt1"], "NI 9215", cdaq.fs_nominal),
                               draw.optical["opt1"].noise_rms, None, None))
    for name, drive_name in (("enc1", "theta_F"), ("enc2", "theta_H")):
        plans["cdaq"].append(_Plan(name, "NI 9411", angle(drive_name), 0.0, None, None,
                                   counts=draw.encoders[name].counts))
    for stream, pair, drive_name, opt in (("wls1", ("tor1", "tor2"), "theta_F", "opt2"),
                                          ("wls2", ("tor3", "tor4"), "theta_H", "opt3")):
        clock = draw.clocks[stream]
        torque = f"torque_{drive_name}"
        plans[stream] = [
            _Plan(name, "NI 9237",
                  lambda t, s=draw.torsion[name], q=torque, d=drive_name: s.ratio(
                      grid.at(q, t), angle(d)(t), t),
                  draw.torsion[name].noise_rms,
                  lambda t, s=draw.torsion[name], q=torque: s.share * grid.at(q, t), "N m")
            for name in pair]
        plans[stream].append(_Plan(opt, "NI 9237",
                                   _pulse_signal(trains[opt], "NI 9237", clock.fs_nominal),
                                   draw.optical[opt].noise_rms, None, None))
    if draw.lags:
        plans = {stream: [replace(p, lag=draw.lags.get(p.name, 0.0)) for p in channels]
                 for stream, channels in plans.items()}
    return plans


def _windows(clock: DeviceClock, window_s: float | None) -> list[list[tuple[int, int, int]]]:
    """Split a clock's samples into windows of true time: [(segment, first, stop), ...] each."""
    if window_s is None:
        return [[(i, 0, seg.n_samples) for i, seg in enumerate(clock.segments)]]
    start = clock.segments[0].true_start
    last = clock.segments[-1]
    stop = last.true_start + last.n_samples / clock.fs_true
    edges = start + window_s * np.arange(int(np.ceil((stop - start) / window_s)) + 1)
    windows = []
    for a, b in itertools.pairwise(edges):
        parts = []
        for i, seg in enumerate(clock.segments):
            k0 = int(np.clip(np.ceil((a - seg.true_start) * clock.fs_true), 0, seg.n_samples))
            k1 = int(np.clip(np.ceil((b - seg.true_start) * clock.fs_true), 0, seg.n_samples))
            if k1 > k0:
                parts.append((i, k0, k1))
        if parts:
            windows.append(parts)
    return windows


def _sample(plan: _Plan, clock: DeviceClock, parts: list[tuple[int, int, int]],
            rng: np.random.Generator) -> tuple[list[NDArray], FloatArray | None, float, float]:
    """Sample one channel on some segment pieces: raw arrays, truth, slope, delay."""
    mod = MODULES[plan.module]
    times = [clock.segments[i].true_start + np.arange(k0, k1) / clock.fs_true
             for i, k0, k1 in parts]
    if plan.counts is not None:
        # The counter starts at the first sample of the record (the cDAQ has one segment).
        delay = mod.delay(clock.fs_nominal)
        theta0 = float(plan.signal(np.array([clock.segments[0].true_start - delay]))[0])
        raw = [plan.counts(plan.signal(t - delay), theta0) for t in times]
        return raw, None, 1.0, delay
    # A delta-sigma module's delay is counted in periods of the device's own (drifting) clock.
    delay = mod.delay(clock.fs_true)
    raw, slope = [], 1.0
    for t in times:
        values = plan.signal(t - delay - plan.lag) + rng.normal(0.0, 1.0, t.size) * plan.noise_rms
        codes, slope = mod.quantise(values, _FULL_SCALE[plan.module])
        raw.append(codes)
    truth = None if plan.truth is None else plan.truth(np.concatenate(times))
    return raw, truth, slope, delay


def _stream_meta(draw: RigDraw, plans: dict[str, list[_Plan]]) -> dict[str, Stream]:
    """Return each stream with its channels' metadata (no samples)."""
    streams = {}
    for name, channels in plans.items():
        clock = draw.clocks[name]
        meta = []
        for plan in channels:
            mod = MODULES[plan.module]
            if plan.counts is not None:
                meta.append(SampledChannel(plan.name, plan.module, None, [], 1.0,
                                           mod.delay(clock.fs_nominal), None, None))
            else:
                top = 2 ** (mod.bits - 1) - 1
                meta.append(SampledChannel(plan.name, plan.module, _FILE_UNIT[plan.module], [],
                                           _FULL_SCALE[plan.module] / top,
                                           mod.delay(clock.fs_true), None, plan.truth_unit))
        streams[name] = Stream(name, DEVICE_NAMES[name], clock, tuple(meta))
    return streams


def _window_span(clock: DeviceClock, parts: list[tuple[int, int, int]]) -> tuple[float, float]:
    """Return the true times (s) a window's samples need the truth over, 1 s either side."""
    first, last = parts[0], parts[-1]
    return (clock.segments[first[0]].true_start + first[1] / clock.fs_true - 1.0,
            clock.segments[last[0]].true_start + last[2] / clock.fs_true + 1.0)


def stream_pieces(draw: RigDraw, truth: SampledTruth | TruthWindows,
                  window_s: float | None = None
                  ) -> tuple[dict[str, Stream], dict[str, dict[str, list[float]]],
                             Iterator[StreamPiece]]:
    """Sample every channel of the rig window by window, in bounded memory.

    Parameters
    ----------
    draw : RigDraw
        The run's random draws (drive, clocks, sensors).
    truth : SampledTruth or TruthWindows
        Truth covering every device's record (and the pre-roll): all of it in memory
        (:func:`sampled_truth`), or given a window at a time (a long record,
        :class:`~rigval.sample_data.truth_store.TruthStore`).
    window_s : float, optional
        Length of a window of true time in s; None: each stream in one piece (only with the
        truth in memory).

    Returns
    -------
    dict of str to Stream
        ``"cdaq"``, ``"wls1"``, ``"wls2"`` with their channels' metadata (``raw`` empty and
        ``truth`` None: the samples come in the pieces).
    dict
        Truth of each optical sensor's pulses (see
        :func:`~rigval.sample_data.sensors.optical_pulses`).
    iterator of StreamPiece
        The samples: the streams in the order cdaq, wls1, wls2, each window after window.
        One noise generator runs through them in this order (channel after channel within a
        window), so one seed and one window length give the same samples.
    """
    trains, pulse_truth = _trains(draw)
    whole = truth if isinstance(truth, SampledTruth) else None
    cdaq = draw.clocks["cdaq"].segments[0]
    plans = _plans(draw, whole or truth.window(cdaq.true_start, cdaq.true_start), trains)
    streams = _stream_meta(draw, plans)

    def pieces() -> Iterator[StreamPiece]:
        rng = np.random.default_rng(draw.noise_seed)
        for name, channels in plans.items():
            clock = draw.clocks[name]
            windows = _windows(clock, window_s)
            for parts in windows:
                if len(windows) > 1 or whole is None:  # splines on this window's truth only
                    channels = _plans(draw, truth.window(*_window_span(clock, parts)),
                                      trains)[name]
                raw, values = {}, {}
                for plan in channels:
                    raw[plan.name], sampled, _, _ = _sample(plan, clock, parts, rng)
                    if sampled is not None:
                        values[plan.name] = sampled
                yield StreamPiece(name, tuple((i, k0) for i, k0, _ in parts), raw, values)

    return streams, pulse_truth, pieces()
