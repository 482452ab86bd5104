"""Identification: inertial parameters and drive friction from measured torques and forces.

:func:`identify` validates the scene once with its mechanism (the pipeline's angle grid, measured
drives and revolution cycles) and hands the compared drive torques and joint forces to the
model's identification as measured curves, each weighted by the inverse of the RMS
cycle-to-cycle scatter of its mean (``vv20.curve.u_scatter``): the stacked regressor and each
revolution's own problem are :mod:`rigval.model.identify_design`, the weighted least squares,
the choice of identifiable parameters and the standard errors :mod:`rigval.model.identify_fit`.
Parameters not chosen stay at the mechanism file's values. A sensor's calibration uncertainty
(the scene's ``u_measurement_rel``) scales every parameter seen through it; it is reported
apart, as ``u_calibration``. Definitions and a worked example: ``docs/identify.md``.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from rigval.acquisition.errors import ConfigError, DataError
from rigval.model.identify_design import Curve, build_design, revolution_problems
from rigval.model.identify_fit import Design, ParameterFit, fit, identifiable
from rigval.model.mechanism import Mechanism, load_mechanism
from rigval.validation.results import ComparisonResult, ValidationResult
from rigval.validation.scene import load_scene
from rigval.validation.scene_types import Scene

__all__ = ["Identification", "identify"]

logger = logging.getLogger(__name__)

_SOURCES = ("driver_torque", "joint_force")


@dataclass(frozen=True)
class Identification(ParameterFit):
    """What the measurements say the parameters are.

    The fields of :class:`~rigval.model.identify_fit.ParameterFit` (``names``: ``"<body>.<kind>"``
    with kind ``mass``, ``mx``, ``my``, ``inertia``, and ``"<driver>.viscous"`` (N m s/rad),
    ``"<driver>.coulomb"`` (N m); ``value``, ``std``, ``nominal`` (the mechanism file's value, 0
    for friction and first moments), ``u_calibration``, ``units``, ``condition_number``,
    ``n_cycles`` and ``residual_rms`` per comparison), and:

    Attributes
    ----------
    not_identifiable : dict of str to str
        Parameters left at their nominal values, with the reason.
    comparisons : tuple of str
        Comparisons used.
    nominal_result : ValidationResult
        The validation with the mechanism file's values.
    """

    not_identifiable: dict[str, str]
    comparisons: tuple[str, ...]
    nominal_result: ValidationResult = dataclasses.field(repr=False)

    def as_dict(self) -> dict[str, Any]:
        """Return the JSON document of ``identified.json``.

        Returns
        -------
        dict
            ``{name: {"value", "std", "nominal", "u_calibration", "units"}, ...}`` under
            ``"parameters"``, plus ``condition_number``, ``not_identifiable``, ``comparisons``,
            ``n_cycles`` and ``residual_rms``.
        """
        return {
            "parameters": {name: {"value": float(v), "std": float(s), "nominal": float(n),
                                  "u_calibration": float(c), "units": u}
                           for name, v, s, n, c, u in zip(self.names, self.value, self.std,
                                                          self.nominal, self.u_calibration,
                                                          self.units, strict=True)},
            "condition_number": self.condition_number,
            "not_identifiable": dict(self.not_identifiable),
            "comparisons": list(self.comparisons), "n_cycles": self.n_cycles,
            "residual_rms": dict(self.residual_rms)}


def identify(scene: Scene | str | Path, parameters: str | Sequence[str] = "auto", *,
             friction: bool = False, comparisons: Sequence[str] | None = None,
             result: ValidationResult | None = None) -> Identification:
    """Identify inertial parameters (and optionally drive friction) from a run.

    Parameters
    ----------
    scene : Scene, str or pathlib.Path
        The run's scene; its mechanism gives the geometry and the nominal values.
    parameters : "auto" or sequence of str
        ``"auto"``: the identifiable base parameters, chosen by QR with column pivoting of the
        weighted regressor (threshold :data:`rigval.model.identify_fit.AUTO_TOLERANCE`); or
        names ``"A.mass"``, ``"A.inertia"``, ``"A.mx"``, ``"A.my"``, ``"theta_F.viscous"``,
        ``"theta_F.coulomb"``.
        Named parameters that the channels cannot separate are left at nominal and reported.
    friction : bool
        With ``"auto"``, also offer viscous and Coulomb friction of every driver seen by a
        compared drive torque.
    comparisons : sequence of str, optional
        Comparisons to use (drive torques and joint forces). Default: every drive torque,
        except single channels that are also part of a summed comparison (``measured =
        [...]``); joint forces only when named (on the sample rig the link force ``str1``
        carries a systematic error that biases the inertia, see ``docs/identify.md``).
    result : ValidationResult, optional
        The scene's validation with its mechanism, when already computed.

    Returns
    -------
    Identification

    Raises
    ------
    ConfigError
        For an unknown parameter or comparison, or no usable comparison.
    DataError
        For too few revolutions.
    """
    from rigval.validation.pipeline import run_scene

    if not isinstance(scene, Scene):
        scene = load_scene(scene)
    if result is None:
        result = run_scene(scene)
    mechanism = load_mechanism(scene.mechanism)
    used = _choose_comparisons(result, comparisons)
    curves = _curves(used)
    design = build_design(mechanism, result.tree["/model"]["time"].to_numpy(), curves,
                          _mean_drives(result), friction=friction or parameters != "auto")
    candidates = list(design.names) if parameters == "auto" else list(parameters)
    unknown = [name for name in candidates if name not in design.names]
    if unknown:
        raise ConfigError(f"unknown parameter {unknown[0]!r}", where={"key": "parameters"},
                          hint=f"parameters: {', '.join(design.names)}")
    if parameters == "auto" and not friction:
        candidates = [n for n in candidates if not n.endswith((".viscous", ".coulomb"))]
    chosen, reasons = identifiable(design, candidates)
    solved = fit(design, chosen, _revolutions(result, mechanism, used, curves, design))
    logger.info("identified %d parameters from %s: condition %.3g", len(chosen),
                ", ".join(c.name for c in used), solved.condition_number)
    return Identification(**vars(solved), not_identifiable=reasons,
                          comparisons=tuple(c.name for c in used), nominal_result=result)


# ---------------------------------------------------------------------------------------------


def _choose_comparisons(result: ValidationResult, names: Sequence[str] | None
                        ) -> list[ComparisonResult]:
    usable = {c.name: c for c in result.comparisons if c.spec.model.quantity in _SOURCES}
    if names is not None:
        missing = [n for n in names if n not in usable]
        if missing:
            raise ConfigError(f"comparison {missing[0]!r} is not a drive torque or joint force "
                              "comparison of the scene", where={"key": "comparisons"},
                              hint=f"use: {', '.join(usable)}")
        chosen = [usable[n] for n in names]
    else:
        summed = {str(ref) for c in usable.values() if c.spec.summed
                  for ref in (c.spec.measured, *c.spec.summed)}
        chosen = [c for c in usable.values() if c.spec.model.quantity == "driver_torque"
                  and (c.spec.summed or str(c.spec.measured) not in summed)]
    if not chosen:
        raise ConfigError("no drive torque or joint force comparison to identify from",
                          where={"key": "comparisons"},
                          hint="compare a driver_torque or joint_force in the scene")
    counts = {c.cycles.shape[0] for c in chosen}
    if min(counts) < 3:
        raise DataError(f"identification needs at least 3 whole revolutions, got {min(counts)}",
                        where={"key": "comparisons"}, hint="record longer")
    return chosen


def _curves(used: list[ComparisonResult]) -> list[Curve]:
    """Return the comparisons as measured curves, each weighted by the inverse of its scatter."""
    curves = []
    for c in used:
        scatter = c.scores.get("vv20.curve.u_scatter")
        weight = (1.0 / max(float(scatter), 1e-300) if scatter
                  else 1.0 / (float(np.std(c.mean)) or 1.0))
        model = c.spec.model
        output = ((model.quantity, model.item) if model.axis is None
                  else (model.quantity, model.item, model.axis))
        curves.append(Curve(c.name, output, c.spec.scale, c.mean, c.cycles, weight,
                            c.spec.remove_offset,
                            float(c.spec.uncertainty.get("u_measurement_rel", 0.0))))
    return curves


def _mean_drives(result: ValidationResult) -> dict[str, tuple[np.ndarray, ...]] | None:
    """Each driver's mean angle, speed and acceleration on the grid (measured drives), or None."""
    if result.scene.model.drives != "measured":
        return None
    model = result.tree["/model"].to_dataset()
    return {d: tuple(model[f"drive_{d}{s}"].to_numpy() for s in ("", "_dot", "_ddot"))
            for d in result.scene.model.drivers}


