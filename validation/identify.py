"""Identification: inertial parameters and drive friction from measured torques and forces.

:func:`identify` validates the scene once with its mechanism (the pipeline's angle grid, measured
drives and revolution cycles), builds the regressor of every compared drive torque and joint
force (:func:`rigval.model.identify.regressor`) on the same grid, and solves the weighted linear
least-squares problem for the chosen parameters on the revolution-averaged curves; parameters not
chosen stay at the mechanism file's values. Each comparison is weighted by the inverse of the
RMS cycle-to-cycle scatter of its mean (``vv20.curve.u_scatter``). Definitions and a worked
example: ``docs/identify.md``.

Standard errors (``std``) add two parts in quadrature. The random part: the scatter of the
parameters fitted to each revolution alone, divided by ``sqrt(n_cycles)``, each revolution with
its own regressor (the main shaft's speed and acceleration over that revolution from its times at
the grid angles, the lifting drive on the same path in angle), so that the slow speed wander,
which the mean drives take into account, does not count as error. The systematic part: the
residual of the fit to the mean, with the covariance ``s^2 (X^T X)^-1`` inflated by ``(1 + rho) /
(1 - rho)`` for the residual's correlation ``rho`` between neighbouring grid angles. The
kinematic part: the drives' accelerations are estimated from the encoders, and an error of
theirs moves mostly the inertias; the fit to the mean is repeated with the mean of the
revolutions' own regressors (a second estimate of the same kinematics, from the main shaft's
grid times instead of the drive encoders' derivatives), and half the square of the difference
is taken as the variance (two estimates with independent errors of equal size). A sensor's
calibration uncertainty (the scene's ``u_measurement_rel``) scales every parameter seen through
it; it is reported apart, as ``u_calibration``.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import scipy.linalg

from rigval.acquisition.errors import ConfigError, DataError
from rigval.model.identify import UNITS, nominal_parameters, parameter_names, regressor
from rigval.model.mechanism import Mechanism, load_mechanism
from rigval.validation.results import ComparisonResult, ValidationResult
from rigval.validation.scene import Scene, load_scene

__all__ = ["AUTO_TOLERANCE", "Identification", "apply_parameters", "identify", "mechanism_toml"]

logger = logging.getLogger(__name__)

#: Pivoted-QR threshold of ``--parameters auto``: a parameter is taken while the part of its
#: (weighted, typical-size) effect not explained by the parameters taken before it is at least
#: this fraction of the strongest parameter's effect.
AUTO_TOLERANCE = 1e-3
#: Typical centre-of-gravity shift that sets the size of a first moment ``m x_c``, m.
FIRST_MOMENT_LENGTH = 0.01
_SOURCES = ("driver_torque", "joint_force")


@dataclass(frozen=True)
class Identification:
    """What the measurements say the parameters are.

    Attributes
    ----------
    names : tuple of str
        Identified parameters: ``"<body>.<kind>"`` (kind ``mass``, ``mx``, ``my``, ``inertia``)
        and ``"<driver>.viscous"`` (N m s/rad), ``"<driver>.coulomb"`` (N m).
    value, std, nominal, u_calibration : numpy.ndarray
        Identified value, its standard error, the mechanism file's value (0 for friction and
        first moments) and the calibration part (see the module docstring), per name.
    units : tuple of str
        Unit per name.
    condition_number : float
        2-norm condition number of the weighted regressor of the identified parameters, each
        column scaled to its parameter's typical size.
    not_identifiable : dict of str to str
        Parameters left at their nominal values, with the reason.
    comparisons : tuple of str
        Comparisons used.
    n_cycles : int
        Revolutions.
    residual_rms : dict of str to float
        Per comparison, RMS of the fit's residual on the mean, signal units.
    nominal_result : ValidationResult
        The validation with the mechanism file's values.
    """

    names: tuple[str, ...]
    value: np.ndarray
    std: np.ndarray
    nominal: np.ndarray
    u_calibration: np.ndarray
    units: tuple[str, ...]
    condition_number: float
    not_identifiable: dict[str, str]
    comparisons: tuple[str, ...]
    n_cycles: int
    residual_rms: dict[str, float]
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
        weighted regressor (threshold :data:`AUTO_TOLERANCE`); or names ``"A.mass"``,
        ``"A.inertia"``, ``"A.mx"``, ``"A.my"``, ``"theta_F.viscous"``, ``"theta_F.coulomb"``.
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
    design = _design(result, mechanism, used, friction or parameters != "auto")
    candidates = list(design.names) if parameters == "auto" else list(parameters)
    unknown = [name for name in candidates if name not in design.names]
    if unknown:
        raise ConfigError(f"unknown parameter {unknown[0]!r}", where={"key": "parameters"},
                          hint=f"parameters: {', '.join(design.names)}")
    if parameters == "auto" and not friction:
        candidates = [n for n in candidates if not n.endswith((".viscous", ".coulomb"))]
    chosen, reasons = _identifiable(design, candidates)
    return _fit(design, chosen, reasons, result, used,
                _revolutions(result, mechanism, used, design))


# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Design:
    """Stacked, weighted least-squares problem over the comparisons used."""

    names: tuple[str, ...]
    nominal: np.ndarray
    units: tuple[str, ...]
    columns: np.ndarray      # (n_rows, n_params), weighted
    size: np.ndarray         # typical size of each parameter
    mean: np.ndarray         # (n_rows,) weighted measured mean
    cycles: np.ndarray       # (n_cycles, n_rows) weighted measured cycles
    nuisance: np.ndarray     # (n_rows, n_offsets) weighted offset columns
    blocks: tuple[slice, ...]
    weights: np.ndarray      # per comparison
    calibration: np.ndarray  # u_measurement_rel per comparison
    friction: tuple[str, ...]  # drivers with friction columns


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


def _design(result: ValidationResult, mechanism: Mechanism, used: list[ComparisonResult],
            friction: bool) -> _Design:
    model = result.tree["/model"].to_dataset()
    times = model["time"].to_numpy()
    drives = None
    if result.scene.model.drives == "measured":
        drives = {d: tuple(model[f"drive_{d}{s}"].to_numpy() for s in ("", "_dot", "_ddot"))
                  for d in result.scene.model.drivers}
    outputs = [(c.spec.model.quantity, c.spec.model.item) if c.spec.model.axis is None
               else (c.spec.model.quantity, c.spec.model.item, c.spec.model.axis) for c in used]
    reg = regressor(mechanism, times, outputs, drives=drives)
    nominal = nominal_parameters(mechanism)
    names = list(parameter_names(mechanism))
    values = [nominal[n] for n in names]
    units = [UNITS[n.split(".")[1]] for n in names]
    size = [nominal[n] if n.endswith((".mass", ".inertia")) else
            FIRST_MOMENT_LENGTH * nominal[n.split(".")[0] + ".mass"] for n in names]
    torque_drivers = tuple(sorted({c.spec.model.item for c in used
                                   if c.spec.model.quantity == "driver_torque"}))
    if not friction:
        torque_drivers = ()
    for driver in torque_drivers:
        omega = reg.omega[driver]
        for kind, column, unit in (("viscous", omega, "N m s rad-1"),
                                   ("coulomb", np.sign(omega), "N m")):
            names.append(f"{driver}.{kind}")
            values.append(0.0)
            units.append(unit)
            curve = (reg.matrix[outputs.index(("driver_torque", driver))]
                     @ np.array(values[:4 * len(mechanism.bodies)]))
            torque = float(np.sqrt(np.mean(curve**2)))
            scale = float(np.sqrt(np.mean(column**2))) or 1.0
            size.append(0.01 * torque / scale)
    weights = np.array([1.0 / max(float(c.scores.get("vv20.curve.u_scatter", 0.0)), 1e-300)
                        if c.scores.get("vv20.curve.u_scatter") else 1.0 / (np.std(c.mean) or 1)
                        for c in used])
    n = times.size
    blocks = tuple(slice(i * n, (i + 1) * n) for i in range(len(used)))
    design_columns = _weighted_columns(reg, used, weights, torque_drivers)
    n_cycles = min(c.cycles.shape[0] for c in used)
    cycles = np.concatenate([c.cycles[:n_cycles] * w for c, w in zip(used, weights, strict=True)],
                            axis=1)
    mean = np.concatenate([c.mean * w for c, w in zip(used, weights, strict=True)])
    offsets = [i for i, c in enumerate(used) if c.spec.remove_offset]
    nuisance = np.zeros((len(used) * n, len(offsets)))
    for j, i in enumerate(offsets):
        nuisance[blocks[i], j] = weights[i]
    calibration = np.array([float(c.spec.uncertainty.get("u_measurement_rel", 0.0))
                            for c in used])
    return _Design(tuple(names), np.array(values), tuple(units), design_columns,
                   np.abs(np.array(size)), mean, cycles, nuisance, blocks, weights, calibration,
                   torque_drivers)


def _weighted_columns(reg: Any, used: list[ComparisonResult], weights: np.ndarray,
                      friction: Sequence[str]) -> np.ndarray:
    """Stacked, scaled and weighted regressor ``(n_outputs * n, P)``, friction columns last."""
    columns = [np.moveaxis(reg.matrix, 2, 0)]     # (P, n_out, n)
    for driver in friction:
        omega = reg.omega[driver]
        for column in (omega, np.sign(omega)):
            columns.append(np.stack([column if c.spec.model.quantity == "driver_torque"
                                     and c.spec.model.item == driver else 0.0 * column
                                     for c in used])[None])
    stacked = np.concatenate(columns)             # (P, n_out, n)
    return np.concatenate([stacked[:, i, :] * c.spec.scale * w
                           for i, (c, w) in enumerate(zip(used, weights, strict=True))],
                          axis=1).T


def _revolutions(result: ValidationResult, mechanism: Mechanism,
                 used: list[ComparisonResult], design: _Design
                 ) -> tuple[np.ndarray, np.ndarray] | None:
    """Each whole revolution's own weighted regressor and data, for the random part of std.

    The main drive's speed and acceleration over a revolution come from its reference times at
    the grid angles (``time_at_angle``: ``omega = 1 / t'``, ``alpha = -t'' omega^3``, second-
    order differences); the drive angles keep the mean path in angle, and the lifting drive
    follows it, ``omega_H = kappa omega_F``, ``alpha_H = kappa' omega_F^2 + kappa alpha_F``
    with ``kappa = d theta_H / d theta_F`` of the mean drives. Revolutions with a gap in any
    comparison used are left out. Returns ``(columns (n_rev, rows, P), data (n_rev, rows))``,
    or None without measured drives on the main encoder's angle.
    """
    scene = result.scene
    drivers = scene.model.drivers
    if scene.model.drives != "measured" or not drivers:
        return None
    main = scene.alignment.main_encoder
    leading = [name for name, d in drivers.items() if d.encoder == main]
    if len(leading) != 1:
        return None
    model = result.tree["/model"].to_dataset()
    angle_ds = result.tree["/angle"].to_dataset()
    times = angle_ds["time_at_angle"].to_numpy()
    whole = {c.name: np.all(np.isfinite(angle_ds[c.name].to_numpy()), axis=1) for c in used}
    keep = np.flatnonzero(np.logical_and.reduce(list(whole.values())))
    if keep.size < 3:
        return None
    mean = {d: tuple(model[f"drive_{d}{s}"].to_numpy() for s in ("", "_dot", "_ddot"))
            for d in drivers}
    lead = mean[leading[0]]
    step = float(model["angle"][1] - model["angle"][0])
    outputs = [(c.spec.model.quantity, c.spec.model.item) if c.spec.model.axis is None
               else (c.spec.model.quantity, c.spec.model.item, c.spec.model.axis) for c in used]
    columns, data = [], []
    for row in keep:
        t = times[row]
        slope = np.gradient(t, step)
        omega = 1.0 / slope
        alpha = -np.gradient(slope, step) * omega**3
        drives = {}
        for name, (theta, w, a) in mean.items():
            kappa = w / lead[1]
            bend = (a - kappa * lead[2]) / lead[1] ** 2
            drives[name] = (theta, kappa * omega, bend * omega**2 + kappa * alpha)
        reg = regressor(mechanism, t - t[0], outputs, drives=drives)
        columns.append(_weighted_columns(reg, used, design.weights, design.friction))
        data.append(np.concatenate([
            c.cycles[int(np.count_nonzero(whole[c.name][:row]))] * w
            for c, w in zip(used, design.weights, strict=True)]))
    return np.array(columns), np.array(data)


def _project_out(design: _Design, matrix: np.ndarray) -> np.ndarray:
    """Remove the offset (nuisance) columns' span from the columns of ``matrix``."""
    if design.nuisance.shape[1] == 0:
        return matrix
    q, _ = np.linalg.qr(design.nuisance)
    return matrix - q @ (q.T @ matrix)


