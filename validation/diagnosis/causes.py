"""A validated run's residuals, candidate causes and stated systematic errors, for the attribution.

:func:`attribution_problem` turns a :class:`~rigval.validation.results.ValidationResult` into
the inputs of :func:`rigval.validation.diagnosis.attribution.attribute`:

* one :class:`~rigval.validation.diagnosis.attribution.Block` per comparison: measured minus
  model per revolution, orders up to :data:`PASSBAND` of the comparison's low-pass corner (above
  it the measurement is filtered and the model is not);
* the causes, each as what one unit of it adds to the residual ``r = measured - model``:
  a **gain** ``g`` of the measurement, ``g S``; an **offset** (comparisons that keep their
  constant part), 1; a **lag** ``tau`` (s) of the measurement, ``-omega tau dS/dphi`` with
  ``omega`` the main shaft's speed; a **mechanism parameter** ``p``, ``scale dY/dp`` with the
  identification regressor of :func:`rigval.model.identify.regressor` (drive torques and joint
  forces are linear in the inertial parameters); a **mode** at ``f_n``, damping ``zeta``, the
  quasi-static model through the mode's dynamic amplification minus one, order by order,
  ``(H(k Omega) - 1) S_k`` with ``H = 1 / (1 - (w / w_n)^2 + 2 i zeta w / w_n)``;
* the stated systematic errors as nuisance directions of one standard uncertainty: each
  comparison's own calibration gain (``u_measurement_rel``, less the common part), the part
  common to a sensor kind (``u_measurement_rel_common``), each stream's clock alignment and the
  drive angles (:func:`rigval.validation.verdict.carried_uncertainty`).

Comparisons that measure the same channel (a shaft alone and in its drive's sum) are not
independent; :func:`independent_sets` picks sets without a shared channel.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Mapping, Sequence

import numpy as np

from rigval.model.identify import nominal_parameters, regressor
from rigval.model.mechanism import load_mechanism
from rigval.validation.diagnosis.attribution import Block, Cause, Nuisance
from rigval.validation.identify import _mean_drives
from rigval.validation.results import ComparisonResult, ValidationResult
from rigval.validation.verdict import carried_uncertainty, comparison_verdict

__all__ = ["MAX_ORDER", "PASSBAND", "attribution_problem", "detected", "independent_sets",
           "mode_effect", "subset"]

logger = logging.getLogger(__name__)

#: Orders used up to this fraction of a comparison's low-pass corner: the zero-phase 4th-order
#: Butterworth of the pipeline attenuates 0.07 % there, and the model is not filtered.
PASSBAND = 0.4
#: Highest order used in any case.
MAX_ORDER = 30
_FORCES = ("driver_torque", "joint_force")


def _channels(comparison: ComparisonResult) -> frozenset[str]:
    return frozenset(str(ref) for _, ref in comparison.spec.terms)


def independent_sets(result: ValidationResult) -> dict[str, tuple[str, ...]]:
    """Per comparison, a set of comparisons holding it and sharing no measured channel.

    The base set keeps every comparison whose channels are not a part of another comparison's
    (a drive's sum before its shafts); a comparison outside it replaces the ones it shares a
    channel with.

    Returns
    -------
    dict of str to tuple of str
        Comparison name to the names of its set, in scene order.
    """
    sets = {c.name: _channels(c) for c in result.comparisons}
    base: list[str] = []
    for name, channels in sets.items():
        wider = any(channels < other for other in sets.values())
        same = any(sets[kept] == channels for kept in base)
        if not (wider or same):
            base.append(name)
    out = {}
    for name, channels in sets.items():
        if name in base:
            out[name] = tuple(base)
            continue
        keep = {n for n in base if not sets[n] & channels} | {name}
        out[name] = tuple(n for n in sets if n in keep)
    return out


def _orders(result: ValidationResult, comparison: ComparisonResult) -> int:
    """Highest order used: within the low-pass's passband, an eighth of the grid, 30."""
    n = comparison.angle.size
    corner = comparison.spec.lowpass_hz
    top = min(MAX_ORDER, n // 8)
    if corner is not None and result.speed_rev_s > 0:
        top = min(top, int(PASSBAND * corner / result.speed_rev_s))
    return max(top, 1)


def _slope(values: np.ndarray) -> np.ndarray:
    """d/dphi over one revolution (periodic central differences), per rad."""
    step = 2.0 * np.pi / values.size
    return (np.roll(values, -1) - np.roll(values, 1)) / (2.0 * step)


def mode_effect(model: np.ndarray, speed_rev_s: float, natural_hz: float, damping: float
                ) -> np.ndarray:
    """Return what a mode adds to a quasi-static curve over one revolution.

    Parameters
    ----------
    model : numpy.ndarray
        ``(n,)`` the rigid model over one revolution.
    speed_rev_s : float
        Main-shaft speed, rev/s (order ``k`` is at ``k speed`` Hz).
    natural_hz, damping : float
        The mode's natural frequency (Hz) and damping ratio (1).

    Returns
    -------
    numpy.ndarray
        ``(n,)`` ``sum_k (H(k speed) - 1) S_k e^(i k phi)``: a unit-static-gain single degree of
        freedom driven by the rigid load, less the load.
    """
    spectrum = np.fft.rfft(model)
    ratio = np.arange(spectrum.size) * speed_rev_s / natural_hz
    amplification = 1.0 / (1.0 - ratio**2 + 2j * damping * ratio)
    return np.fft.irfft(spectrum * (amplification - 1.0), n=model.size)


def detected(comparison: ComparisonResult) -> bool:
    """Whether the V&V 20 verdict detects a model error in a comparison."""
    return bool(comparison_verdict(comparison)["detected"])


def _meaning(result: ValidationResult, comparison: ComparisonResult) -> str:
    """Return what a gain of this comparison stands for."""
    channels = _channels(comparison)
    shared = any(channels < _channels(other) for other in result.comparisons)
    return "calibration or the pair's split" if shared else "calibration"


Problem = tuple[list[Block], list[Cause], list[Nuisance]]


def subset(problem: Problem, names: Sequence[str]) -> Problem:
    """Return the part of a problem that concerns some comparisons only.

    Parameters
    ----------
    problem : tuple
        Blocks, causes and nuisances of every comparison (:func:`attribution_problem`).
    names : sequence of str
        Comparisons kept (no two sharing a measured channel, see :func:`independent_sets`).

    Returns
    -------
    tuple
        The kept blocks, and the causes and nuisances that act on them, restricted to them.
    """
    keep = set(names)
    blocks, causes, nuisances = problem
    causes = [dataclasses.replace(c, effect={k: v for k, v in c.effect.items() if k in keep})
              for c in causes]
    nuisances = [dataclasses.replace(n, effect={k: v for k, v in n.effect.items() if k in keep})
                 for n in nuisances]
    return ([b for b in blocks if b.name in keep], [c for c in causes if c.effect],
            [n for n in nuisances if n.effect])


def attribution_problem(result: ValidationResult,
                        modes: Mapping[str, Sequence[tuple[float, float]]] | None = None
                        ) -> Problem:
    """Build the attribution's residuals, causes and nuisances of every comparison of a run.

    Parameters
    ----------
    result : ValidationResult
        The validated run.
    modes : mapping of str to sequence of (float, float), optional
        Per comparison, modes found in its residual: natural frequency (Hz) and damping ratio.

    Returns
    -------
    blocks, causes, nuisances : list
        As :func:`rigval.validation.diagnosis.attribution.attribute` takes them; take a set of
        comparisons that share no channel with :func:`subset`.
    """
    used = list(result.comparisons)
    scene = result.scene
    omega = 2.0 * math.pi * result.speed_rev_s
    blocks, causes, nuisances = [], [], []
    common: dict[str, dict[str, np.ndarray]] = {}
    streams: dict[str, dict[str, np.ndarray]] = {}
    drive: dict[str, np.ndarray] = {}
    u_drive = 0.0
    for c in used:
        spec, model = c.spec, c.model
        slope = _slope(model)
        u = spec.uncertainty
        floor = math.hypot(float(c.scores.get("vv20.curve.u_grid", 0.0)),
                           float(c.scores.get("vv20.curve.u_input", 0.0)),
                           float(u.get("u_measurement", 0.0)))
        blocks.append(Block(c.name, c.cycles - model, _orders(result, c),
                            with_offset=not spec.remove_offset, floor=floor,
                            accepted=not detected(c)))
        causes.append(Cause(f"gain {c.name}", "gain", "1", {c.name: model},
                            meaning=_meaning(result, c)))
        causes.append(Cause(f"lag {c.name}", "lag", "s", {c.name: -omega * slope},
                            meaning="time lag of the channel"))
        if not spec.remove_offset:
            causes.append(Cause(f"offset {c.name}", "offset", c.units,
                                {c.name: np.ones_like(model)}, meaning="zero offset"))
        for hz, damping in (modes or {}).get(c.name, ()):
            causes.append(Cause(f"mode {hz:.3g} Hz {c.name}", "mode", "1",
                                {c.name: mode_effect(model, result.speed_rev_s, hz, damping)},
                                meaning=f"structural mode at {hz:.3g} Hz"))
        rel, rel_common = (float(u.get("u_measurement_rel", 0.0)),
                           float(u.get("u_measurement_rel_common", 0.0)))
        own = math.sqrt(max(rel**2 - rel_common**2, 0.0))
        if own > 0.0:
            nuisances.append(Nuisance(f"calibration {c.name}", {c.name: own * model}))
        if rel_common > 0.0:
            kind = scene.streams[spec.measured.stream].channels[spec.measured.channel].sensor
            common.setdefault(kind, {})[c.name] = rel_common * model
        carried = carried_uncertainty(scene, result.alignment[spec.measured.stream],
                                      result.speed_rev_s)
        if carried["u_time"] > 0.0:
            streams.setdefault(spec.measured.stream, {})[c.name] = (
                carried["u_time"] * carried["speed"] * slope)
        u_drive = max(u_drive, carried["u_drive_angle"])
        drive[c.name] = slope
    nuisances += [Nuisance(f"common calibration {kind}", effect)
                  for kind, effect in common.items()]
    nuisances += [Nuisance(f"alignment {stream}", effect) for stream, effect in streams.items()]
    if u_drive > 0.0:
        nuisances.append(Nuisance("drive angles", {n: u_drive * s for n, s in drive.items()}))
    causes += _parameter_causes(result, [c for c in used if c.spec.model.quantity in _FORCES])
    return blocks, causes, nuisances


def _parameter_causes(result: ValidationResult, used: Sequence[ComparisonResult]
                      ) -> list[Cause]:
    """One cause per inertial parameter that changes a compared force or torque."""
    if not used:
        return []
    mechanism = load_mechanism(result.scene.mechanism)
    outputs = [(c.spec.model.quantity, c.spec.model.item) if c.spec.model.axis is None
               else (c.spec.model.quantity, c.spec.model.item, c.spec.model.axis) for c in used]
    reg = regressor(mechanism, result.tree["/model"]["time"].to_numpy(), outputs,
                    drives=_mean_drives(result))
    nominal = nominal_parameters(mechanism)
    units = {"mass": "kg", "mx": "kg m", "my": "kg m", "inertia": "kg m2"}
    out = []
    for j, name in enumerate(reg.names):
        effect = {c.name: c.spec.scale * reg.matrix[i, :, j] for i, c in enumerate(used)}
        size = max(float(np.ptp(values)) for values in effect.values())
        if size <= 1e-9 * max(float(np.ptp(c.model)) for c in used):
            continue
        kind = name.split(".")[1]
        out.append(Cause(name, "parameter", units[kind], effect, nominal=nominal[name],
                         meaning="mechanism parameter"))
    return out
