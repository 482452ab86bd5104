"""Why a run's model disagrees: the attribution of every comparison and the symmetry pairs.

:func:`diagnose` runs :func:`rigval.validation.diagnosis.attribution.attribute` on each set of
comparisons that share no channel (:func:`rigval.validation.diagnosis.causes.independent_sets`)
and the scene's ``[[symmetry]]`` pairs (:mod:`rigval.validation.diagnosis.symmetry`), and words
the result: per comparison the most likely cause with its size and uncertainty, against the best
cause of the other class (a parameter against a measurement error). :class:`Diagnosis` gives the
same as JSON (metrics.json) and as typed variables (the run's netCDF group ``/why``).
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr

from rigval.acquisition.json_values import json_ready
from rigval.validation.diagnosis.attribution import (
    Attribution,
    Evidence,
    Found,
    Sized,
    attribute,
)
from rigval.validation.diagnosis.causes import (
    attribution_problem,
    detected,
    independent_sets,
    subset,
)
from rigval.validation.diagnosis.rigidity import RigidityEvidence, run_rigidity
from rigval.validation.diagnosis.symmetry import (
    AxialBending,
    PairShares,
    axial_bending,
    pair_shares,
)
from rigval.validation.results import ValidationResult
from rigval.validation.scene_types import SymmetrySpec

__all__ = ["MODE_SHARE", "CauseStatement", "Diagnosis", "PairStatement", "attach_diagnosis",
           "diagnose"]

logger = logging.getLogger(__name__)

#: A found mode is named a comparison's most likely cause when it holds more than this share of
#: the residual's variance (measured minus model, below the rigidity evidence's upper
#: frequency): most of the disagreement is then the mode, whether or not the revolution mean
#: shows it (a mode rung between the orders averages out of the mean).
MODE_SHARE = 0.5


@dataclasses.dataclass(frozen=True)
class CauseStatement(Sized):
    """The most likely cause of one comparison's residual: a sized cause and its standing.

    Attributes
    ----------
    name, kind, unit, meaning, value, std, relative, relative_std
        The cause as :class:`~rigval.validation.diagnosis.attribution.Sized` (``name``
        ``"gain torque_F"``, ``"A.mass"``; ``""`` and NaN sizes without one). metrics.json
        and the netCDF group ``/why`` call the name ``cause`` (:meth:`record`).
    comparison : str
        The comparison.
    detected : bool
        The V&V 20 verdict detects a model error in it.
    significant : bool
        The cause passed the attribution's selection (else it is only the best candidate).
    weight : float
        Its share of the evidence among single causes (1).
    alternative : str
        The best cause of the other class (a parameter against a gain, lag, offset or mode).
    alternative_weight : float
        Its share of the evidence.
    confusable_with : str
        A cause the data cannot tell apart from it (``""``: none).
    correlation : float
        Whitened correlation of the two signatures (NaN without one).
    residual_share : float
        For a found mode named because it holds most of the residual (:data:`MODE_SHARE`):
        its share of the residual's variance below the rigidity evidence's upper frequency
        (1); NaN otherwise.
    """

    comparison: str
    detected: bool
    significant: bool
    weight: float
    alternative: str = ""
    alternative_weight: float = 0.0
    confusable_with: str = ""
    correlation: float = math.nan
    residual_share: float = math.nan

    def record(self) -> dict[str, Any]:
        """Return the fields by name, the cause's as ``cause``: metrics.json and ``/why``."""
        fields = dataclasses.asdict(self)
        return {"comparison": fields.pop("comparison"), "cause": fields.pop("name"), **fields}

    @property
    def mode_holds_residual(self) -> bool:
        """Whether the cause is a found mode named for holding most of the residual."""
        return self.kind == "mode" and math.isfinite(self.residual_share)

    @property
    def phrase(self) -> str:
        """The cause in words with its size, e.g. ``"a gain of +3.1 +- 0.4 % (calibration)"``."""
        if not self.name:
            return "no candidate"
        v, s = self.value, self.std
        if self.kind == "gain":
            return f"a gain of {100 * v:+.1f} +- {100 * s:.1f} % ({self.meaning})"
        if self.kind == "lag":
            return f"a lag of {1e3 * v:+.2f} +- {1e3 * s:.2f} ms ({self.meaning})"
        if self.kind == "offset":
            return f"an offset of {v:+.3g} +- {s:.2g} {self.unit}"
        if self.mode_holds_residual:
            return (f"the {self.meaning}, holding {100 * v:.0f} +- {100 * s:.0f} % of the "
                    "residual's variance")
        if self.kind == "mode":
            return f"the {self.meaning} (participation {v:.2f} +- {s:.2f})"
        if math.isfinite(self.relative):
            return (f"{self.name} {100 * self.relative:+.1f} +- {100 * self.relative_std:.1f} %"
                    f" ({v:+.3g} +- {s:.2g} {self.unit}), a mechanism parameter")
        return f"{self.name} {v:+.3g} +- {s:.2g} {self.unit}, a mechanism parameter"

    @property
    def explanation(self) -> str:
        """The most likely cause in words, e.g. ``"most likely A.mass +8.0 +- 0.2 % ..."``."""
        if not self.name:
            return "no candidate cause acts on it"
        if not self.significant:
            return (f"no single cause stands out (closest: {self.phrase}, weight "
                    f"{self.weight:.2f})")
        other = "a parameter" if self.kind != "parameter" else "a measurement error"
        text = f"most likely {self.phrase}"
        if self.alternative:
            text += (f", not {other} (best: {self.alternative}, weight "
                     f"{self.alternative_weight:.2f})")
        if self.confusable_with:
            text += (f"; cannot be told from {self.confusable_with} here (correlation "
                     f"{self.correlation:.2f})")
        return text

    @property
    def sentence(self) -> str:
        """The verdict's sentence for this comparison."""
        if not self.detected and self.mode_holds_residual:
            return (f"{self.comparison}: no model error detected in the revolution mean; "
                    f"most of its residual is {self.phrase}")
        if not self.detected:
            return f"{self.comparison}: no model error detected"
        return f"{self.comparison}: error detected; {self.explanation}"


