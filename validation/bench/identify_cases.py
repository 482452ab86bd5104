"""Identification sweep of ``rigval bench``: parameter error and time of ``rigval identify``.

The virtual rig runs the pendulum with its arm A 8 % heavier (432 kg instead of 400 kg) at
0.8 rev/s (20 s, seed 1; ``--quick``: 10 s); the run is validated and identified with the nominal
file. Choices: ``A.mass, A.inertia`` named (the baseline) and ``--parameters auto``. The error is
the largest relative error of A.mass and A.inertia against the rig's truth (bound 1 %); the time
is the whole identification (validation of the run included), the work ``n`` the revolutions.
"""

from __future__ import annotations

import logging
import re
import tempfile
from pathlib import Path

from rigval.model import builtin_mechanism
from rigval.validation.bench.rows import BenchRow, measure, with_baseline

__all__ = ["identification_rows"]

logger = logging.getLogger(__name__)

TRUTH = {"A.mass": 432.0, "A.inertia": 330.0}
BASELINE = "A.mass, A.inertia named"
METRIC = "max relative error of A.mass, A.inertia against the rig's truth"


def identification_rows(quick: bool) -> list[BenchRow]:
    """Return the identification rows (see the module docstring).

    Parameters
    ----------
    quick : bool
        A 10 s run instead of 20 s.

    Returns
    -------
    list of BenchRow
    """
    from rigval.sample_data import RigSettings, simulate_rig
    from rigval.validation.identify import identify

    duration = 10.0 if quick else 20.0
    case = f"virtual rig, arm A +8 % (432 kg), 0.8 rev/s, {duration:g} s, drive torques"
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        text = Path(builtin_mechanism("pendulum")).read_text(encoding="utf-8")
        text = re.sub(r'(name = "A"\n(?:.*\n)*?)mass = 400\.0', r"\g<1>mass = 432.0", text,
                      count=1)
        mechanism = Path(tmp) / "heavy_arm.toml"
        mechanism.write_text(text, encoding="utf-8")
        files = simulate_rig(Path(tmp) / "run", RigSettings(speed=0.8, duration=duration, seed=1,
                                                             mechanism=mechanism))
        scene = files.path("scene.toml")
        scene.write_text(re.sub(r"^mechanism = .*$", 'mechanism = "builtin:pendulum"',
                                scene.read_text(encoding="utf-8"), flags=re.M),
                         encoding="utf-8")
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
