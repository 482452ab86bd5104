"""Rigidity evidence of a run: how much of each comparison the rigid model explains, and its modes.

The small API the pipeline, the report and the attribution call:

* :func:`rigidity_evidence` - one comparison's residual in time
  (:class:`~rigval.validation.diagnosis.residual.ResidualSeries`) to its spectra, resonances and
  one sentence;
* :func:`run_rigidity` - every comparison of a validated run whose aligned stream the run kept;
* :func:`run_rigidity_pair` - the same for two validations of one measurement (``rigval
  identify``'s nominal and identified runs), the work they share done once.

Both analyse the comparisons at the same samples (one stream's) together, sharing the work
that depends on the samples alone.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import asdict, dataclass, fields
from typing import Any

from rigval.acquisition.errors import DataError
from rigval.acquisition.json_values import json_ready
from rigval.processing.stretch_decimation import UPPER_HZ
from rigval.validation.diagnosis.modes import Resonance, default_band, find_resonances
from rigval.validation.diagnosis.residual import ResidualSeries, residual_series
from rigval.validation.diagnosis.spectra import (
    ResidualSpectra,
    residual_spectra,
    shared_residual_spectra,
)
from rigval.validation.results import ValidationResult

__all__ = ["RigidityEvidence", "evidence_record", "resonances_from_record",
           "rigidity_evidence", "run_rigidity", "run_rigidity_pair"]

logger = logging.getLogger(__name__)

#: Samples of residual series held together at most, one stream's comparisons, before they are
#: analysed (:func:`run_rigidity`): about 80 MiB of series (five 8-byte arrays). A 20 s run's
#: comparisons fit many times; a 4 h record's (2.3 M samples each) are analysed one by one.
SHARED_SAMPLES = 2**21


@dataclass(frozen=True)
class RigidityEvidence:
    """One comparison's rigidity evidence.

    Parameters
    ----------
    name, units : str
        Comparison and signal unit.
    spectra : ResidualSpectra
        The residual's synchronous and non-synchronous parts and their spectra.
    band : tuple of float
        Frequencies searched for resonances (Hz).
    resonances : tuple of Resonance
        Resonances found in the non-synchronous spectrum, by frequency.
    """

    name: str
    units: str
    spectra: ResidualSpectra
    band: tuple[float, float]
    resonances: tuple[Resonance, ...]

    @property
    def explained(self) -> float:
        """Share of the measured variance below the upper frequency the model explains (1)."""
        return self.spectra.explained

    def share(self, resonance: Resonance) -> float:
        """Share of the measured variance below the upper frequency in a resonance (1)."""
        return resonance.variance / self.spectra.variance_measured

    @property
    def sentence(self) -> str:
        """One sentence for the console and the report."""
        head = (f"the rigid model explains {100.0 * self.explained:.1f} % of {self.name}'s "
                f"variance below {self.spectra.upper_hz:g} Hz")
        if not self.resonances:
            return (f"{head}; no resonance stands above the residual's floor between "
                    f"{self.band[0]:.3g} and {self.band[1]:.3g} Hz")
        parts = [f"{100.0 * self.share(r):.2g} % is a structural mode at "
                 f"{r.frequency_hz:.1f} +- {max(r.u_frequency_hz, 0.05):.1f} Hz (damping about "
                 f"{100.0 * r.damping:.1g} %)" for r in self.resonances]
        return f"{head}; " + "; ".join(parts)


def rigidity_evidence(series: ResidualSeries, upper_hz: float = UPPER_HZ,
                      band: tuple[float, float] | None = None) -> RigidityEvidence:
    """Return one comparison's residual spectra, resonances and sentence.

    Parameters
    ----------
    series : ResidualSeries
        The comparison's residual in time (:func:`residual_series`).
    upper_hz : float, default :data:`UPPER_HZ`
        Upper end of the analysis (Hz).
    band : tuple of float, optional
        Frequencies searched for resonances (Hz); default
        :func:`~rigval.validation.diagnosis.modes.default_band`.
    """
    return _evidence(series, residual_spectra(series, upper_hz), band)


def _evidence(series: ResidualSeries, spectra: ResidualSpectra,
              band: tuple[float, float] | None = None) -> RigidityEvidence:
    """Return the evidence of one series from its spectra: the resonances found in them."""
    band = band or default_band(series.speed_rev_s, spectra.upper_hz)
    resonances = find_resonances(spectra.nonsynchronous, series.speed_rev_s, band)
    evidence = RigidityEvidence(series.name, series.units, spectra, band, resonances)
    logger.info("%s", evidence.sentence)
    return evidence


def run_rigidity(result: ValidationResult, upper_hz: float = UPPER_HZ
                 ) -> dict[str, RigidityEvidence]:
    """Return the rigidity evidence of every comparison whose aligned stream the run kept.

    Comparisons of streams the run did not keep (scene ``[output] aligned``) are left out, with
    a log line; so are those whose record is too short or broken for spectra. Comparisons at
    the same samples (one stream's, with the same gaps) share the work that depends on the
    samples alone (:func:`~rigval.validation.diagnosis.spectra.shared_residual_spectra`); each
    evidence is the one :func:`rigidity_evidence` gives, to the bit.
    """
    return _run_rigidity((result,), upper_hz)[0]


def run_rigidity_pair(first: ValidationResult, second: ValidationResult,
                      upper_hz: float = UPPER_HZ
                      ) -> tuple[dict[str, RigidityEvidence], dict[str, RigidityEvidence]]:
    """Return :func:`run_rigidity` of two validations of one measurement, sharing the work.

    ``rigval identify`` validates one measurement against the nominal and the identified
    mechanism (:meth:`rigval.validation.pipeline.Measurement.against`). Per comparison, a
    residual equal to the bit in both (a model output the changed parameters do not move, such
    as an acceleration) is analysed once; the others share, beside what the samples share, the
    measured signal's decimation and spectrum. Each evidence is the one :func:`run_rigidity`
    gives, to the bit.

    Parameters
    ----------
    first, second : ValidationResult
        Validations of one measurement, with the same comparisons.
    upper_hz : float, default :data:`UPPER_HZ`
        Upper end of the analysis (Hz).

    Returns
    -------
    tuple of dict
        The evidence of ``first`` and of ``second`` by comparison. A comparison without
        evidence for either (no kept signal, too short a record: logged) is left out of both.
    """
    found = _run_rigidity((first, second), upper_hz)
    return found[0], found[1]


def _run_rigidity(results: Sequence[ValidationResult], upper_hz: float
                  ) -> list[dict[str, RigidityEvidence]]:
    """Return the evidence of validations of one measurement, by comparison in scene order.

    One stream's comparisons are held together, split into groups at the same samples, until
    their series reach :data:`SHARED_SAMPLES` (then analysed and let go).
    """
    names = [c.name for c in results[0].comparisons]
    found: dict[str, list[RigidityEvidence]] = {}
    for stream in _by_stream(results[0]):
        held: dict[str, list[ResidualSeries]] = {}
        for name in stream:
            try:
                held[name] = [residual_series(result, name) for result in results]
            except DataError as exc:
                logger.info("no rigidity evidence for %s: %s", name, exc)
                continue
            if sum(s.time.size for series in held.values() for s in series) >= SHARED_SAMPLES:
                found.update(_held_evidence(held, upper_hz))
                held = {}
        found.update(_held_evidence(held, upper_hz))
    return [{name: found[name][k] for name in names if name in found}
            for k in range(len(results))]


def _held_evidence(held: dict[str, list[ResidualSeries]], upper_hz: float
                   ) -> dict[str, list[RigidityEvidence]]:
    """Return the evidence of held comparisons (each's series per result), group by group."""
    found = {}
    for group in _same_samples(held):
        try:
            evidence = _group_evidence([s for name in group for s in held[name]], upper_hz)
        except DataError as exc:
            for name in group:
                logger.info("no rigidity evidence for %s: %s", name, exc)
            continue
        width = len(held[group[0]])
        found.update({name: evidence[i * width:(i + 1) * width] for i, name in enumerate(group)})
    return found


def _by_stream(result: ValidationResult) -> list[list[str]]:
    """Return the comparisons' names by the stream they measure, in scene order."""
    streams: dict[str, list[str]] = {}
    for comparison in result.comparisons:
        streams.setdefault(comparison.spec.measured.stream, []).append(comparison.name)
    return list(streams.values())


def _same_samples(held: dict[str, list[ResidualSeries]]) -> list[list[str]]:
    """Return the comparisons' names in groups whose series are at the same samples."""
    groups: list[list[str]] = []
    for name, series in held.items():
        group = next((g for g in groups if all(
            a.same_samples(b) for a, b in zip(held[g[0]], series, strict=True))), None)
        if group is None:
            groups.append([name])
        else:
            group.append(name)
    return groups


def _group_evidence(series: Sequence[ResidualSeries], upper_hz: float
                    ) -> list[RigidityEvidence]:
    """Return the evidence of series at the same samples, a series equal to another's once."""
    distinct: list[ResidualSeries] = []
    which = []
    for s in series:
        index = next((i for i, d in enumerate(distinct) if d.same(s)), None)
        if index is None:
            distinct.append(s)
            index = len(distinct) - 1
        which.append(index)
    evidence = [_evidence(s, spectra) for s, spectra in
                zip(distinct, shared_residual_spectra(distinct, upper_hz), strict=True)]
    return [evidence[i] for i in which]


def evidence_record(evidence: RigidityEvidence) -> dict[str, Any]:
    """Return one comparison's evidence as JSON-ready data (``rigidity.json`` of a run).

    Keys: ``sentence``, ``units``, ``speed_rev_s``, ``upper_hz``, ``band_hz``, ``explained``,
    the variances, ``orders`` (amplitudes of the synchronous residual, order 0 first),
    ``spectrum`` (``frequency_hz``, ``residual_psd``, ``nonsynchronous_psd``) and
    ``resonances`` (the fields of :class:`Resonance` plus ``share``).
    """
    s = evidence.spectra
    return json_ready({
        "sentence": evidence.sentence, "units": evidence.units, "speed_rev_s": s.speed_rev_s,
        "upper_hz": s.upper_hz, "band_hz": list(evidence.band), "explained": evidence.explained,
        "variance_measured": s.variance_measured, "variance_residual": s.variance_residual,
        "variance_synchronous": s.variance_synchronous,
        "variance_nonsynchronous": s.variance_nonsynchronous,
        "orders": s.orders.amplitude.tolist(),
        "spectrum": {"frequency_hz": s.residual.frequency.tolist(),
                     "residual_psd": s.residual.psd.tolist(),
                     "nonsynchronous_psd": s.nonsynchronous.psd.tolist()},
        "resonances": [{**asdict(r), "share": evidence.share(r)} for r in evidence.resonances]})


def resonances_from_record(record: dict[str, Any]) -> tuple[Resonance, ...]:
    """Return the resonances of an :func:`evidence_record` (as read back from JSON)."""
    names = {f.name for f in fields(Resonance)}
    return tuple(Resonance(**{k: v for k, v in r.items() if k in names})
                 for r in record["resonances"])