@dataclasses.dataclass(frozen=True)
class PairStatement:
    """One ``[[symmetry]]`` pair's evidence.

    Attributes
    ----------
    spec : SymmetrySpec
        The pair as the scene states it.
    shares : PairShares or None
        For ``kind = "shares"``.
    bending : AxialBending or None
        For ``kind = "faces"``.
    """

    spec: SymmetrySpec
    shares: PairShares | None = None
    bending: AxialBending | None = None

    @property
    def sentence(self) -> str:
        """The pair's statement in words."""
        a, b = self.spec.comparisons
        if self.shares is not None:
            s = self.shares
            beyond = ("asymmetric beyond the stated calibration" if s.asymmetric
                      else "symmetric within the stated calibration")
            text = (f"{self.spec.name}: {a} carries {s.share:.4f} (95 %: {s.lower:.4f} ..."
                    f" {s.upper:.4f}) of {a} + {b}, {beyond} "
                    f"({100 * self.spec.u_measurement_rel:g} % per channel)")
            if math.isfinite(s.lag_s):
                text += f"; {b} lags {1e3 * s.lag_s:+.2f} +- {1e3 * s.u_lag_s:.2f} ms"
            return text
        g = self.bending
        assert g is not None
        found = ("bending beyond a gain mismatch: the rod is not a two-force member"
                 if g.bending else "no bending beyond a gain mismatch")
        return (f"{self.spec.name}: bending RMS {g.bending_rms:.4g} ({100 * g.ratio:.1f} % of the"
                f" axial RMS {g.axial_rms:.4g}; allowed {g.k:g} x {g.u_bending:.3g}): {found}")