def _identifiable(design: _Design, candidates: list[str]) -> tuple[list[str], dict[str, str]]:
    """Split candidates into identifiable ones (pivoted QR) and the rest with reasons."""
    index = [design.names.index(n) for n in candidates]
    raw = design.columns[:, index] * design.size[index]
    scaled = _project_out(design, raw)
    norms = np.linalg.norm(scaled, axis=0)
    before = np.linalg.norm(raw, axis=0)
    strongest = float(norms.max()) if norms.size else 0.0
    _, r, pivots = scipy.linalg.qr(scaled, mode="economic", pivoting=True)
    diag = np.abs(np.diag(r))
    keep = [int(p) for p, d in zip(pivots, diag, strict=False)
            if strongest > 0 and d >= AUTO_TOLERANCE * strongest]
    chosen = [candidates[i] for i in sorted(keep)]
    reasons = {}
    for i, name in enumerate(candidates):
        if i in keep:
            continue
        if norms[i] < AUTO_TOLERANCE * strongest <= before[i]:
            reasons[name] = ("absorbed by the constant offsets the comparisons remove "
                             "(remove_offset): its effect is nearly constant over a revolution")
            continue
        if strongest == 0 or norms[i] < AUTO_TOLERANCE * strongest:
            reasons[name] = ("no effect on these channels: a change of its typical size moves "
                             f"them by {norms[i] / strongest if strongest else 0:.1e} of the "
                             "strongest parameter's effect")
            continue
        basis = scaled[:, sorted(keep)]
        coef, *_ = np.linalg.lstsq(basis, scaled[:, i], rcond=None)
        order = np.argsort(-np.abs(coef))[:3]
        combo = ", ".join(f"{chosen[j]} ({coef[j]:+.3g})" for j in order)
        rest = float(np.linalg.norm(scaled[:, i] - basis @ coef)) / strongest
        reasons[name] = ("not separable from the parameters taken: its effect is that of "
                         f"{combo} in typical sizes (left over: {rest:.1e} of the strongest)")
    return chosen, reasons


