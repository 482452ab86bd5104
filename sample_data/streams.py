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

import logging
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from rigval.sample_data.devices import MODULES, DeviceClock
from rigval.sample_data.rig import RigDraw
from rigval.sample_data.sensors import PulseTrain, optical_pulses
from rigval.sample_data.truth import TruthGrid, frame_vibration

__all__ = ["DEVICE_NAMES", "SampledChannel", "Stream", "sample_streams"]

logger = logging.getLogger(__name__)

_FloatArray = NDArray[np.float64]
#: A signal as a function of true time (s).
_Signal = Callable[[_FloatArray], _FloatArray]

#: Device model of each stream.
DEVICE_NAMES = {"cdaq": "cDAQ-9172", "wls1": "WLS-9163", "wls2": "WLS-9163"}
#: ADC full scale by module: +-10 V (NI 9215), +-25 mV/V (NI 9237).
_FULL_SCALE = {"NI 9215": 10.0, "NI 9237": 0.025}
#: File unit of an analog channel by module.
_FILE_UNIT = {"NI 9215": "Volts", "NI 9237": "V/V"}


@dataclass(frozen=True)
class SampledChannel:
    """One channel as its device recorded it.

    Parameters
    ----------
    name : str
        Channel name.
    module : str
        Module model (key of :data:`~rigval.sample_data.devices.MODULES`).
    unit : str or None
        Unit string in the file (None for counters).
    raw : list of numpy.ndarray
        Raw codes or counts, one array per gap-free segment.
    slope : float
        Scale from raw to ``unit``.
    delay : float
        Module input delay in s.
    truth : numpy.ndarray or None
        Physical truth at the sample instants (segments concatenated), or None where the truth is
        kept elsewhere (pulses: edge lists; encoders: the drive law).
    truth_unit : str or None
        UDUNITS unit of ``truth``.
    """

    name: str
    module: str
    unit: str | None
    raw: list[NDArray]
    slope: float
    delay: float
    truth: _FloatArray | None
    truth_unit: str | None


@dataclass(frozen=True)
class Stream:
    """One device's record: its clock and its channels.

    Parameters
    ----------
    name : str
        ``"cdaq"``, ``"wls1"`` or ``"wls2"``.
    device : str
        Device model.
    clock : DeviceClock
        Sample clock and segments.
    channels : tuple of SampledChannel
        Channels in file order.
    """

    name: str
    device: str
    clock: DeviceClock
    channels: tuple[SampledChannel, ...]


def _accelerometer_grids(draw: RigDraw, grid: TruthGrid) -> tuple[TruthGrid, TruthGrid]:
    """Return the physical accelerations and the amplifier voltages on the truth grid."""
    physical = {
        "acc1": grid.values["acc_P1_x"],
        "acc2": grid.values["acc_P2_x"],
        "acc3": frame_vibration(grid.t, grid.values["frame_force_P3_x"], **draw.frame),
    }
    volts = {name: draw.accelerometers[name].voltage(grid.fs, values)
             for name, values in physical.items()}
    return TruthGrid(grid.t, physical), TruthGrid(grid.t, volts)


def _analog(name: str, module: str, clock: DeviceClock, signal: _Signal, noise_rms: float,
            truth: _Signal | None, truth_unit: str | None,
            rng: np.random.Generator) -> SampledChannel:
    """Sample a sensor output through an analog module on every segment of a clock."""
    mod = MODULES[module]
    # A delta-sigma module's delay is counted in periods of the device's own (drifting) clock.
    delay = mod.delay(clock.fs_true)
    raw, slope = [], 1.0
    for i in range(len(clock.segments)):
        t = clock.sample_times(i)
        values = signal(t - delay) + rng.normal(0.0, 1.0, t.size) * noise_rms
        codes, slope = mod.quantise(values, _FULL_SCALE[module])
        raw.append(codes)
    samples = clock.all_sample_times()
    return SampledChannel(name, module, _FILE_UNIT[module], raw, slope, delay,
                          None if truth is None else truth(samples), truth_unit)


def _pulse_signal(train: PulseTrain, module: str, fs: float) -> _Signal:
    band = MODULES[module].filter_bandwidth(fs)
    return lambda t: train.value(t, band_limit=band)


def sample_streams(draw: RigDraw, grid: TruthGrid) -> tuple[dict[str, Stream],
                                                            dict[str, dict[str, list[float]]]]:
    """Sample every channel of the rig.

    Parameters
    ----------
    draw : RigDraw
        The run's random draws (drive, clocks, sensors).
    grid : TruthGrid
        Model truth covering every device's record (and the pre-roll).

    Returns
    -------
    dict of str to Stream
        ``"cdaq"``, ``"wls1"``, ``"wls2"``.
    dict
        Truth of each optical sensor's pulses (see
        :func:`~rigval.sample_data.sensors.optical_pulses`).
    """
    drive = draw.drive
    physical, volts = _accelerometer_grids(draw, grid)
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
    rng = np.random.default_rng(draw.noise_seed)

    def angle(drive_name: str) -> _Signal:
        return lambda t: drive.angles(t)[drive_name][0]

    cdaq = draw.clocks["cdaq"]
    channels = [
        _analog(name, "NI 9215", cdaq, lambda t, n=name: volts.at(n, t),
                draw.accelerometers[name].noise_rms, lambda t, n=name: physical.at(n, t),
                "m s-2", rng)
        for name in ("acc1", "acc2", "acc3")]
    bridge = draw.str1
    channels.append(_analog(
        "str1", "NI 9237", cdaq,
        lambda t: bridge.ratio(grid.at("rod_B_axial_force", t), t), bridge.noise_rms,
        lambda t: grid.at("rod_B_axial_force", t) / bridge.area, "Pa", rng))
    channels.append(_analog("opt1", "NI 9215", cdaq, _pulse_signal(trains["opt1"], "NI 9215",
                                                                   cdaq.fs_nominal),
                            draw.optical["opt1"].noise_rms, None, None, rng))
    counter_delay = MODULES["NI 9411"].delay(cdaq.fs_nominal)
    t_cdaq = cdaq.sample_times(0) - counter_delay
    for name, drive_name in (("enc1", "theta_F"), ("enc2", "theta_H")):
        theta = angle(drive_name)(t_cdaq)
        counts = draw.encoders[name].counts(theta, float(theta[0]))
        channels.append(SampledChannel(name, "NI 9411", None, [counts], 1.0, counter_delay,
                                       None, None))
    streams = {"cdaq": Stream("cdaq", DEVICE_NAMES["cdaq"], cdaq, tuple(channels))}

    for stream, pair, drive_name, opt in (("wls1", ("tor1", "tor2"), "theta_F", "opt2"),
                                          ("wls2", ("tor3", "tor4"), "theta_H", "opt3")):
        clock = draw.clocks[stream]
        torque = f"torque_{drive_name}"
        channels = []
        for name in pair:
            sensor = draw.torsion[name]
            channels.append(_analog(
                name, "NI 9237", clock,
                lambda t, s=sensor, q=torque, d=drive_name: s.ratio(grid.at(q, t),
                                                                    angle(d)(t), t),
                sensor.noise_rms, lambda t, s=sensor, q=torque: s.share * grid.at(q, t), "N m",
                rng))
        channels.append(_analog(opt, "NI 9237", clock,
                                _pulse_signal(trains[opt], "NI 9237", clock.fs_nominal),
                                draw.optical[opt].noise_rms, None, None, rng))
        streams[stream] = Stream(stream, DEVICE_NAMES[stream], clock, tuple(channels))
    return streams, pulse_truth
