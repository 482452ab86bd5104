"""Diagnosis sweep of ``rigval bench``: what naming a model error's cause costs, against its error.

The virtual rig runs the pendulum with its arm A 8 % heavier (432 kg instead of 400 kg,
:mod:`rigval.validation.bench.heavy_arm`) at 1 rev/s; the run is validated once with the nominal
mechanism file. Choices: the attribution of every comparison
(:func:`rigval.validation.diagnosis.explain.diagnose`, the baseline: it names A.mass among every
cause it considers) and ``rigval identify`` told to fit A.mass and A.inertia (it is given the
cause). The error is that of the arm's mass change against the rig's truth, relative to it
(bound 10 %); the time is the step alone (the validation before it not included), the work
``n`` the revolutions.
"""

from __future__ import annotations

import logging
import math
import tempfile
from pathlib import Path

from rigval.validation.bench.heavy_arm import ARM_MASS_KG, HEAVIER_BY, heavy_arm_scene
from rigval.validation.bench.rows import BenchRow, measure, with_baseline

__all__ = ["diagnosis_rows"]

logger = logging.getLogger(__name__)

#: The rig's arm mass change, kg (400 kg times 0.08).
TRUTH_KG = ARM_MASS_KG * (HEAVIER_BY - 1.0)
BASELINE = "attribution of every comparison (diagnose)"
METRIC = "relative error of the arm's mass change (A.mass, +32 kg) against the rig's truth"


def diagnosis_rows(quick: bool) -> list[BenchRow]:
    """Return the diagnosis rows (see the module docstring).

    Parameters
    ----------
    quick : bool
        Diagnose a 10 s run instead of a 20 s one.

    Returns
    -------
    list of BenchRow
    """
    from rigval.validation.diagnosis.explain import diagnose
    from rigval.validation.identify import identify
    from rigval.validation.pipeline import run_scene

    with tempfile.TemporaryDirectory() as tmp:
        scene, duration = heavy_arm_scene(Path(tmp), speed=1.0, quick=quick)
        case = f"virtual rig, arm A +8 % (432 kg), 1 rev/s, {duration:g} s, 9 comparisons"
        result = run_scene(scene)
        attribution = measure(lambda: diagnose(result), 3)
        cause = attribution.value.causes["torque_F"]
        found = cause.value if cause.name == "A.mass" else math.nan
        fitted = measure(lambda: identify(result.scene, ["A.mass", "A.inertia"],
                                          result=result), 1)
        values = dict(zip(fitted.value.names, fitted.value.value, strict=True))
        rows = []
        for choice, change, run in ((BASELINE, found, attribution),
                                    ("rigval identify A.mass, A.inertia (cause given)",
                                     values["A.mass"] - ARM_MASS_KG, fitted)):
            error = float(abs(change - TRUTH_KG) / TRUTH_KG)
            logger.info("%s: error %.3g in %.2f s", choice, error, run.time_s)
            rows.append(BenchRow(stage="diagnosis", case=case, choice=choice, metric=METRIC,
                                 unit="1", error=error, bound=0.1, time_s=run.time_s,
                                 cpu_s=run.cpu_s, n=result.n_cycles))
    return with_baseline(rows, BASELINE)