def _fit(design: _Design, chosen: list[str], reasons: dict[str, str],
         result: ValidationResult, used: list[ComparisonResult],
         revolutions: tuple[np.ndarray, np.ndarray] | None) -> Identification:
    index = [design.names.index(n) for n in chosen]
    fixed = [i for i in range(len(design.names)) if i not in index]
    x = _project_out(design, design.columns[:, index])
    known = design.columns[:, fixed] @ design.nominal[fixed]
    target = _project_out(design, (design.mean - known)[:, None])[:, 0]
    solution, *_ = np.linalg.lstsq(x, target, rcond=None)
    if revolutions is None:       # no revolution's own kinematics: the mean's regressor
        per_cycle = _project_out(design, (design.cycles - known).T)
        cycle_fits = np.linalg.lstsq(x, per_cycle, rcond=None)[0].T  # (n_cycles, P)
    else:
        cycle_fits = np.array([np.linalg.lstsq(
            _project_out(design, cols[:, index]),
            _project_out(design, (y - cols[:, fixed] @ design.nominal[fixed])[:, None])[:, 0],
            rcond=None)[0] for cols, y in zip(*revolutions, strict=True)])
    n_cycles = cycle_fits.shape[0]
    var_cycle = np.var(cycle_fits, axis=0, ddof=1) / n_cycles
    var_kinematic = np.zeros(len(index))
    if revolutions is not None:
        other = revolutions[0].mean(axis=0)
        second, *_ = np.linalg.lstsq(_project_out(design, other[:, index]), _project_out(
            design, (design.mean - other[:, fixed] @ design.nominal[fixed])[:, None])[:, 0],
            rcond=None)
        var_kinematic = 0.5 * (second - solution) ** 2
    residual = target - x @ solution
    dof = max(x.shape[0] - x.shape[1] - design.nuisance.shape[1], 1)
    s2 = float(residual @ residual) / dof
    inverse = np.linalg.pinv(x.T @ x)
    rho = np.mean([_lag_one(residual[block]) for block in design.blocks])
    inflation = (1.0 + rho) / (1.0 - rho) if rho > 0 else 1.0
    var_residual = s2 * np.diag(inverse) * inflation
    std = np.sqrt(var_cycle + var_residual + var_kinematic)
    scaled = x * design.size[index]
    condition = float(np.linalg.cond(scaled)) if scaled.size else math.nan
    calibration = float(np.sqrt(np.mean(design.calibration**2)))
    residual_rms = {c.name: float(np.sqrt(np.mean(residual[b] ** 2)) / w)
                    for c, b, w in zip(used, design.blocks, design.weights, strict=True)}
    logger.info("identified %d parameters from %s: condition %.3g", len(chosen),
                ", ".join(c.name for c in used), condition)
    return Identification(
        names=tuple(chosen), value=solution, std=std, nominal=design.nominal[index],
        u_calibration=np.abs(solution) * calibration,
        units=tuple(design.units[i] for i in index), condition_number=condition,
        not_identifiable=reasons, comparisons=tuple(c.name for c in used), n_cycles=n_cycles,
        residual_rms=residual_rms, nominal_result=result)


