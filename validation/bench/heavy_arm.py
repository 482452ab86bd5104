"""The virtual-rig run of the identification and diagnosis rows: the pendulum's arm A 8 % heavier.

The rig simulates arm A with 432 kg instead of the mechanism file's 400 kg (the departure
``mass_scale A=1.08``) while the run's scene names the nominal file, so the run holds a model
error whose size and cause are known (seed 1; 20 s, ``--quick``: 10 s).
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["ARM_MASS_KG", "HEAVIER_BY", "heavy_arm_scene"]

#: Arm A's mass in the pendulum's mechanism file, kg.
ARM_MASS_KG = 400.0
#: Factor on arm A's mass in the rig.
HEAVIER_BY = 1.08


def heavy_arm_scene(folder: Path, *, speed: float, quick: bool) -> tuple[Path, float]:
    """Simulate the run and return its scene file and its duration.

    Parameters
    ----------
    folder : pathlib.Path
        The run folder to write.
    speed : float
        Main-shaft speed, rev/s.
    quick : bool
        A 10 s run instead of 20 s.

    Returns
    -------
    scene : pathlib.Path
        The run's scene (it names the nominal mechanism file).
    duration : float
        The run's length, s.
    """
    from rigval.sample_data import RigSettings, simulate_rig
    from rigval.sample_data.departures import Departures

    duration = 10.0 if quick else 20.0
    files = simulate_rig(folder, RigSettings(
        speed=speed, duration=duration, seed=1,
        departures=Departures(mass_scale=(("A", HEAVIER_BY),))))
    return files.path("scene.toml"), duration