@dataclasses.dataclass(frozen=True)
class Diagnosis:
    """Why the run's model disagrees.

    Attributes
    ----------
    causes : mapping of str to CauseStatement
        Per comparison, in scene order.
    pairs : tuple of PairStatement
        The scene's symmetry pairs.
    attributions : mapping of str to Attribution
        The attribution of each set of comparisons, keyed by its names joined with ``+``.
    explained : mapping of str to numpy.ndarray
        Per comparison, what the chosen causes add to its residual over phi_F, ``(n,)``
        (zeros without a chosen cause), signal units.
    rigidity : mapping of str to RigidityEvidence
        The rigidity evidence whose resonances entered the attribution, per comparison whose
        aligned stream the run kept (empty when the modes were given): ``rigidity.json``.
    """

    causes: Mapping[str, CauseStatement]
    pairs: tuple[PairStatement, ...]
    attributions: Mapping[str, Attribution]
    explained: Mapping[str, np.ndarray]
    rigidity: Mapping[str, RigidityEvidence] = dataclasses.field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        """Return the diagnosis as JSON-ready values (metrics.json's ``diagnosis``; NaN as None)."""
        return json_ready({
            "attribution": {name: {**c.record(), "sentence": c.sentence}
                            for name, c in self.causes.items()},
            "symmetry": [{"name": p.spec.name, "kind": p.spec.kind,
                          "comparisons": list(p.spec.comparisons),
                          "u_measurement_rel": p.spec.u_measurement_rel,
                          "u_measurement_rel_common": p.spec.u_measurement_rel_common,
                          **(p.shares or p.bending).as_dict(),  # type: ignore[union-attr]
                          "sentence": p.sentence} for p in self.pairs]})

    def dataset(self) -> xr.Dataset:
        """Return the diagnosis as typed variables (the netCDF group ``/why``), in one Dataset.

        Along ``comparison`` the ``cause_*`` fields of :meth:`CauseStatement.record`,
        ``cause_sentence`` and ``explained`` (comparison x angle, signal units); along
        ``pair_shares`` and ``pair_faces`` the symmetry pairs' scores (``shares_*``,
        ``faces_*``), where there are such pairs.
        """
        names = list(self.causes)
        records = [self.causes[n].record() for n in names]
        variables: dict[str, Any] = {"comparison": ("comparison", names)}
        for field in records[0] if records else ():
            if field != "comparison":
                variables[f"cause_{field}"] = ("comparison", _typed([r[field] for r in records]),
                                               {"units": _unit(field),
                                                "long_name": f"attribution: {field}"})
        variables["cause_sentence"] = ("comparison", np.array(
            [self.causes[n].sentence for n in names], dtype=object), {"long_name": "verdict"})
        variables["explained"] = (("comparison", "angle"), np.array(
            [self.explained[n] for n in names]), {
            "long_name": "residual the chosen causes explain (measured minus model), in each "
                         "comparison's unit"})
        for kind, rows in (("shares", [p for p in self.pairs if p.shares is not None]),
                           ("faces", [p for p in self.pairs if p.bending is not None])):
            variables.update(_pair_variables(kind, rows))
        return xr.Dataset(variables)


def _pair_variables(kind: str, rows: Sequence[PairStatement]) -> dict[str, Any]:
    """Return the symmetry pairs of one kind as variables along ``pair_<kind>`` (none: {})."""
    if not rows:
        return {}
    dim = f"pair_{kind}"
    scores = [(p.shares or p.bending).as_dict() for p in rows]  # type: ignore[union-attr]
    return {dim: (dim, [p.spec.name for p in rows]),
            **{f"{kind}_{score}": (dim, _typed([s[score] for s in scores]), {
                "units": "1", "long_name": f"symmetry pair: {score}"}) for score in scores[0]}}


