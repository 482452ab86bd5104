"""Virtual-rig cases of known cause for the diagnosis: split, gain, lag, heavier arm, calibration.

Each case runs the virtual rig with one departure from the rigid planar model or its scene
(:class:`rigval.sample_data.departures.Departures`, or a scene that states a calibration other
than the sensor's), validates the scene and diagnoses it, and returns what the diagnosis said
beside the truth. ``tests/validation/test_diagnosis_rig.py`` runs a few seeds;
``benchmarks/diagnosis_attribution.py`` runs many.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from rigval.sample_data import RigSettings, simulate_rig
from rigval.sample_data.departures import Departures
from rigval.validation.diagnosis.explain import diagnose
from rigval.validation.pipeline import run_scene
from rigval.validation.verdict import comparison_verdict, run_verdict

#: The symmetry pair of the main drive's shafts as the rig's scene states their calibration:
#: 1 %, 0.98 % of it common to the shafts (one gauge lot, one steel, one drawing).
PAIR = """
[[symmetry]]
name = "main drive shafts"
comparisons = ["tor1", "tor2"]
u_measurement_rel = 0.01
u_measurement_rel_common = 0.0098
"""

#: Case name -> (departures, scene gain of tor1 and tor2, what is expected).
CASES: dict[str, tuple[Departures, float]] = {
    "split 0.53": (Departures(split_main=0.53, calibration_error=1.0), 0.0),
    "split 0.50": (Departures(split_main=0.50, calibration_error=1.0), 0.0),
    "gain 3 %": (Departures(), 0.03),
    "lag 2 ms": (Departures(lag_channel="tor1", lag_s=0.002, split_main=0.5), 0.0),
    "arm +8 %": (Departures(mass_scale=(("A", 1.08),)), 0.0),
    "calibration": (Departures(calibration_error=1.0), 0.0),
    "calibration, arm +8 %": (Departures(calibration_error=1.0, mass_scale=(("A", 1.08),)), 0.0),
}


def _state_gain(scene: Path, gain: float) -> None:
    """Make tor1 and tor2 read ``1 + gain`` times the torque: their stated gauge factors."""
    text = scene.read_text(encoding="utf-8")
    for name in ("tor1", "tor2"):
        text, count = re.subn(
            rf"(\[streams\.wls1\.channels\.{name}\]\n(?:.*\n)*?gauge_factor = )([0-9.]+)",
            lambda m: f"{m.group(1)}{float(m.group(2)) / (1.0 + gain)!r}", text, count=1)
        assert count == 1, name
    scene.write_text(text, encoding="utf-8")


def run_case(case: str, seed: int, folder: Path, *, duration: float = 20.0) -> dict[str, Any]:
    """Run one case on one seed and return the diagnosis beside the truth.

    Returns
    -------
    dict
        ``case``, ``seed``, ``detected`` (comparison names the verdict detects), ``ratios``
        (comparison -> ``|E| / (k u_val)``, the larger of the curve's and the common gain's),
        ``family`` (the run's statements together, :func:`rigval.validation.verdict.run_verdict`),
        ``causes``
        (comparison -> the statement as a dict), ``pair`` (the symmetry pair's scores or None)
        and ``truth`` (the departures' record).
    """
    departures, gain = CASES[case]
    files = simulate_rig(folder, RigSettings(speed=1.0, duration=duration, seed=seed,
                                             departures=departures))
    scene = files.path("scene.toml")
    if gain:
        _state_gain(scene, gain)
    with scene.open("a", encoding="utf-8") as handle:
        handle.write(PAIR)
    result = run_scene(scene)
    diagnosis = diagnose(result)
    pair = diagnosis.pairs[0].shares
    return {"case": case, "seed": seed,
            "detected": [c.name for c in result.comparisons
                         if comparison_verdict(c)["detected"]],
            "ratios": {c.name: comparison_verdict(c)["ratio"] for c in result.comparisons},
            "family": run_verdict(result)["family"],
            "causes": {name: {**s.record(), "sentence": s.sentence}
                       for name, s in diagnosis.causes.items()},
            "pair": None if pair is None else pair.as_dict(),
            "truth": {"gain": gain, **departures.record()}}
