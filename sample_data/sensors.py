"""Sensor models of the virtual rig: from a true physical quantity to the sensor's output.

The bridge and charge-amplifier models are the exact forward models of
:mod:`rigval.processing.bridge`, :mod:`rigval.processing.torsion` and
:mod:`rigval.processing.accelerometer` (the same equations processing inverts), plus what real
sensors add: zero offsets, a slow thermal drift and noise. Noise is added by the device that samples
the sensor (:mod:`rigval.sample_data.devices`), from each sensor's ``noise_rms``.

Optical once-per-revolution sensors are pulse trains with a finite rise time (an error-function
edge of 10-90 % rise time ``rise_time``; through a delta-sigma module's anti-alias filter, that
edge band-limited by an ideal low-pass), per-edge jitter, and occasional missing or spurious
pulses (:func:`optical_pulses`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import erf, sici

from rigval.acquisition.errors import ConfigError
from rigval.processing.accelerometer import charge_chain_voltage
from rigval.processing.arrays import FloatArray
from rigval.processing.bridge import bridge_ratio
from rigval.processing.torsion import rosette_bridge_ratio, shear_strain_from_torque
from rigval.sample_data.drive import DriveMotion

__all__ = [
    "BridgeErrors",
    "ChargeAccelerometer",
    "Encoder",
    "OpticalSensor",
    "PulseTrain",
    "StrainBridge",
    "TorsionBridge",
    "optical_pulses",
]

logger = logging.getLogger(__name__)

#: 10-90 % rise time of an error-function edge in units of its sigma: 2 sqrt(2) erfinv(0.8).
RISE_PER_SIGMA = 2.5631031310892007
#: Gauss-Hermite nodes and weights that average a band-limited step over a sensor's Gaussian edge.
_HERMITE = np.polynomial.hermite.hermgauss(16)
#: Largest ``band_limit * rise_time`` for which that quadrature is exact to rounding.
_MAX_BAND_RISE = 0.3


@dataclass(frozen=True)
class ChargeAccelerometer:
    """Charge accelerometer (PCB 357B40 type) with charge amplifier.

    Parameters
    ----------
    charge_sensitivity : float
        Charge sensitivity S_q in pC/g (calibration certificate).
    amplifier_gain : float
        Charge amplifier gain in mV/pC.
    highpass_hz : float
        First-order high-pass corner of the amplifier in Hz.
    noise_rms : float
        Output noise in V rms (white, at the sampling device's bandwidth).
    """

    charge_sensitivity: float
    amplifier_gain: float
    highpass_hz: float
    noise_rms: float

    def voltage(self, fs: float, acceleration: ArrayLike) -> FloatArray:
        """Return the amplifier output (V) for an acceleration (m s-2) sampled uniformly at fs (Hz).

        The record should start well before the data of interest (a pre-roll of several high-pass
        time constants ``1 / (2 pi f_c)``): the high-pass starts from the steady state of the
        first sample.
        """
        return charge_chain_voltage(acceleration, charge_sensitivity=self.charge_sensitivity,
                                    amplifier_gain=self.amplifier_gain, fs=fs,
                                    highpass_hz=self.highpass_hz)

    def voltage_unfiltered(self, acceleration: ArrayLike) -> FloatArray:
        """Return the amplifier output (V) for an acceleration (m s-2) before its high-pass."""
        return charge_chain_voltage(acceleration, charge_sensitivity=self.charge_sensitivity,
                                    amplifier_gain=self.amplifier_gain)


@dataclass(frozen=True, kw_only=True)
class BridgeErrors:
    """What a strain-gauge bridge adds to its exact ratio: imbalance, thermal drift and noise.

    Parameters
    ----------
    zero_offset : float
        Residual bridge imbalance after the pre-run offset null, in V/V.
    drift_total : float
        Final value of the slow thermal drift in V/V.
    drift_time_constant : float
        Time constant of the thermal drift in s.
    noise_rms : float
        Noise in V/V rms.
    """

    zero_offset: float
    drift_total: float
    drift_time_constant: float
    noise_rms: float

    def drifted(self, exact: FloatArray, t: ArrayLike) -> FloatArray:
        """Return the exact ratio (V/V) plus the zero offset and the drift at true times t (s).

        The drift is ``drift_total (1 - exp(-t / drift_time_constant))`` for t >= 0, 0 before.
        """
        elapsed = np.clip(np.asarray(t, dtype=np.float64), 0.0, None)
        return exact + self.zero_offset + self.drift_total * -np.expm1(
            -elapsed / self.drift_time_constant)


@dataclass(frozen=True, kw_only=True)
class StrainBridge(BridgeErrors):
    """Axial strain gauges in an NI bridge configuration (rod B: half bridge I on the neutral axis).

    Parameters
    ----------
    bridge_type : str
        NI bridge type, e.g. ``"half_i"`` (see :func:`rigval.processing.bridge.bridge_ratio`).
    gauge_factor : float
        Gauge factor of the lot (1).
    poisson : float
        Poisson ratio of the rod (1).
    youngs_modulus : float
        E of the rod in Pa.
    area : float
        Cross-section of the rod in m^2.
    excitation : float
        Bridge excitation in V.
    zero_offset, drift_total, drift_time_constant, noise_rms : float
        As for :class:`BridgeErrors`.
    gauge_resistance : float, default 120
        Gauge resistance in ohm.
    """

    bridge_type: str
    gauge_factor: float
    poisson: float
    youngs_modulus: float
    area: float
    excitation: float
    gauge_resistance: float = 120.0

    def strain(self, axial_force: ArrayLike) -> FloatArray:
        """Return the axial strain (1) of the rod under an axial force (N, tension positive)."""
        return np.asarray(axial_force, dtype=np.float64) / (self.youngs_modulus * self.area)

    def ratio(self, axial_force: ArrayLike, t: ArrayLike) -> FloatArray:
        """Return the bridge ratio Vr (V/V) at true times t (s) for the axial force there (N)."""
        exact = bridge_ratio(self.strain(axial_force), self.bridge_type,  # type: ignore[arg-type]
                             gauge_factor=self.gauge_factor, poisson=self.poisson,
                             gauge_resistance=self.gauge_resistance)
        return self.drifted(exact, t)


@dataclass(frozen=True, kw_only=True)
class TorsionBridge(BridgeErrors):
    """Two +-45 degree rosettes 180 degrees apart in a full bridge (NI Full Bridge I) on a shaft.

    Parameters
    ----------
    gauge_factor : float
        Gauge factor (1).
    outer_diameter, inner_diameter : float
        Shaft diameters in m.
    shear_modulus : float
        G of the shaft in Pa.
    excitation : float
        Bridge excitation in V.
    share : float
        Share of the drive's total torque this shaft carries (1); the other shaft carries the rest.
    bending_strain : float
        Amplitude of the once-per-revolution rotating bending strain at the rosettes (1); the full
        bridge cancels it to second order.
    zero_offset, drift_total, drift_time_constant, noise_rms : float
        As for :class:`BridgeErrors` (V/V, V/V, s, V/V rms).
    poisson : float, default 0.3
        Poisson ratio of the shaft (1).
    """

    gauge_factor: float
    outer_diameter: float
    inner_diameter: float
    shear_modulus: float
    excitation: float
    share: float
    bending_strain: float
    poisson: float = 0.3

    def ratio(self, drive_torque: ArrayLike, shaft_angle: ArrayLike, t: ArrayLike) -> FloatArray:
        """Return Vr (V/V) for the drive's total torque (N m) at shaft angles (rad), times (s)."""
        gamma = shear_strain_from_torque(self.share * np.asarray(drive_torque, dtype=np.float64),
                                         shear_modulus=self.shear_modulus,
                                         outer_diameter=self.outer_diameter,
                                         inner_diameter=self.inner_diameter)
        bending = self.bending_strain * np.sin(np.asarray(shaft_angle, dtype=np.float64))
        exact = rosette_bridge_ratio(gamma, "full", gauge_factor=self.gauge_factor,
                                     poisson=self.poisson, bending_strain=bending)
        return self.drifted(exact, t)


@dataclass(frozen=True)
class Encoder:
    """Quadrature encoder decoded x4 by an NI counter.

    Parameters
    ----------
    counts_per_rev : int
        Counts per revolution after x4 decoding (2048 lines -> 8192).
    index_angle : float
        Shaft angle (rad, the drive's angle) at which the index (Z) pulse fires.
    index_reset : bool
        True: the counter reloads 0 at every index pulse (NI-DAQmx Z index enabled), so counts run
        0 ... counts_per_rev - 1 after the first index; False: cumulative counts from task start.
    """

    counts_per_rev: int
    index_angle: float
    index_reset: bool

    def counts(self, angle: ArrayLike, angle_at_start: float) -> NDArray[np.uint32]:
        """Return the counter values (uint32) for the shaft angles (rad) at the samples.

        Parameters
        ----------
        angle : array_like
            Unwrapped shaft angle at each sample in rad (non-decreasing in practice).
        angle_at_start : float
            Shaft angle when the counter task started (its count is 0 there).
        """
        cpr = self.counts_per_rev
        per_rad = cpr / (2.0 * np.pi)
        edges = np.floor(np.asarray(angle, dtype=np.float64) * per_rad).astype(np.int64)
        edge0 = int(np.floor(angle_at_start * per_rad))
        counts = edges - edge0
        if self.index_reset:
            # The counter reloads 0 on the count edge at the index position, once per turn.
            index_edge = int(np.ceil(self.index_angle * per_rad)) % cpr
            first_index = index_edge + cpr * ((edge0 - index_edge) // cpr + 1)
            counts = np.where(edges >= first_index, np.mod(edges - index_edge, cpr), counts)
        return np.mod(counts, 2**32).astype(np.uint32)


@dataclass(frozen=True)
class OpticalSensor:
    """Optical once-per-revolution sensor (Pepperl+Fuchs GLV12 type) and its reflective mark.

    Parameters
    ----------
    low, high : float
        Output levels in the channel's unit (V; V/V when the sensor switches a shunt on a spare
        bridge channel of an NI 9237).
    rise_time : float
        10-90 % rise (and fall) time of the output in s.
    jitter_rms : float
        Timing jitter of each edge in s rms.
    mark_width : float
        Angular width of the mark in rad (the pulse is high while the mark passes).
    noise_rms : float
        Output noise in the unit of ``low`` and ``high``, rms.
    """

    low: float
    high: float
    rise_time: float
    jitter_rms: float
    mark_width: float
    noise_rms: float


@dataclass(frozen=True)
class PulseTrain:
    """A train of non-overlapping pulses with error-function edges.

    Parameters
    ----------
    rises, falls : numpy.ndarray
        Edge times in s (true time), sorted, one fall per rise.
    low, high : float
        Levels (the sensor's output unit).
    rise_time : float
        10-90 % rise time of each edge in s.
    """

    rises: FloatArray
    falls: FloatArray
    low: float
    high: float
    rise_time: float

    def value(self, t: ArrayLike, band_limit: float | None = None) -> FloatArray:
        """Return the output (unit of ``low`` and ``high``) at true times t (s).

        Parameters
        ----------
        t : array_like
            True times in s.
        band_limit : float, optional
            Band edge in Hz of an ideal low-pass the signal passes afterwards (a delta-sigma
            module's anti-alias filter); None: the sensor's output as it is.
        """
        t = np.asarray(t, dtype=np.float64)
        out = np.zeros_like(t)
        if self.rises.size:
            last = np.searchsorted(self.rises, t) - 1  # the pulse that rose last (-1: none yet)
            for index in (last, last + 1):
                ok = (index >= 0) & (index < self.rises.size)
                i = np.clip(index, 0, self.rises.size - 1)
                pulse = (self._step(t - self.rises[i], band_limit)
                         - self._step(t - self.falls[i], band_limit))
                out += np.where(ok, pulse, 0.0)
        return self.low + (self.high - self.low) * out

    def _step(self, u: FloatArray, band_limit: float | None) -> FloatArray:
        """Return one edge's response (0 to 1) at times u (s) after it.

        The sensor's edge is an error function (Gaussian impulse response of standard deviation
        ``rise_time / RISE_PER_SIGMA``); an ideal low-pass at ``band_limit`` turns a step into
        ``1/2 + Si(2 pi band_limit u) / pi``, and the two in series are that sine integral
        averaged over the Gaussian (16-point Gauss-Hermite quadrature, exact to rounding while
        ``band_limit * rise_time <= 0.3``, i.e. a filter slower than the sensor).
        """
        sigma = self.rise_time / RISE_PER_SIGMA
        if band_limit is None:
            return 0.5 * (1.0 + erf(u / (np.sqrt(2.0) * sigma)))
        if band_limit * self.rise_time > _MAX_BAND_RISE:
            raise ConfigError(
                f"a {band_limit:.4g} Hz band limit on a {self.rise_time:.3g} s sensor edge: the "
                "filter is faster than the sensor, which this edge model does not cover",
                where={"key": "band_limit"},
                hint=f"keep band_limit * rise_time <= {_MAX_BAND_RISE} or pass band_limit=None")
        omega = 2.0 * np.pi * band_limit
        nodes, weights = _HERMITE
        shifted = u[..., None] - np.sqrt(2.0) * sigma * nodes
        return 0.5 + (sici(omega * shifted)[0] @ weights) / (np.pi * np.sqrt(np.pi))


def optical_pulses(sensor: OpticalSensor, drive: DriveMotion, drive_name: str,
                   reference_angle: float, t_start: float, t_stop: float,
                   rng: np.random.Generator, missing_probability: float,
                   spurious_per_minute: float) -> tuple[PulseTrain, dict[str, list[float]]]:
    """Return the pulse train an optical sensor produces and the truth of its pulses.

    A pulse rises when the drive angle passes ``reference_angle + 2 pi k`` and falls a mark width
    later; each edge is jittered; each pulse is missing with ``missing_probability``; spurious
    short pulses (1-3 ms) appear at random between real ones at ``spurious_per_minute``.

    Parameters
    ----------
    sensor : OpticalSensor
        The sensor.
    drive : DriveMotion
        True drive motion.
    drive_name : {"theta_F", "theta_H"}
        The shaft the mark is on (or the sensor rides on).
    reference_angle : float
        Drive angle of the rising edge, rad (any branch; all turns are used).
    t_start, t_stop : float
        True time span to cover in s.
    rng : numpy.random.Generator
        Random source (jitter, missing and spurious pulses).
    missing_probability : float
        Probability that a pulse is missing (1).
    spurious_per_minute : float
        Mean number of spurious pulses per minute.

    Returns
    -------
    PulseTrain
        The pulses, sorted.
    dict
        ``{"rise_true_s", "missing_true_s", "spurious_s"}``: ideal rising-edge times of the pulses
        present (before jitter), those of the missing ones, and the spurious pulses' rising edges.
    """
    theta_start = drive.angles(np.array([t_start]))[drive_name][0][0]
    theta_stop = drive.angles(np.array([t_stop]))[drive_name][0][0]
    k0 = np.ceil((theta_start - reference_angle) / (2.0 * np.pi))
    k1 = np.floor((theta_stop - reference_angle) / (2.0 * np.pi))
    turns = np.arange(k0, k1 + 1)
    rise_ideal = drive.crossing_times(drive_name, reference_angle + 2.0 * np.pi * turns)
    fall_ideal = drive.crossing_times(drive_name,
                                      reference_angle + 2.0 * np.pi * turns + sensor.mark_width)
    present = rng.random(turns.size) >= missing_probability
    rises = rise_ideal + rng.normal(0.0, sensor.jitter_rms, turns.size)
    falls = fall_ideal + rng.normal(0.0, sensor.jitter_rms, turns.size)
    n_spurious = rng.poisson(spurious_per_minute * (t_stop - t_start) / 60.0)
    spurious = np.sort(rng.uniform(t_start, t_stop, n_spurious))
    # Spurious pulses (reflections) fall between real pulses, clear of them by 10 ms.
    clear = [not np.any((s > rise_ideal - 0.01) & (s < fall_ideal + 0.015)) for s in spurious]
    spurious = spurious[np.asarray(clear, dtype=bool)]
    widths = rng.uniform(1e-3, 3e-3, spurious.size)
    all_rises = np.concatenate([rises[present], spurious])
    all_falls = np.concatenate([falls[present], spurious + widths])
    order = np.argsort(all_rises)
    train = PulseTrain(all_rises[order], all_falls[order], sensor.low, sensor.high,
                       sensor.rise_time)
    record = {"rise_true_s": rise_ideal[present].tolist(),
              "missing_true_s": rise_ideal[~present].tolist(),
              "spurious_s": spurious.tolist()}
    return train, record