def _typed(values: Sequence[Any]) -> np.ndarray:
    """Values as a typed array: bool as int8 (netCDF), int32, float64, text as str."""
    if all(isinstance(v, bool) for v in values):
        return np.array(values, dtype=np.int8)
    if all(isinstance(v, int) for v in values):
        return np.array(values, dtype=np.int32)
    if all(isinstance(v, int | float) for v in values):
        return np.array(values, dtype=np.float64)
    return np.array([str(v) for v in values], dtype=object)


def _unit(name: str) -> str:
    return "1" if name in ("relative", "relative_std", "weight", "alternative_weight",
                           "correlation", "detected", "significant", "residual_share") else ""


def diagnose(result: ValidationResult,
             modes: Mapping[str, Sequence[tuple[float, float]]] | None = None,
             rigidity: Mapping[str, RigidityEvidence] | None = None) -> Diagnosis:
    """Attribute every comparison's residual and measure the scene's symmetry pairs.

    Parameters
    ----------
    result : ValidationResult
        The validated run.
    modes : mapping of str to sequence of (float, float), optional
        Per comparison, modes found in its residual (natural frequency Hz, damping ratio).
    rigidity : mapping of str to RigidityEvidence, optional
        Per comparison, its rigidity evidence: a resonance holding more than
        :data:`MODE_SHARE` of the residual's variance is named its most likely cause.

    Returns
    -------
    Diagnosis
    """
    problem = attribution_problem(result, modes)
    sets = independent_sets(result)
    attributions: dict[str, Attribution] = {}
    causes: dict[str, CauseStatement] = {}
    explained: dict[str, np.ndarray] = {}
    for comparison in result.comparisons:
        names = sets[comparison.name]
        key = "+".join(names)
        part = subset(problem, names)
        if key not in attributions:
            attributions[key] = attribute(*part)
        touching = {c.name: c for c in part[1] if comparison.name in c.effect}
        kinds = {c.name: c.kind for c in part[1]}
        causes[comparison.name] = _statement(comparison.name, detected(comparison),
                                             attributions[key], set(touching), kinds)
        evidence = (rigidity or {}).get(comparison.name)
        if evidence is not None:
            causes[comparison.name] = _mode_statement(causes[comparison.name], evidence)
        explained[comparison.name] = sum(
            (f.value * touching[f.name].effect[comparison.name]
             for f in attributions[key].found if f.name in touching),
            np.zeros(comparison.angle.size))
    pairs = tuple(_pair(result, spec) for spec in result.scene.symmetry)
    return Diagnosis(causes, pairs, attributions, explained)


def attach_diagnosis(result: ValidationResult,
                     modes: Mapping[str, Sequence[tuple[float, float]]] | None = None
                     ) -> ValidationResult:
    """Diagnose a run: the result with ``diagnosis`` and its tree with ``/why``.

    Parameters
    ----------
    result : ValidationResult
        The validated run (its tree gains the group ``/why``; ``/diagnosis`` holds the
        residual spectra's input).
    modes : mapping, optional
        As for :func:`diagnose`; default: the resonances
        :func:`rigval.validation.diagnosis.rigidity.run_rigidity` finds in each comparison
        whose aligned stream the run kept (none otherwise).

    Returns
    -------
    ValidationResult
        The result with its ``diagnosis``.
    """
    start = time.perf_counter()
    rigidity = run_rigidity(result) if modes is None else {}
    if modes is None:
        modes = {name: [(r.frequency_hz, r.damping) for r in evidence.resonances]
                 for name, evidence in rigidity.items()}
    diagnosis = dataclasses.replace(diagnose(result, modes, rigidity), rigidity=rigidity)
    result.tree["/why"] = xr.DataTree(diagnosis.dataset())
    logger.info("diagnosis: %.3f s", time.perf_counter() - start)
    return dataclasses.replace(result, diagnosis=diagnosis)


