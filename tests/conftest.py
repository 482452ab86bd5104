"""Shared test configuration: a non-interactive matplotlib backend and the third-party files.

Tests of rigval's own features need nothing outside the repository. Only the tests that read
third-party files written by NI software (``realdata/``) and the check that the built-in mechanism
files equal the project's reference copies (``mechanisms/``) need the project's shared folder:
``RIGVAL_SHARED=/path/to/shared`` (default ``../shared`` beside the repository; README, "Tests").
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
from collections.abc import Callable
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
    """The project's shared folder (real NI files, mechanisms); skip when absent."""
    if not SHARED.is_dir():
        pytest.skip(f"needs the third-party files of the shared folder, not found at {SHARED}: "
                    "set RIGVAL_SHARED=/path/to/shared (README, section Tests)")
    return SHARED


def _shared_subfolder(shared_dir: Path, name: str, what: str) -> Path:
    """Return ``shared_dir / name``; skip the test, saying how to provide it, when absent."""
    path = shared_dir / name
    if not path.is_dir():
        pytest.skip(f"needs {what}, not found at {path}: set RIGVAL_SHARED to a folder holding "
                    f"{name}/ (README, section Tests)")
    return path


@pytest.fixture(scope="session")
def realdata_dir(shared_dir: Path) -> Path:
    """``$RIGVAL_SHARED/realdata``: byte copies of NI-written files."""
    return _shared_subfolder(shared_dir, "realdata", "the real NI files")


@pytest.fixture(scope="session")
def mechanisms_dir(shared_dir: Path) -> Path:
    """``$RIGVAL_SHARED/mechanisms``: the project's reference mechanism files."""
    return _shared_subfolder(shared_dir, "mechanisms", "the reference mechanism files")


def _chromium_probe(page: Path, script: str, tmp_path: Path, *extra_args: str) -> object:
    """Load ``page`` in headless Chromium with ``script`` (which writes JSON into a
    ``<pre id="probe">`` element on load) and return the parsed JSON."""
    chromium = shutil.which("chromium")
    if chromium is None:
        pytest.skip("chromium not installed (apt-get install chromium); .ci/run installs it")
    probe = tmp_path / "probe.html"
    probe.write_text(page.read_text().replace("</body>", script + "</body>", 1))
    command = [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
               "--no-first-run", "--disable-background-networking",
               "--disable-component-update", "--disable-sync", *extra_args,
               f"--user-data-dir={tmp_path / 'profile'}", "--virtual-time-budget=10000",
               "--dump-dom", probe.as_uri()]
    dom = subprocess.run(command, capture_output=True, text=True, timeout=180,
                         check=True).stdout
    match = re.search(r'<pre id="probe">(.*?)</pre>', dom, re.S)
    assert match, f"the probe script did not run; chromium printed {dom[:300]!r}"
    return json.loads(match.group(1).replace("&quot;", '"').replace("&amp;", "&"))


@pytest.fixture
def chromium_probe() -> Callable[..., object]:
    """``probe(page, script, tmp_path, *chromium_args)``: run a probe script in headless Chromium
    on a copy of ``page`` and return the JSON it wrote (skips when Chromium is absent)."""
    return _chromium_probe


@pytest.fixture
def forks_beside() -> None:
    """Skip unless :func:`rigval.validation.beside.can_fork` holds now, when the test runs.

    Decided at run time, not at collection: an earlier test (a Dask cluster, say) may have left a
    thread running in this process, and with a second thread a ``Standby`` rightly refuses to fork.
    """
    from rigval.validation.beside import can_fork

    if not can_fork():
        pytest.skip("no fork here now: no fork start method, one CPU, or another thread runs "
                    "in this test process")
