"""Two runs of one seed: as written by default, and with one setting of how it is computed."""

from __future__ import annotations

from pathlib import Path

import pytest

import rigval.sample_data.simulate as simulate
from rigval.sample_data import RigSettings, RunFiles, simulate_rig

__all__ = ["runs_with_and_without"]


def runs_with_and_without(folder: Path, setting: str, value: float
                          ) -> tuple[RunFiles, RunFiles]:
    """Return a 10 s run (seed 3) as written by default and with ``simulate.<setting>`` set.

    A setting that only decides how the run is computed in pieces (the sampling window, the
    stored truth's piece) must leave the run's files as they are.
    """
    settings = RigSettings(duration=10.0, seed=3)
    whole = simulate_rig(folder / "whole", settings)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(simulate, setting, value)
        pieces = simulate_rig(folder / "pieces", settings)
    return whole, pieces