def _lag_one(values: np.ndarray) -> float:
    """Circular lag-one autocorrelation of one revolution's residual (0 for a flat one)."""
    centred = values - values.mean()
    power = float(centred @ centred)
    if power == 0.0:
        return 0.0
    return min(float(centred @ np.roll(centred, 1)) / power, 0.999)


def apply_parameters(mechanism: Mechanism, values: Mapping[str, float]) -> dict[str, Any]:
    """Return the mechanism file's content with identified inertial parameters.

    Parameters
    ----------
    mechanism : Mechanism
        The nominal mechanism (read again from its source file, so that every key is kept).
    values : mapping of str to float
        ``"<body>.mass"``, ``".mx"``, ``".my"``, ``".inertia"`` (about the frame origin); others
        (friction) are ignored here.

    Returns
    -------
    dict
        The mechanism document: a body with first moments ``(mx, my)`` has its centre of
        gravity moved to ``c = (mx, my) / m`` (points and guess shifted so that the geometry is
        unchanged) and the inertia about the new centre ``I_O - m |c|^2``.
    """
    import tomllib

    document = tomllib.loads(Path(mechanism.source).read_text(encoding="utf-8"))
    for table in document["bodies"]:
        name = table["name"]
        mass = float(values.get(f"{name}.mass", table["mass"]))
        c = np.array([values.get(f"{name}.mx", 0.0), values.get(f"{name}.my", 0.0)]) / mass
        inertia = float(values.get(f"{name}.inertia", table["inertia"])) - mass * float(c @ c)
        table["mass"], table["inertia"] = mass, inertia
        if np.any(c != 0.0):
            table["points"] = {p: [float(v[0] - c[0]), float(v[1] - c[1])]
                               for p, v in table["points"].items()}
            if "guess" in table:
                x, y, theta = table["guess"]
                shift = complex(*c) * complex(math.cos(theta), math.sin(theta))
                table["guess"] = [x + shift.real, y + shift.imag, theta]
    return document


