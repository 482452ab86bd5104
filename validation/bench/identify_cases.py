"""Identification sweep of ``rigval bench``: parameter error and time of ``rigval identify``.

The virtual rig runs the pendulum with its arm A 8 % heavier (432 kg instead of 400 kg,
:mod:`rigval.validation.bench.heavy_arm`) at 0.8 rev/s; the run is validated and identified with
the nominal file. Choices: ``A.mass, A.inertia`` named (the baseline) and ``--parameters auto``.
The error is the largest relative error of A.mass and A.inertia against the rig's truth (bound
1 %); the time is the whole identification (validation of the run included), the work ``n`` the
revolutions.
"""

from __future__ import annotations

import logging
import tempfile
from pathlib import Path

from rigval.validation.bench.heavy_arm import ARM_MASS_KG, HEAVIER_BY, heavy_arm_scene
from rigval.validation.bench.rows import BenchRow, measure, with_baseline

__all__ = ["identification_rows"]

logger = logging.getLogger(__name__)

TRUTH = {"A.mass": ARM_MASS_KG * HEAVIER_BY, "A.inertia": 330.0}
BASELINE = "A.mass, A.inertia named"
METRIC = "max relative error of A.mass, A.inertia against the rig's truth"


def identification_rows(quick: bool) -> list[BenchRow]:
    """Return the identification rows (see the module docstring).

    Parameters
    ----------
    quick : bool
        Identify from a 10 s run instead of a 20 s one.

    Returns
    -------
    list of BenchRow
    """
    from rigval.validation.identify import identify

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        scene, duration = heavy_arm_scene(Path(tmp), speed=0.8, quick=quick)
        case = f"virtual rig, arm A +8 % (432 kg), 0.8 rev/s, {duration:g} s, drive torques"
        for choice, parameters in ((BASELINE, list(TRUTH)), ("--parameters auto", "auto")):
            run = measure(lambda parameters=parameters: identify(scene, parameters), 1)
            value = dict(zip(run.value.names, run.value.value, strict=True))
            error = float(max(abs(value.get(name, float("nan")) / truth - 1.0)
                              for name, truth in TRUTH.items()))
            logger.info("identify %s: error %.3g in %.1f s", choice, error, run.time_s)
            rows.append(BenchRow(stage="identification", case=case, choice=choice,
                                 metric=METRIC, unit="1", error=error, bound=0.01,
                                 time_s=run.time_s, cpu_s=run.cpu_s, n=run.value.n_cycles))
    return with_baseline(rows, BASELINE)
