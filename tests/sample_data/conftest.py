"""Fixtures of the virtual-rig tests: short runs generated once per session."""

from __future__ import annotations

from pathlib import Path

import pytest

from rigval.sample_data import Imperfections, RigSettings, RunFiles, simulate_rig


@pytest.fixture(scope="session")
def rig_run(tmp_path_factory: pytest.TempPathFactory) -> RunFiles:
    """A 4 s run at 1.0 rev/s with the default imperfections (one dropout per carrier)."""
    out: Path = tmp_path_factory.mktemp("rig_run")
    return simulate_rig(out, RigSettings(speed=1.0, duration=4.0, seed=7))


@pytest.fixture(scope="session")
def ideal_run(tmp_path_factory: pytest.TempPathFactory) -> RunFiles:
    """A 3 s run at 1.2 rev/s of an ideal rig (only ADC quantisation and the module delays)."""
    out: Path = tmp_path_factory.mktemp("ideal_run")
    return simulate_rig(out, RigSettings(speed=1.2, duration=3.0, seed=3,
                                         imperfections=Imperfections.none()))
