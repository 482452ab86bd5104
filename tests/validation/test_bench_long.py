"""``rigval bench --long``: how it measures a command and checks its arguments (no long run)."""

from __future__ import annotations

import numpy as np
import pytest

from rigval.acquisition.errors import ConfigError
from rigval.sample_data import runs_dir
from rigval.validation.bench.long_cases import long_rows, run_measured


def test_run_measured_reports_the_childs_own_usage() -> None:
    usage = run_measured(["info", str(runs_dir() / "run_0p8_wls1.tdms")])
    assert usage.returncode == 0
    # a Python process importing rigval holds tens of MiB; its CPU time is its own, not ours
    assert 20.0 < usage.peak_mib < 4096.0 and usage.cpu_s > 0.0
    assert usage.wall_s >= usage.cpu_s / 2.0  # at most 2 cores busy


def test_run_measured_peak_is_not_this_processs() -> None:
    # Linux carries a process's memory high-water mark into the program it execs: a child's
    # ru_maxrss would report at least this process's peak
    held = np.ones(512 << 17)  # 512 MiB, touched
    usage = run_measured(["info", str(runs_dir() / "run_0p8_wls1.tdms")])
    assert usage.returncode == 0 and held[-1] == 1.0
    assert 20.0 < usage.peak_mib < 256.0


def test_run_measured_passes_on_the_exit_code() -> None:
    assert run_measured(["validate", "/nonexistent/scene.toml", "--out", "/nonexistent"]
                        ).returncode == 2


@pytest.mark.parametrize("durations", [[0.5], [20.0, 20000.0]])
def test_long_rows_refuse_lengths_the_rig_cannot_write(durations: list[float]) -> None:
    with pytest.raises(ConfigError, match=r"outside 1 \.\.\. 14400 s"):
        long_rows(durations)
