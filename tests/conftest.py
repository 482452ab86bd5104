"""Shared test configuration: a non-interactive matplotlib backend and the path to shared/."""

from __future__ import annotations

import os
from pathlib import Path

import matplotlib
import pytest
from hypothesis import settings

matplotlib.use("Agg")
settings.register_profile("ci", deadline=None, max_examples=50, derandomize=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("RIGVAL_SHARED", REPO.parent / "shared"))


@pytest.fixture(scope="session")
def shared_dir() -> Path:
    """The project's ``shared/`` folder (real NI files, mechanisms); skip when absent."""
    if not SHARED.is_dir():
        pytest.skip(f"shared/ folder not found at {SHARED} (set RIGVAL_SHARED)")
    return SHARED


@pytest.fixture(scope="session")
def realdata_dir(shared_dir: Path) -> Path:
    """``shared/realdata``: byte copies of NI-written files."""
    path = shared_dir / "realdata"
    if not path.is_dir():
        pytest.skip(f"real NI files not found at {path}")
    return path


@pytest.fixture(scope="session")
def mechanisms_dir(shared_dir: Path) -> Path:
    """``shared/mechanisms``: the reference mechanism files."""
    return shared_dir / "mechanisms"
