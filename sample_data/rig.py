"""The virtual rig: settings, the random draws of one run, and the run from drive motion to files.

:func:`rigval.sample_data.simulate_rig` reproduces the set-up of docs/references.md ([paper]
section 4.1) on a mechanism:

1. true drive motion (:mod:`~rigval.sample_data.drive`) and the model truth along it
   (:mod:`~rigval.sample_data.truth`);
2. sensors (:mod:`~rigval.sample_data.sensors`);
3. devices with their own clocks, dropouts, module delays and ADCs
   (:mod:`~rigval.sample_data.devices`), sampled by :mod:`~rigval.sample_data.streams`;
4. files: cDAQ and WLS #1 TDMS, WLS #2 CSV, truth, scene and note
   (:mod:`~rigval.sample_data.simulate`).

This module holds the settings and draws everything random about a run (:func:`draw_rig`).

Every random draw comes from ``numpy.random.SeedSequence(seed)`` children in a fixed order, and no
file holds wall-clock time, so one seed gives byte-identical files.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field, fields, replace
from pathlib import Path

import numpy as np

from rigval.acquisition.errors import ConfigError
from rigval.sample_data.departures import Departures, calibration_errors
from rigval.sample_data.devices import ClockSegment, DeviceClock, dropout_segments
from rigval.sample_data.drive import DriveMotion, Harmonic, SpeedWander
from rigval.sample_data.faults import Fault
from rigval.sample_data.sensors import (
    ChargeAccelerometer,
    Encoder,
    OpticalSensor,
    StrainBridge,
    TorsionBridge,
)

__all__ = ["FS_CDAQ", "FS_WLS", "Imperfections", "RigDraw", "RigSettings", "RunFiles", "draw_rig",
           "run_stem"]

logger = logging.getLogger(__name__)

#: cDAQ AI sample clock (Hz) and the NI 9237 rate on the wireless carriers, 50 kS/s / 31 (Hz).
FS_CDAQ = 5000.0
FS_WLS = 50000.0 / 31.0
#: Longest record in s (4 hours; the rig writes in windows and keeps a long record's truth
#: grid in temporary files).
MAX_DURATION_S = 14400.0
#: Date the virtual rig's runs are dated from (a run starts ``seed`` days later, see
#: :func:`draw_rig`).
BASE_START = np.datetime64("2026-03-10T08:00:00", "ns")


@dataclass(frozen=True)
class Imperfections:
    """How imperfect the rig is; :meth:`none` gives an ideal rig (only quantisation remains).

    Parameters
    ----------
    start_offset_s : float, default 1.5
        The wireless carriers start within +- this (s) of the cDAQ.
    drift_ppm : float, default 50
        Bound of each device's oscillator error (ppm), drawn uniformly.
    stamp_error_s : float, default 0.02
        Software start-time stamp error of the wireless carriers (s rms); the USB cDAQ's is a
        tenth of it.
    host_clock_s : float, default 1.0
        Bound of the offset (s) of the second laptop's clock, which stamps WLS #2's start times.
    dropouts : int, default 1
        Wi-Fi dropouts (each followed by a task restart) per wireless carrier.
    missing_pulse_probability : float, default 0.03
        Probability that an optical pulse is missing (1).
    spurious_pulses_per_minute : float, default 3
        Mean rate of spurious optical pulses per sensor (1/min).
    noise : float, default 1
        Scale of all sensor noise and timing jitter (1 = the rig's typical levels).
    torque_split : float, default 0.03
        Bound of ``|share - 0.5|`` of each shaft pair's torque split (1).
    bridge_drift : float, default 1
        Scale of the strain bridges' residual zero offsets and thermal drift (1 = typical).
    speed_wander : float, default 0.004
        Relative amplitude of the slow speed wander that makes cycles uneven (1); 0 gives an
        exactly periodic drive (a speed-controlled machine).
    stamp_offset_s : float, default 0
        Extra error (s) of every start stamp of WLS #1 that its scene does not declare (a
        wrong host clock: the profile says 0.1 s).
    running_clock : bool, default False
        True: the wireless carriers' clocks run on through each dropout (no task restart; the
        samples after it are stamped by counting).
    fast_pulses : bool, default False
        True: optical sensors with 1 us edges instead of 100 us; opt1 on the NI 9215 (no
        anti-alias filter) is then sample-switched, each edge known only to +-0.5 sample.
    """

    start_offset_s: float = 1.5
    drift_ppm: float = 50.0
    stamp_error_s: float = 0.02
    host_clock_s: float = 1.0
    dropouts: int = 1
    missing_pulse_probability: float = 0.03
    spurious_pulses_per_minute: float = 3.0
    noise: float = 1.0
    torque_split: float = 0.03
    bridge_drift: float = 1.0
    speed_wander: float = 0.004
    stamp_offset_s: float = 0.0
    running_clock: bool = False
    fast_pulses: bool = False

    @classmethod
    def none(cls) -> Imperfections:
        """Return an ideal rig: no offsets, drift, dropouts, noise or pulse faults."""
        return cls(**{f.name: type(f.default)(0) for f in fields(cls)})

    def check(self) -> None:
        """Raise ConfigError for a negative level or a probability above 1."""
        for name, value in vars(self).items():
            if value < 0 and name != "stamp_offset_s":
                raise ConfigError(f"imperfection {name} must be >= 0, got {value}",
                                  where={"key": name})
        if self.missing_pulse_probability >= 1:
            raise ConfigError("missing_pulse_probability must be below 1",
                              where={"key": "missing_pulse_probability"})
        if self.torque_split >= 0.5:
            raise ConfigError("torque_split must be below 0.5 (a share stays positive)",
                              where={"key": "torque_split"})


@dataclass(frozen=True)
class RigSettings:
    """One run of the virtual rig.

    Parameters
    ----------
    speed : float, default 1.0
        Main-shaft speed in rev/s.
    duration : float, default 20
        Length of each device's record in s.
    seed : int, default 1
        Seed of every random draw.
    imperfections : Imperfections
        Imperfection levels.
    mechanism : str or Path or None
        Mechanism file; None: rigval's built-in ``pendulum.toml``.
    truth_fs : float, default 1000
        Rate of the model truth grid in Hz (devices interpolate it with cubic splines).
    preroll : float, default 12
        Truth computed this long (s) before the first device starts, so the charge amplifiers'
        high-pass (time constant 1.6 s at 0.1 Hz) and the frame vibration are in steady state.
    index_reset : bool, default False
        True: the main-shaft counter (enc1) reloads 0 at every index pulse (NI-DAQmx Z index
        enabled); False: both counters count on from the task start.
    faults : tuple of Fault, default ()
        Sensor faults injected into the written channels (:mod:`rigval.sample_data.faults`);
        their truth goes to ``faults`` in ``truth.json``.
    departures : Departures
        Where the rig departs from the rigid planar model and its scene (a flexible mode, rod
        bending, calibration errors, a lag, a torque split, other masses); default: none.
    """

    speed: float = 1.0
    duration: float = 20.0
    seed: int = 1
    imperfections: Imperfections = field(default_factory=Imperfections)
    mechanism: str | Path | None = None
    truth_fs: float = 1000.0
    preroll: float = 12.0
    index_reset: bool = False
    faults: tuple[Fault, ...] = ()
    departures: Departures = field(default_factory=Departures)

    def check(self) -> None:
        """Raise ConfigError for settings the rig cannot run."""
        if not 0.05 <= self.speed <= 5.0:
            raise ConfigError(f"speed must be within 0.05 ... 5 rev/s, got {self.speed}",
                              where={"key": "speed"})
        if not 1.0 <= self.duration <= MAX_DURATION_S:
            raise ConfigError(f"duration must be within 1 ... {MAX_DURATION_S:g} s, got "
                              f"{self.duration}", where={"key": "duration"})
        if self.seed < 0:
            raise ConfigError(f"seed must be >= 0, got {self.seed}", where={"key": "seed"})
        self.imperfections.check()
        for fault in self.faults:
            fault.check()
        self.departures.check()


def run_stem(speed: float) -> str:
    """Return the file-name stem of a run at ``speed`` rev/s, e.g. ``run_0p8``."""
    text = f"{speed:.3f}".rstrip("0")
    return "run_" + (text + "0" if text.endswith(".") else text).replace(".", "p")


@dataclass(frozen=True)
class RigDraw:
    """Everything random about one run: the drive, the clocks, the sensors and their settings.

    Parameters
    ----------
    start_time : numpy.datetime64
        Absolute UTC time of true time 0 (the cDAQ's first sample).
    drive : DriveMotion
        True drive motion.
    clocks : dict of str to DeviceClock
        ``"cdaq"``, ``"wls1"``, ``"wls2"``.
    accelerometers : dict of str to ChargeAccelerometer
        ``"acc1"``, ``"acc2"``, ``"acc3"``.
    str1 : StrainBridge
        Rod B bridge.
    torsion : dict of str to TorsionBridge
        ``"tor1"`` ... ``"tor4"``.
    encoders : dict of str to Encoder
        ``"enc1"`` (theta_F, index reset as the settings say), ``"enc2"`` (theta_H, cumulative).
    optical : dict of str to OpticalSensor
        ``"opt1"`` (cDAQ, volts), ``"opt2"``, ``"opt3"`` (NI 9237 channels, V/V).
    frame : dict of str to float
        Frame mode seen by acc3: ``natural_hz``, ``damping_ratio``, ``modal_mass`` (kg).
    pulse_seeds : dict of str to numpy.random.SeedSequence
        Random source of each optical sensor's pulse faults.
    noise_seed : numpy.random.SeedSequence
        Random source of the sample noise.
    missing_probability : float
        Probability that an optical pulse is missing (1).
    spurious_per_minute : float
        Mean rate of spurious optical pulses (1/min).
    bending : dict of str to StrainBridge
        Gauge pair on rod B's faces (``str2`` stretched by bending, ``str3`` opposite); empty
        unless the departures ask for rod bending.
    calibration_error : dict of str to float
        Relative error of each sensor's true sensitivity over the value its scene states (1);
        the sensors above are the true ones. Empty: the scene states the truth.
    lags : dict of str to float
        Undeclared lag of a channel's samples beyond its module's delay (s).
    """

    start_time: np.datetime64
    drive: DriveMotion
    clocks: dict[str, DeviceClock]
    accelerometers: dict[str, ChargeAccelerometer]
    str1: StrainBridge
    torsion: dict[str, TorsionBridge]
    encoders: dict[str, Encoder]
    optical: dict[str, OpticalSensor]
    frame: dict[str, float]
    pulse_seeds: dict[str, np.random.SeedSequence]
    noise_seed: np.random.SeedSequence
    missing_probability: float
    spurious_per_minute: float
    bending: dict[str, StrainBridge] = field(default_factory=dict)
    calibration_error: dict[str, float] = field(default_factory=dict)
    lags: dict[str, float] = field(default_factory=dict)


def _round(value: float, decimals: int) -> float:
    """Round to ``decimals`` decimals, as a calibration sheet prints the value."""
    return round(float(value), decimals)


def _drive(settings: RigSettings, drivers: dict[str, tuple[float, tuple[Harmonic, ...]]],
           rng: np.random.Generator) -> DriveMotion:
    omega = 2.0 * np.pi * settings.speed
    level = settings.imperfections.speed_wander
    wander = tuple(SpeedWander(omega * ratio * rng.uniform(0.9, 1.1), level * share,
                               rng.uniform(0.0, 2.0 * np.pi))
                   for ratio, share in ((0.13, 0.5), (0.29, 0.3), (0.47, 0.2)))
    # Belt and gear ripple on top of the mechanism file's harmonics.
    extra_f = (Harmonic(order=2, amplitude=rng.uniform(0.003, 0.008),
                         phase=rng.uniform(0.0, 2.0 * np.pi)),)
    # An even order on the lifting shaft: its two pulses per main revolution stay half a turn apart.
    extra_h = (Harmonic(order=2, amplitude=rng.uniform(0.003, 0.008),
                         phase=rng.uniform(0.0, 2.0 * np.pi)),)
    theta_f0, ripple_f = drivers["theta_F"]
    theta_h0, ripple_h = drivers["theta_H"]
    return DriveMotion(settings.speed, theta_f0, theta_h0, ripple_f + extra_f, ripple_h + extra_h,
                       wander if level > 0 else ())


def _clocks(settings: RigSettings, rng: np.random.Generator) -> dict[str, DeviceClock]:
    imp = settings.imperfections
    cdaq_fs = FS_CDAQ * (1.0 + rng.uniform(-1.0, 1.0) * imp.drift_ppm * 1e-6)
    cdaq = DeviceClock(FS_CDAQ, (cdaq_fs / FS_CDAQ - 1.0) * 1e6,
                       (ClockSegment(0.0, int(np.floor(settings.duration * cdaq_fs)),
                                     float(rng.normal(0.0, imp.stamp_error_s / 10.0))),))
    clocks = {"cdaq": cdaq}
    for name in ("wls1", "wls2"):
        drift = rng.uniform(-1.0, 1.0) * imp.drift_ppm
        fs_true = FS_WLS * (1.0 + drift * 1e-6)
        start = rng.uniform(-1.0, 1.0) * imp.start_offset_s
        segments = dropout_segments(start, settings.duration, fs_true, imp.dropouts,
                                    imp.stamp_error_s, rng, running_clock=imp.running_clock,
                                    fs_nominal=FS_WLS)
        if name == "wls1" and imp.stamp_offset_s:
            segments = tuple(replace(seg, stamp_error=seg.stamp_error + imp.stamp_offset_s)
                             for seg in segments)
        clocks[name] = DeviceClock(FS_WLS, drift, segments)
    # WLS #2 is logged on a second laptop whose clock is off: every stamp it writes is shifted.
    host = float(rng.uniform(-1.0, 1.0) * imp.host_clock_s)
    wls2 = clocks["wls2"]
    clocks["wls2"] = DeviceClock(
        wls2.fs_nominal, wls2.drift_ppm,
        tuple(replace(seg, stamp_error=seg.stamp_error + host) for seg in wls2.segments), host)
    return clocks


def draw_rig(settings: RigSettings,
             drivers: dict[str, tuple[float, tuple[Harmonic, ...]]]) -> RigDraw:
    """Draw everything random about a run from its seed.

    Parameters
    ----------
    settings : RigSettings
        The run.
    drivers : dict
        ``{"theta_F": (theta0, ripple), "theta_H": (theta0, ripple)}`` from the mechanism file:
        angle at the reference position (rad) and the harmonics of its law as functions of the
        main-shaft phase.

    Returns
    -------
    RigDraw
        The draws.
    """
    settings.check()
    imp = settings.imperfections
    seeds = np.random.SeedSequence(settings.seed).spawn(8)
    rng = np.random.default_rng(seeds[0])
    # A working day (08:00-16:00 UTC) some days after the base date, fixed by the seed.
    start = (BASE_START + np.timedelta64(settings.seed % 365, "D")
             + np.timedelta64(int(rng.integers(0, 8 * 3600)), "s")
             + np.timedelta64(int(rng.integers(0, 10**9)), "ns"))
    drive = _drive(settings, drivers, np.random.default_rng(seeds[1]))
    clocks = _clocks(settings, np.random.default_rng(seeds[2]))
    rng = np.random.default_rng(seeds[3])
    noise = imp.noise
    # The frame sensor acc3 sees far less than the moving bodies: its amplifier gain is 10x.
    accelerometers = {
        name: ChargeAccelerometer(_round(rng.uniform(9.5, 10.5), 2), gain, 0.1, 5e-4 * noise)
        for name, gain in (("acc1", 10.0), ("acc2", 10.0), ("acc3", 100.0))}
    drift = imp.bridge_drift
    str1 = StrainBridge(bridge_type="half_i", gauge_factor=_round(rng.uniform(2.0, 2.1), 2),
                        poisson=0.3, youngs_modulus=210e9, area=1.9e-3, excitation=2.5,
                        zero_offset=rng.uniform(-1.0, 1.0) * 2e-7 * drift,
                        drift_total=rng.uniform(-1.0, 1.0) * 4e-7 * drift,
                        drift_time_constant=60.0, noise_rms=1e-7 * noise)
    gauge_factor_shafts = _round(rng.uniform(2.0, 2.1), 2)
    torsion = {}
    departures = settings.departures
    fixed = (departures.split_main, departures.split_lift)
    for (first, second), split in zip((("tor1", "tor2"), ("tor3", "tor4")), fixed, strict=True):
        share = 0.5 + rng.uniform(-1.0, 1.0) * imp.torque_split
        share = share if split is None else split
        for name, part in ((first, share), (second, 1.0 - share)):
            torsion[name] = TorsionBridge(
                gauge_factor=gauge_factor_shafts, outer_diameter=0.100, inner_diameter=0.060,
                shear_modulus=80e9, excitation=2.5, share=part,
                bending_strain=3e-5 * rng.uniform(0.5, 1.0),
                zero_offset=rng.uniform(-1.0, 1.0) * 5e-7 * drift,
                drift_total=rng.uniform(-1.0, 1.0) * 1e-6 * drift, drift_time_constant=90.0,
                noise_rms=2e-7 * noise)
    encoders = {"enc1": Encoder(8192, drive.theta_f0 + rng.uniform(0.0, 2.0 * np.pi),
                                settings.index_reset),
                "enc2": Encoder(8192, drive.theta_h0 + rng.uniform(0.0, 2.0 * np.pi), False)}
    rise = 1e-6 if imp.fast_pulses else 100e-6
    optical = {
        "opt1": OpticalSensor(0.3, 4.7, rise, 20e-6 * noise, np.deg2rad(10.0), 3e-3 * noise),
        "opt2": OpticalSensor(0.0, 4e-3, rise, 20e-6 * noise, np.deg2rad(10.0), 2e-7 * noise),
        "opt3": OpticalSensor(0.0, 4e-3, rise, 20e-6 * noise, np.deg2rad(10.0), 2e-7 * noise),
    }
    frame = {"natural_hz": _round(rng.uniform(18.0, 30.0), 1),
             "damping_ratio": _round(rng.uniform(0.02, 0.05), 3), "modal_mass": 900.0}
    pulse_seeds = dict(zip(("opt1", "opt2", "opt3"), seeds[4:7], strict=True))
    bending = ({name: replace(str1, bridge_type="quarter_i") for name in ("str2", "str3")}
               if departures.rod_bending > 0 else {})
    errors = {}
    if departures.calibration_error > 0:
        errors = calibration_errors(
            settings.seed, departures.calibration_error, tuple(torsion),
            {**dict.fromkeys(accelerometers, "accelerometer"),
             **dict.fromkeys(("str1", *bending), "strain")})
        accelerometers = {name: replace(s, charge_sensitivity=s.charge_sensitivity
                                        * (1.0 + errors[name]))
                          for name, s in accelerometers.items()}
        str1 = replace(str1, gauge_factor=str1.gauge_factor * (1.0 + errors["str1"]))
        bending = {name: replace(s, gauge_factor=s.gauge_factor * (1.0 + errors[name]))
                   for name, s in bending.items()}
        torsion = {name: replace(s, gauge_factor=s.gauge_factor * (1.0 + errors[name]))
                   for name, s in torsion.items()}
    return RigDraw(start, drive, clocks, accelerometers, str1, torsion, encoders, optical, frame,
                   pulse_seeds, seeds[7], imp.missing_pulse_probability,
                   imp.spurious_pulses_per_minute, bending, errors,
                   {departures.lag_channel: departures.lag_s} if departures.lag_channel else {})


@dataclass(frozen=True)
class RunFiles:
    """Paths of one written run.

    Parameters
    ----------
    folder : Path
        The run folder.
    stem : str
        File-name stem, e.g. ``run_0p8``.
    """

    folder: Path
    stem: str

    def path(self, suffix: str) -> Path:
        """Return the path of one file, e.g. ``path("cdaq.tdms")``."""
        return self.folder / f"{self.stem}_{suffix}"

    @property
    def files(self) -> tuple[Path, ...]:
        """All files of the run, in a fixed order."""
        return tuple(self.path(s) for s in ("cdaq.tdms", "wls1.tdms", "wls2.csv", "scene.toml",
                                             "note.txt", "truth.json", "truth.npz"))