def _statement(name: str, is_detected: bool, attribution: Attribution, touching: set[str],
               kinds: Mapping[str, str]) -> CauseStatement:
    found = attribution.cause_of(name)
    ranked = [e for e in attribution.candidates if e.name in touching]
    best: Evidence | None = ranked[0] if ranked else None
    top: Found | Evidence | None = found or best
    if top is None:
        return CauseStatement("", "", "", "", math.nan, math.nan, math.nan, math.nan,
                              comparison=name, detected=is_detected, significant=False,
                              weight=0.0)
    kind = kinds[top.name]
    weight = next((e.weight for e in attribution.candidates if e.name == top.name), 0.0)
    other = next((e for e in ranked if (e.kind == "parameter") != (kind == "parameter")), None)
    confusable = next(((b if a == top.name else a, r) for a, b, r in attribution.confusable
                       if top.name in (a, b)), ("", math.nan))
    # chosen: sized with the other chosen causes; else the best single cause, sized alone
    size = {field.name: getattr(top, field.name) for field in dataclasses.fields(Sized)}
    if found is None:
        size["kind"] = kind
    return CauseStatement(**size, comparison=name, detected=is_detected,
                          significant=found is not None, weight=weight,
                          alternative=other.name if other else "",
                          alternative_weight=other.weight if other else 0.0,
                          confusable_with=confusable[0], correlation=confusable[1])


def _mode_statement(statement: CauseStatement, evidence: RigidityEvidence) -> CauseStatement:
    """Return the statement naming the found mode that holds most of the residual, or as it was.

    The share is the mode's variance below the evidence's upper frequency over the residual's
    variance there; its standard uncertainty follows the amplitude's (variance ~ amplitude^2).
    """
    residual = evidence.spectra.variance_residual
    if not evidence.resonances or not residual > 0.0:
        return statement
    upper = evidence.spectra.upper_hz
    shares = [min(r.variance_below(upper) / residual, 1.0) for r in evidence.resonances]
    best = int(np.argmax(shares))
    if shares[best] <= MODE_SHARE:
        return statement
    mode, share = evidence.resonances[best], shares[best]
    u_share = 2.0 * share * mode.u_amplitude / mode.amplitude if mode.amplitude > 0 else math.nan
    meaning = (f"structural mode at {mode.frequency_hz:.1f} +- "
               f"{max(mode.u_frequency_hz, 0.05):.1f} Hz, damping about "
               f"{100.0 * mode.damping:.1g} %")
    # the other class's best: the attribution's best parameter (its own statement's cause when
    # that was a parameter)
    keep_other = statement.kind != "parameter"
    return dataclasses.replace(
        statement, significant=True,
        name=f"mode {mode.frequency_hz:.3g} Hz {statement.comparison}",
        kind="mode", unit="1", meaning=meaning, value=share, std=u_share, relative=math.nan,
        relative_std=math.nan, weight=math.nan,
        alternative=statement.alternative if keep_other else statement.name,
        alternative_weight=statement.alternative_weight if keep_other else statement.weight,
        confusable_with="", correlation=math.nan, residual_share=share)


def _pair(result: ValidationResult, spec: SymmetrySpec) -> PairStatement:
    """One symmetry pair over the revolutions both comparisons have whole."""
    angle = result.tree["/angle"].to_dataset()
    a, b = (angle[n].to_numpy().astype(np.float64) for n in spec.comparisons)
    whole = np.all(np.isfinite(a), axis=1) & np.all(np.isfinite(b), axis=1)
    a, b = a[whole], b[whole]
    u = {"u_first": spec.u_measurement_rel, "u_second": spec.u_measurement_rel,
         "u_common": spec.u_measurement_rel_common}
    if spec.kind == "faces":
        return PairStatement(spec, bending=axial_bending(a, b, **u, what=spec.key))
    return PairStatement(spec, shares=pair_shares(
        a, b, **u, speed=2.0 * math.pi * result.speed_rev_s, what=spec.key))
