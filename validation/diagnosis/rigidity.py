"""Rigidity evidence of a run: how much of each comparison the rigid model explains, and its modes.

The small API the pipeline, the report and the attribution call:

* :func:`rigidity_evidence` - one comparison's residual in time
  (:class:`~rigval.validation.diagnosis.residual.ResidualSeries`) to its spectra, resonances and
  one sentence;
* :func:`run_rigidity` - every comparison of a validated run whose aligned stream the run kept;
* :func:`run_rigidity_pair` - the same for two validations of one measurement (``rigval
  identify``'s nominal and identified runs), the work they share done once.
"""

from __future__ import annotations

import logging
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
    a log line; so are those whose record is too short or broken for spectra.
    """
    out = {}
    for comparison in result.comparisons:
        try:
            out[comparison.name] = rigidity_evidence(residual_series(result, comparison.name),
                                                     upper_hz)
        except DataError as exc:
            logger.info("no rigidity evidence for %s: %s", comparison.name, exc)
    return out


def run_rigidity_pair(first: ValidationResult, second: ValidationResult,
                      upper_hz: float = UPPER_HZ
                      ) -> tuple[dict[str, RigidityEvidence], dict[str, RigidityEvidence]]:
    """Return :func:`run_rigidity` of two validations of one measurement, sharing the work.

    ``rigval identify`` validates one measurement against the nominal and the identified
    mechanism (:meth:`rigval.validation.pipeline.Measurement.against`). Per comparison, a
    residual equal to the bit in both (a model output the changed parameters do not move, such
    as an acceleration) is analysed once; otherwise the two share what depends on the
    measurement alone (:func:`~rigval.validation.diagnosis.spectra.shared_residual_spectra`).
    Either way each evidence is the one :func:`run_rigidity` gives, to the bit.

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
    out: tuple[dict[str, RigidityEvidence], dict[str, RigidityEvidence]] = ({}, {})
    for comparison in first.comparisons:
        name = comparison.name
        try:
            out[0][name], out[1][name] = _evidence_pair(residual_series(first, name),
                                                        residual_series(second, name), upper_hz)
        except DataError as exc:
            logger.info("no rigidity evidence for %s: %s", name, exc)
    return out


def _evidence_pair(first: ResidualSeries, second: ResidualSeries, upper_hz: float
                   ) -> tuple[RigidityEvidence, RigidityEvidence]:
    """Return the evidence of two series of one comparison, each analysed at most once."""
    if first.same(second):
        evidence = rigidity_evidence(first, upper_hz)
        logger.info("%s (the same residual again)", evidence.sentence)
        return evidence, evidence
    if not first.same_measurement(second):
        return rigidity_evidence(first, upper_hz), rigidity_evidence(second, upper_hz)
    spectra = shared_residual_spectra([first, second], upper_hz)
    return _evidence(first, spectra[0]), _evidence(second, spectra[1])


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
