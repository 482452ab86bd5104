"""Where the virtual rig departs from the rigid planar model and from its scene: the truths.

The default rig is the rigid planar model measured by calibrated sensors. The diagnosis of
docs/diagnosis.md asks *why* a model disagrees, so the rig can be told to depart from that on
purpose, with every departure written to the truth JSON (``departures``):

* a flexible mode of one body (:class:`Departures` ``mode_*``), excited by the rigid-body motion
  and by broadband forcing, seen by that body's gauges and accelerometers
  (:func:`flexible_mode`);
* a gauge pair on opposite faces of rod B (``str2``, ``str3``) that sees the rod's bending
  (``rod_bending``);
* a calibration error per sensor drawn from the uncertainties the scene states
  (``calibration_error``; :func:`calibration_errors`);
* an undeclared time lag on one channel (``lag_channel``, ``lag_s``);
* a fixed torque split between the two shafts of a drive (``split_main``, ``split_lift``);
* body masses other than the scene's mechanism file says (``mass_scale``).

All default to off, and the default rig's draws and files are unchanged: the random draws of a
departure come from their own ``SeedSequence`` spawn keys.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigval.acquisition.errors import ConfigError
from rigval.processing.arrays import FloatArray
from rigval.processing.scipy_signal import lsim
from rigval.sample_data.truth import TruthGrid

__all__ = ["CALIBRATION_UNCERTAINTY", "MODE_BODIES", "ROD_SECTION_MODULUS", "Departures",
           "ModeResponse", "calibration_errors", "departed_grid", "flexible_mode",
           "resonance"]

logger = logging.getLogger(__name__)

#: Bodies that can carry a flexible mode: the channel whose rigid signal sets the mode's level,
#: and each channel that sees it with its participation (signal of the mode at that channel
#: over the mode's signal at the level channel, in the channel's own unit; see
#: :func:`flexible_mode`).
MODE_BODIES: dict[str, dict[str, Any]] = {
    # Rod B's first axial mode: the mid-length gauges see its stress; acc2 at P2 sees the
    # acceleration of the rod's end (elongation of half the rod, projected on x).
    "B": {"level_channel": "str1", "description": "rod B, first axial mode"},
    # Arm A's first bending mode: the tip accelerometer acc1; acc2 at P2 (0.75 m above the
    # centre of gravity, the tip 1.4 m below) moves -0.35 times the tip.
    "A": {"level_channel": "acc1", "participation": {"acc2": -0.35},
          "description": "pendulum arm A, first bending mode"},
}
#: Standard calibration uncertainty (relative, 1) the rig's scene states per sensor kind, and
#: the part common to all shafts of the torsion bridges (one gauge lot, one steel, one drawing).
CALIBRATION_UNCERTAINTY = {"accelerometer": 0.02, "strain": 0.02, "torsion_common": 0.0098,
                           "torsion_own": 0.002}
#: Section modulus of rod B for in-plane bending (m3): a 38 x 50 mm bar (A = 1.9e-3 m2),
#: 50 mm in the plane, W = b h^2 / 6.
ROD_SECTION_MODULUS = 0.038 * 0.050**2 / 6.0
#: Spawn keys of the departures' random draws (apart from the rig's own eight children).
SPAWN_CALIBRATION, SPAWN_MODE = 20, 21
#: Channels that can carry an undeclared lag.
LAG_CHANNELS = ("acc1", "acc2", "acc3", "str1", "str2", "str3", "tor1", "tor2", "tor3", "tor4")


@dataclass(frozen=True)
class Departures:
    """How the rig departs from the rigid planar model and its scene (all off by default).

    Parameters
    ----------
    mode_body : str or None, default None
        Body with a flexible mode (a key of :data:`MODE_BODIES`: ``"B"`` rod B, ``"A"`` the
        arm); None: no mode.
    mode_hz : float, default 18
        Natural frequency of the mode in Hz.
    mode_damping : float, default 0.02
        Damping ratio of the mode (1).
    mode_level : float, default 0.05
        Amplitude of the mode at its level channel (str1 for B, acc1 for A), as ``sqrt(2)``
        times its rms over the record, relative to the range (max - min) of that channel's
        rigid signal over the record (1).
    rod_bending : float, default 0
        Above 0: a gauge pair on the two faces of rod B at mid-length (``str2`` on the face
        bending stretches, ``str3`` opposite), quarter bridges, seeing the axial stress plus and
        minus the bending stress ``rod_bending M / W`` (M: the bending moment the rod's weight
        and inertia put at mid-length, W: :data:`ROD_SECTION_MODULUS`).
    calibration_error : float, default 0
        Scale of each sensor's calibration error (1: drawn from the standard uncertainties the
        scene states, :data:`CALIBRATION_UNCERTAINTY`); the scene keeps the nominal values.
    lag_channel : str or None, default None
        Channel whose samples lag by ``lag_s`` beyond the module's delay, undeclared.
    lag_s : float, default 0
        That lag in s (may be negative: a lead).
    split_main, split_lift : float or None, default None
        Share of tor1 (main drive) / tor3 (lifting drive) in its drive's torque; None: drawn
        within the imperfections' ``torque_split`` bound as before.
    mass_scale : tuple of (str, float), default ()
        ``(body, factor)`` pairs: the rig's mechanism has these bodies' masses times the factor,
        while the scene names the unchanged mechanism file.
    """

    mode_body: str | None = None
    mode_hz: float = 18.0
    mode_damping: float = 0.02
    mode_level: float = 0.05
    rod_bending: float = 0.0
    calibration_error: float = 0.0
    lag_channel: str | None = None
    lag_s: float = 0.0
    split_main: float | None = None
    split_lift: float | None = None
    mass_scale: tuple[tuple[str, float], ...] = ()

    @property
    def active(self) -> bool:
        """True if any departure is switched on."""
        return self != Departures()

    def check(self) -> None:
        """Raise ConfigError for a departure the rig cannot make."""
        if self.mode_body is not None:
            if self.mode_body not in MODE_BODIES:
                raise ConfigError(f"no flexible mode for body {self.mode_body!r}",
                                  where={"key": "mode_body"},
                                  hint=f"use one of {sorted(MODE_BODIES)}")
            if not 1.0 <= self.mode_hz <= 200.0:
                raise ConfigError(f"mode_hz must be within 1 ... 200 Hz, got {self.mode_hz}",
                                  where={"key": "mode_hz"},
                                  hint="the rig's truth grid runs at 1 kHz")
            if not 0.001 <= self.mode_damping <= 0.3:
                raise ConfigError(f"mode_damping must be within 0.001 ... 0.3, got "
                                  f"{self.mode_damping}", where={"key": "mode_damping"})
            if not 0.0 < self.mode_level <= 1.0:
                raise ConfigError(f"mode_level must be within (0, 1], got {self.mode_level}",
                                  where={"key": "mode_level"})
        for key in ("rod_bending", "calibration_error"):
            if getattr(self, key) < 0:
                raise ConfigError(f"{key} must be >= 0, got {getattr(self, key)}",
                                  where={"key": key})
        if self.lag_channel is not None and self.lag_channel not in LAG_CHANNELS:
            raise ConfigError(f"cannot lag channel {self.lag_channel!r}",
                              where={"key": "lag_channel"}, hint=f"use one of {LAG_CHANNELS}")
        if self.lag_channel in ("str2", "str3") and self.rod_bending <= 0:
            raise ConfigError(f"{self.lag_channel} exists only with rod_bending > 0",
                              where={"key": "lag_channel"})
        if abs(self.lag_s) > 0.5:
            raise ConfigError(f"lag_s must be within +-0.5 s, got {self.lag_s}",
                              where={"key": "lag_s"})
        for key in ("split_main", "split_lift"):
            value = getattr(self, key)
            if value is not None and not 0.0 < value < 1.0:
                raise ConfigError(f"{key} must be within (0, 1), got {value}", where={"key": key})
        for body, factor in self.mass_scale:
            if not 0.1 <= factor <= 10.0:
                raise ConfigError(f"mass factor of {body} must be within 0.1 ... 10, got {factor}",
                                  where={"key": f"mass_scale.{body}"})

    def record(self) -> dict[str, Any]:
        """Return the departures as a JSON-ready mapping (for truth.json)."""
        out: dict[str, Any] = {
            "mode_body": self.mode_body, "rod_bending": self.rod_bending,
            "calibration_error": self.calibration_error, "lag_channel": self.lag_channel,
            "lag_s": self.lag_s, "split_main": self.split_main, "split_lift": self.split_lift,
            "mass_scale": dict(self.mass_scale)}
        if self.mode_body is not None:
            out.update(mode_hz=self.mode_hz, mode_damping=self.mode_damping,
                       mode_level=self.mode_level)
        return out


def calibration_errors(seed: int, scale: float, torsion: tuple[str, ...],
                       others: dict[str, str]) -> dict[str, float]:
    """Draw each sensor's relative calibration error (true sensitivity / stated - 1).

    Parameters
    ----------
    seed : int
        The run's seed (the draws use spawn key :data:`SPAWN_CALIBRATION`).
    scale : float
        Multiple of the stated standard uncertainties (1: as stated).
    torsion : tuple of str
        Torsion channels: a common error (``torsion_common``) plus each one's own.
    others : dict of str to str
        Other channels and their kind (``"accelerometer"``, ``"strain"``).

    Returns
    -------
    dict of str to float
        Relative error per channel (1), Gaussian with the stated standard uncertainty.
    """
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(SPAWN_CALIBRATION,)))
    u = CALIBRATION_UNCERTAINTY
    common = rng.normal(0.0, u["torsion_common"] * scale)
    out = {name: float(common + rng.normal(0.0, u["torsion_own"] * scale)) for name in torsion}
    out.update({name: float(rng.normal(0.0, u[kind] * scale)) for name, kind in others.items()})
    return out


def resonance(t: FloatArray, u: FloatArray, natural_hz: float, damping_ratio: float,
              acceleration: bool = False) -> FloatArray:
    """Return one mode's response to an input, ``H(s) = wn^2 / (s^2 + 2 zeta wn s + wn^2)``.

    Unit static gain: a slow input passes unchanged. Solved exactly for an input linear between
    samples (:func:`scipy.signal.lsim`), starting at rest.

    Parameters
    ----------
    t : numpy.ndarray
        Uniform times in s.
    u : numpy.ndarray
        Input, any unit.
    natural_hz, damping_ratio : float
        Natural frequency (Hz) and damping ratio (1).
    acceleration : bool, default False
        True: the second time derivative of the response (``s^2 H``), unit of u per s^2.
    """
    wn = 2.0 * np.pi * natural_hz
    num = [wn**2, 0.0, 0.0] if acceleration else [wn**2]
    _, y, _ = lsim((num, [1.0, 2.0 * damping_ratio * wn, wn**2]), u, t - t[0])
    return np.asarray(y, dtype=np.float64)


@dataclass(frozen=True)
class ModeResponse:
    """A flexible mode's contribution to the signals of its body, on the truth grid.

    Parameters
    ----------
    level_signal : numpy.ndarray
        The mode's part of the level channel's signal (its unit: Pa for str1, m s-2 for acc1).
    level_acceleration : numpy.ndarray
        Its second time derivative (unit per s^2).
    achieved_level : float
        ``sqrt(2) rms / range`` over the record (1); the requested level unless the orders near
        the mode alone excite more.
    broadband_gain : float
        Scale of the unit white forcing that tops the orders' response up to the level.
    order_share : float
        Share of the mode's variance that the rigid-body forcing (the orders) drives (1).
    """

    level_signal: FloatArray
    level_acceleration: FloatArray
    achieved_level: float
    broadband_gain: float
    order_share: float


def flexible_mode(t: FloatArray, rigid: FloatArray, in_record: NDArray[np.bool_],
                  departures: Departures, seed: int) -> ModeResponse:
    """Return a flexible mode's part of a signal, excited by the rigid motion and broadband.

    The mode is a single degree of freedom of unit static gain (:func:`resonance`) driven by
    the rigid-body signal of its level channel (the force or acceleration the rigid motion puts
    on the body) plus white forcing (clearances, gear mesh, the floor). Its part of the signal
    is what it adds beyond the quasi-static (rigid) response: ``(H - 1) rigid + g H w``, so
    the rigid model stays exact for slow loads, the orders near the mode are amplified by up to
    ``1 / (2 zeta)``, and the white forcing gives the resonance its off-order peak. ``g`` is
    chosen so the part's amplitude ``sqrt(2) rms`` over the record is ``mode_level`` times the
    rigid signal's range.

    Parameters
    ----------
    t : numpy.ndarray
        Uniform times of the truth grid in s (starting well before the record, so the mode
        starts in steady state).
    rigid : numpy.ndarray
        The level channel's rigid-body signal on ``t``.
    in_record : numpy.ndarray of bool
        Grid points within the devices' records (level and range are taken there).
    departures : Departures
        ``mode_hz``, ``mode_damping``, ``mode_level``.
    seed : int
        The run's seed (the white forcing uses spawn key :data:`SPAWN_MODE`).

    Returns
    -------
    ModeResponse
        The mode's part and how it was scaled.
    """
    fn, zeta = departures.mode_hz, departures.mode_damping
    dyn_input = rigid - rigid[0]  # the mode starts at rest under the first load
    orders = resonance(t, dyn_input, fn, zeta) - dyn_input
    orders_acc = resonance(t, dyn_input, fn, zeta, acceleration=True) - np.gradient(
        np.gradient(dyn_input, t), t)
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(SPAWN_MODE,)))
    white = rng.normal(0.0, 1.0, t.size)
    broad = resonance(t, white, fn, zeta)
    broad_acc = resonance(t, white, fn, zeta, acceleration=True)
    rec = in_record
    target = departures.mode_level * float(np.ptp(rigid[rec])) / np.sqrt(2.0)
    a2, ab, b2 = (float(np.mean(orders[rec] ** 2)), float(np.mean(orders[rec] * broad[rec])),
                  float(np.mean(broad[rec] ** 2)))
    disc = ab**2 - b2 * (a2 - target**2)
    gain = max((-ab + np.sqrt(disc)) / b2, 0.0) if disc >= 0 else 0.0
    if gain == 0.0:
        logger.warning("the orders near the %.1f Hz mode alone exceed its level %.3f",
                       fn, departures.mode_level)
    signal = orders + gain * broad
    achieved = float(np.sqrt(2.0 * np.mean(signal[rec] ** 2)) / np.ptp(rigid[rec]))
    return ModeResponse(signal, orders_acc + gain * broad_acc, achieved, float(gain),
                        float(a2 / np.mean(signal[rec] ** 2)))


def departed_grid(grid: TruthGrid, departures: Departures, seed: int, record: tuple[float, float],
                  rod_area: float, rod_modulus: float) -> tuple[TruthGrid, dict[str, Any]]:
    """Return the truth grid with the departures' physics added, and what was added.

    Parameters
    ----------
    grid : TruthGrid
        The rigid model's truth (:func:`rigval.sample_data.truth.model_truth`).
    departures : Departures
        The departures (the mode and rod bending act here).
    seed : int
        The run's seed.
    record : tuple of float
        First and last true time (s) of the devices' records.
    rod_area, rod_modulus : float
        Rod B's cross-section (m2) and Young's modulus (Pa).

    Returns
    -------
    TruthGrid
        The grid with ``rod_B_axial_force``, ``acc_P1_x``, ``acc_P2_x`` carrying the mode and
        ``rod_B_bending_stress`` (Pa, positive on the face at +n) when the rod bends.
    dict
        The mode's truth for truth.json (empty without a mode).
    """
    values = dict(grid.values)
    if departures.rod_bending > 0:
        values["rod_B_bending_stress"] = (departures.rod_bending * values["rod_B_bending_moment"]
                                          / ROD_SECTION_MODULUS)
    body = departures.mode_body
    if body is None:
        return TruthGrid(grid.t, values), {}
    in_record = (grid.t >= record[0]) & (grid.t <= record[1])
    if body == "B":
        mode = flexible_mode(grid.t, values["rod_B_axial_force"] / rod_area, in_record,
                             departures, seed)
        values["rod_B_axial_force"] = values["rod_B_axial_force"] + mode.level_signal * rod_area
        # P2 moves with the elongation of half the rod (strain sigma / E over L / 2) along the
        # rod's axis.
        end = mode.level_acceleration * values["rod_B_length"] / (2.0 * rod_modulus)
        values["acc_P2_x"] = values["acc_P2_x"] + end * values["rod_B_axis_x"]
        seen = ["str1", "str2", "str3", "acc2"] if departures.rod_bending > 0 else ["str1",
                                                                                   "acc2"]
    else:
        mode = flexible_mode(grid.t, values["acc_P1_x"], in_record, departures, seed)
        values["acc_P1_x"] = values["acc_P1_x"] + mode.level_signal
        ratio = MODE_BODIES["A"]["participation"]["acc2"]
        values["acc_P2_x"] = values["acc_P2_x"] + ratio * mode.level_signal
        seen = ["acc1", "acc2"]
    info = {"body": body, "description": MODE_BODIES[body]["description"],
            "natural_hz": departures.mode_hz, "damping_ratio": departures.mode_damping,
            "level_channel": MODE_BODIES[body]["level_channel"],
            "requested_level": departures.mode_level, "achieved_level": mode.achieved_level,
            "broadband_gain": mode.broadband_gain, "order_share": mode.order_share,
            "seen_by": seen}
    logger.info("flexible mode of %s at %.2f Hz, damping %.3f, level %.3f", body,
                departures.mode_hz, departures.mode_damping, mode.achieved_level)
    return TruthGrid(grid.t, values), info