def mechanism_toml(document: Mapping[str, Any], header: str = "") -> str:
    """Write a mechanism document (as :func:`apply_parameters` returns it) as TOML text.

    Parameters
    ----------
    document : mapping
        Top-level keys with strings, numbers and lists; ``bodies``, ``joints``, ``drivers`` as
        arrays of tables whose values are strings, numbers, lists or inline tables.
    header : str
        Comment lines put first (each without the ``#``).

    Returns
    -------
    str
        TOML that :func:`rigval.model.load_mechanism` reads back to the same values (floats
        written with ``repr``, so exactly).
    """
    lines = [f"# {line}" for line in header.splitlines()]
    arrays = {key: value for key, value in document.items()
              if isinstance(value, list) and value and isinstance(value[0], dict)}
    lines += [f"{key} = {_toml_value(value)}" for key, value in document.items()
              if key not in arrays]
    for key, tables in arrays.items():
        for table in tables:
            lines += ["", f"[[{key}]]"]
            lines += [f"{name} = {_toml_value(value)}" for name, value in table.items()]
    return "\n".join(lines) + "\n"


def _toml_value(value: Any) -> str:
    """One TOML value: string, bool, number, array or inline table."""
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        return repr(float(value)) if isinstance(value, float) else str(value)
    if isinstance(value, Mapping):
        return "{ " + ", ".join(f"{k} = {_toml_value(v)}" for k, v in value.items()) + " }"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    raise ConfigError(f"cannot write {value!r} to TOML", where={"key": "mechanism"},
                      hint="mechanism values are strings, numbers, arrays and tables")