def _revolutions(result: ValidationResult, mechanism: Mechanism, used: list[ComparisonResult],
                 curves: list[Curve], design: Design) -> tuple[np.ndarray, np.ndarray] | None:
    """Each whole revolution's own problem (:func:`revolution_problems`), or None.

    Revolutions with a gap in any comparison used are left out; None without measured drives on
    the main encoder or with fewer than 3 whole revolutions.
    """
    scene = result.scene
    drives = _mean_drives(result)
    leading = [name for name, d in scene.model.drivers.items()
               if d.encoder == scene.alignment.main_encoder]
    if drives is None or len(leading) != 1:
        return None
    angle_ds = result.tree["/angle"].to_dataset()
    whole = {c.name: np.all(np.isfinite(angle_ds[c.name].to_numpy()), axis=1) for c in used}
    keep = np.flatnonzero(np.logical_and.reduce(list(whole.values())))
    if keep.size < 3:
        return None
    # a comparison's cycles hold its whole revolutions only: row r is its cycle number
    # (whole revolutions before r)
    cycles = [c.cycles[np.cumsum(whole[c.name])[keep] - 1] for c in used]
    model = result.tree["/model"].to_dataset()
    step = float(model["angle"][1] - model["angle"][0])
    return revolution_problems(mechanism, curves, design, drives, leading[0],
                               angle_ds["time_at_angle"].to_numpy()[keep], step, cycles)
