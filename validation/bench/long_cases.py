"""Long records: ``rigval validate`` on virtual-rig runs of growing length (``bench --long``).

For each record length the virtual rig writes a run (``rigval simulate-rig``) and ``rigval
validate`` checks it, each in a fresh process whose wall time and CPU time (user + system) are
read from the operating system (:func:`os.wait4`) and whose peak resident memory the process
reports itself as it ends (Linux's ``VmHWM``), so the figures are those a user gets from the
command line. (The child's ``ru_maxrss`` would not do: Linux carries the high-water mark of the
memory a process replaces at ``exec`` into it, so every child would report at least this
process's own peak.) The row's error is the validation's clock offset of
WLS #1 against the rig's truth (the run is validated, not only timed). Time and memory should
grow linearly with the record; the rows give both per second of record.

This is not part of the unit tests: an hour of record takes minutes to write and to validate.
"""

from __future__ import annotations

import json
import logging
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from rigval.acquisition.errors import ConfigError
from rigval.validation.bench.core import BenchRow

__all__ = ["DURATIONS_S", "QUICK_DURATIONS_S", "Usage", "long_rows", "run_measured"]

logger = logging.getLogger(__name__)

#: Record lengths of ``rigval bench --long`` (s): up to four hours, where memory that grows with
#: the record shows first.
DURATIONS_S = (20.0, 200.0, 2000.0, 3600.0, 14400.0)
#: With ``--quick``.
QUICK_DURATIONS_S = (20.0, 200.0)
#: Bound of the clock offset error of WLS #1 (s): 0.1 ms, 0.036 deg at 1 rev/s.
OFFSET_BOUND_S = 1e-4


@dataclass(frozen=True)
class Usage:
    """What one command cost: wall time and CPU time in s, peak resident memory in MiB."""

    wall_s: float
    cpu_s: float
    peak_mib: float
    returncode: int


#: Marks the line in which the measured command reports its peak memory (kB) on stderr.
_PEAK_MARK = "rigval-bench-peak-kB:"
#: The measured command: ``rigval ARGS``, then its own peak resident memory (``VmHWM`` of
#: ``/proc/self/status``, a fresh memory map since ``exec``) on stderr.
_MEASURED = f"""
import sys
from rigval.validation.cli import main
try:
    code = main(sys.argv[1:])
finally:
    try:
        with open("/proc/self/status") as status:
            peak = next(line.split()[1] for line in status if line.startswith("VmHWM:"))
        sys.stderr.write("\\n{_PEAK_MARK}" + peak + "\\n")
    except (OSError, StopIteration):  # not Linux: the parent falls back to ru_maxrss
        pass
sys.exit(code)
"""


def run_measured(args: Sequence[str]) -> Usage:
    """Run ``rigval ARGS`` in a fresh Python process and measure it.

    Parameters
    ----------
    args : sequence of str
        The ``rigval`` command line after ``rigval``.

    Returns
    -------
    Usage
        Wall time, CPU time (user + system of the child) and its peak resident memory (as the
        child reports it; where it cannot, its ``ru_maxrss``, which may include this process's).
    """
    command = [sys.executable, "-c", _MEASURED, *args]
    start = time.perf_counter()
    with tempfile.TemporaryFile() as errors:  # a file: a pipe could fill up and block the child
        process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=errors)
        _, status, usage = os.wait4(process.pid, 0)
        wall = time.perf_counter() - start
        errors.seek(0)
        stderr = errors.read().decode(errors="replace")
    process.returncode = os.waitstatus_to_exitcode(status)
    if process.returncode not in (0, 1):
        logger.warning("rigval %s exited with %d: %s", " ".join(args), process.returncode,
                       stderr.strip()[-500:])
    reported = [line for line in stderr.splitlines() if line.startswith(_PEAK_MARK)]
    peak_kib = int(reported[-1][len(_PEAK_MARK):]) if reported else usage.ru_maxrss
    return Usage(wall, usage.ru_utime + usage.ru_stime, peak_kib / 1024.0, process.returncode)


def _offset_error(out: Path, run: Path) -> float:
    """Return |offset of WLS #1 - rig truth| in s (NaN when the validation wrote nothing)."""
    from rigval.sample_data import load_truth

    alignment = out / "alignment.json"
    if not alignment.is_file():
        return float("nan")
    found = json.loads(alignment.read_text(encoding="utf-8"))["wls1"]["offset_s"]
    truth = load_truth(next(run.glob("*_truth.json")), signals=False)
    offsets, _ = truth.clock_on_reference("wls1")
    return abs(float(found) - offsets[0])


def long_rows(durations: Sequence[float] = DURATIONS_S, *, folder: Path | None = None,
              speed: float = 1.0, seed: int = 1) -> list[BenchRow]:
    """Write and validate virtual-rig runs of the given lengths; one row per length.

    Parameters
    ----------
    durations : sequence of float
        Record lengths in s (1 ... 14400).
    folder : pathlib.Path, optional
        Where the runs and reports go (kept); default a temporary folder, removed after.
    speed : float, default 1
        Main-shaft speed in rev/s.
    seed : int, default 1
        The rig's seed.

    Returns
    -------
    list of BenchRow
        Stage ``long``: per length the validation's wall and CPU time and peak memory, and
        its clock offset error against the truth (bound :data:`OFFSET_BOUND_S`); the rig's
        own time and memory are logged and in the case text.

    Raises
    ------
    ConfigError
        For a length outside 1 ... 14400 s.
    """
    bad = [d for d in durations if not 1.0 <= d <= 14400.0]
    if bad:
        raise ConfigError(f"record lengths {bad} outside 1 ... 14400 s",
                          where={"key": "durations"}, hint="e.g. --durations 20,200,2000,3600")
    with tempfile.TemporaryDirectory(prefix="rigval-long-") as scratch:
        base = Path(folder) if folder is not None else Path(scratch)
        rows = []
        for duration in durations:
            run, out = base / f"run_{duration:g}s", base / f"report_{duration:g}s"
            rig = run_measured(["simulate-rig", "--out", str(run), "--duration", f"{duration:g}",
                                "--speed", f"{speed:g}", "--seed", str(seed), "-q"])
            logger.info("rig %g s: %.1f s wall, %.1f s CPU, %.0f MiB", duration, rig.wall_s,
                        rig.cpu_s, rig.peak_mib)
            scene = next(run.glob("*_scene.toml"))
            check = run_measured(["validate", str(scene), "--out", str(out), "-q"])
            logger.info("validate %g s: %.1f s wall, %.1f s CPU, %.0f MiB", duration,
                        check.wall_s, check.cpu_s, check.peak_mib)
            samples = round(duration * (5000.0 * 7 + 2 * 3 * 50000.0 / 31.0))
            rows.append(BenchRow(
                stage="long", case=f"rigval validate of virtual-rig runs at {speed:g} rev/s "
                                   "(3 devices, 13 channels); peak MiB: the whole process",
                choice=f"{duration:g} s record (rig: {rig.wall_s:.0f} s wall, "
                       f"{rig.cpu_s:.0f} s CPU, {rig.peak_mib:.0f} MiB)",
                metric="clock offset error of WLS #1 against the rig truth", unit="s",
                error=_offset_error(out, run), bound=OFFSET_BOUND_S, time_s=check.wall_s,
                cpu_s=check.cpu_s, n=samples, peak_mib=check.peak_mib))
        return rows
