"""Speed against error: the rows every sweep of ``rigval bench`` returns, and the sweep runner.

Each sweep (one function per stage, in the ``bench_*_cases`` modules) runs one stage's main
choices on a synthetic case whose truth is known and returns :class:`BenchRow` objects: the
choice, its time, its error against the truth, the stated bound that error must stay below, the
physical limit where one is known, and the baseline the row is compared to (another row of the
same stage, case and metric). :func:`run_bench` runs the sweeps;
:mod:`rigval.validation.bench.report` writes the CSV, Markdown and PNG files.

Times are the best of a few repeats, wall clock (``time.perf_counter``) and CPU of this process
(``time.process_time``, less disturbed by other work on a shared machine).
"""

from __future__ import annotations

import logging
import math
import multiprocessing
import os
import platform
import time
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, fields, replace
from typing import Any, TypeVar

from rigval.acquisition.errors import ConfigError

__all__ = ["SINGLE_THREAD_ENV", "STAGES", "BenchRow", "Measured", "machine_note", "measure",
           "run_bench", "with_baseline"]

logger = logging.getLogger(__name__)

T = TypeVar("T")

#: Stage names in the order :func:`run_bench` runs them.
STAGES: tuple[str, ...] = ("model", "alignment", "resampling", "derivatives", "reading",
                           "identification")


@dataclass(frozen=True)
class BenchRow:
    """One measured choice of one stage.

    Attributes
    ----------
    stage : str
        One of :data:`STAGES`.
    case : str
        The synthetic case (what was computed, on what input).
    choice : str
        The option measured (method, tolerance, order, ...).
    metric : str
        What ``error`` measures, against which truth.
    unit : str
        Unit of ``error``, ``bound`` and ``limit`` (``"1"`` for relative errors).
    error : float
        Error against the truth.
    bound : float
        Stated upper bound of ``error`` (``rigval bench`` fails when it is exceeded).
    limit : float
        Error set by the input itself (quantisation, timing noise) where known; NaN otherwise.
    time_s : float
        Best wall-clock time of the repeats, s.
    cpu_s : float
        Best CPU time of this process over the repeats, s (reading: of the reading subprocess).
    n : int
        Work done: samples, steps or events the time is for.
    baseline : str
        The ``choice`` of the row this one is compared to (its own for a baseline row).
    baseline_error : float
        That row's error, in ``unit``.
    baseline_time_s : float
        That row's wall-clock time scaled to this row's work ``n``, s.
    peak_mib : float
        Growth of the resident memory during the work (peak minus the size before it), MiB,
        where measured (reading); NaN otherwise.
    """

    stage: str
    case: str
    choice: str
    metric: str
    unit: str
    error: float
    bound: float
    time_s: float
    cpu_s: float
    n: int
    limit: float = math.nan
    baseline: str = ""
    baseline_error: float = math.nan
    baseline_time_s: float = math.nan
    peak_mib: float = math.nan

    @property
    def within_bound(self) -> bool:
        """Whether ``error`` is finite and at most ``bound``."""
        return math.isfinite(self.error) and self.error <= self.bound

    @property
    def is_baseline(self) -> bool:
        """Whether this row is its own baseline."""
        return self.baseline == self.choice

    def as_dict(self) -> dict[str, Any]:
        """Return the row as a plain dict in field order (for CSV and JSON)."""
        return {f.name: getattr(self, f.name) for f in fields(self)}


@dataclass(frozen=True)
class Measured:
    """The result of a timed call and its best wall-clock and CPU time in s."""

    value: Any
    time_s: float
    cpu_s: float


def measure(func: Callable[[], T], repeats: int = 3) -> Measured:
    """Call ``func`` ``repeats`` times; keep the last result and the best times.

    Parameters
    ----------
    func : callable
        Work to time, without arguments.
    repeats : int, default 3
        Number of calls (at least 1).

    Returns
    -------
    Measured
        The result and the shortest wall-clock and CPU times, s.
    """
    best_wall = best_cpu = math.inf
    value: Any = None
    for _ in range(max(1, repeats)):
        wall, cpu = time.perf_counter(), time.process_time()
        value = func()
        best_wall = min(best_wall, time.perf_counter() - wall)
        best_cpu = min(best_cpu, time.process_time() - cpu)
    return Measured(value, best_wall, best_cpu)


def with_baseline(rows: Iterable[BenchRow], baseline_choice: str) -> list[BenchRow]:
    """Fill the baseline columns from the row with ``choice == baseline_choice``.

    Rows are matched to their baseline by stage, case and metric.

    Parameters
    ----------
    rows : iterable of BenchRow
        Rows of one sweep, the baseline rows among them.
    baseline_choice : str
        The ``choice`` of the baseline rows.

    Returns
    -------
    list of BenchRow
        The rows with ``baseline``, ``baseline_error`` and ``baseline_time_s`` (the baseline's
        time scaled to the row's work ``n``) set.

    Raises
    ------
    ValueError
        If a row has no baseline row with the same stage, case and metric.
    """
    rows = list(rows)
    bases = {(r.stage, r.case, r.metric): r for r in rows if r.choice == baseline_choice}
    out = []
    for row in rows:
        base = bases.get((row.stage, row.case, row.metric))
        if base is None:
            raise ValueError(f"no baseline {baseline_choice!r} for {row.stage} / {row.case} / "
                             f"{row.metric}")
        out.append(replace(row, baseline=base.choice, baseline_error=base.error,
                           baseline_time_s=base.time_s * row.n / base.n))
    return out


def machine_note() -> str:
    """Return one line naming the machine, its cores and its load (for the reports)."""
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else math.nan
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as handle:
            names = [line.split(":", 1)[1].strip() for line in handle
                     if line.startswith("model name")]
        cpu = names[0] if names else cpu
    except OSError:
        pass
    return (f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}, "
            f"load average {load:.2f} at {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")


def _sweeps() -> dict[str, Callable[[bool], list[BenchRow]]]:
    from rigval.validation.bench import (
        align_cases,
        identify_cases,
        model_cases,
        read_cases,
        signal_cases,
    )

    return {"model": model_cases.model_rows,
            "alignment": align_cases.alignment_rows,
            "resampling": signal_cases.resampling_rows,
            "derivatives": signal_cases.derivative_rows,
            "reading": read_cases.reading_rows,
            "identification": identify_cases.identification_rows}


#: Environment of the worker process: one thread in every BLAS / OpenMP pool.
SINGLE_THREAD_ENV = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def run_bench(stages: Sequence[str] | None = None, *, quick: bool = False,
              single_thread: bool = True) -> list[BenchRow]:
    """Run the sweeps of the given stages and return all their rows.

    Parameters
    ----------
    stages : sequence of str, optional
        Stages from :data:`STAGES` (default: all, in that order).
    quick : bool, default False
        Small cases and fewer choices (well under a minute in all); the full run takes a few
        minutes on 2 cores.
    single_thread : bool, default True
        Run the sweeps in a fresh process whose BLAS and OpenMP pools have one thread
        (:data:`SINGLE_THREAD_ENV`). With helper threads, the CPU time counts their spinning and
        wall times on a shared 2-core machine scatter by 2-3x; with one thread the batched
        solver is also faster. False: run in this process as it is. With the model stage, two
        more fresh processes time full inverse dynamics of the pendulum as installed (default
        BLAS threads) and with one BLAS thread (rows labelled with the thread count used).

    Returns
    -------
    list of BenchRow
        The rows of every stage, in stage order.

    Raises
    ------
    ConfigError
        For an unknown stage name.
    """
    chosen = list(STAGES if stages is None else stages)
    unknown = [s for s in chosen if s not in STAGES]
    if unknown:
        raise ConfigError(f"unknown bench stage(s) {unknown}, expected some of {list(STAGES)}",
                          where={"key": "stages"}, hint="leave the stages out to run all")
    if single_thread:
        rows = _spawned(SINGLE_THREAD_ENV, run_bench, chosen, quick=quick, single_thread=False)
        if "model" in chosen:
            rows = _with_blas_rows(rows, quick)
        return rows
    sweeps = _sweeps()
    rows: list[BenchRow] = []
    for stage in chosen:
        start = time.perf_counter()
        stage_rows = sweeps[stage](quick)
        logger.info("bench %s: %d rows in %.1f s", stage, len(stage_rows),
                    time.perf_counter() - start)
        rows.extend(stage_rows)
    return rows


def _with_blas_rows(rows: list[BenchRow], quick: bool) -> list[BenchRow]:
    """Add the model's full inverse dynamics timed as installed and with one BLAS thread.

    Each runs in a fresh process: one with the environment as it is (OpenBLAS's default thread
    count unless the user set one), one with :data:`SINGLE_THREAD_ENV`; the one-thread row is
    the baseline. The rows go right after the other model rows.
    """
    from rigval.validation.bench.model_cases import blas_thread_row

    one = _spawned(SINGLE_THREAD_ENV, blas_thread_row, quick)
    default = _spawned({}, blas_thread_row, quick)
    blas = with_baseline([default, one], one.choice)
    last_model = max((k for k, r in enumerate(rows) if r.stage == "model"), default=-1)
    return rows[:last_model + 1] + blas + rows[last_model + 1:]


def _spawned(env: dict[str, str], func: Callable[..., T], *args: Any, **kwargs: Any) -> T:
    """Call ``func`` in a fresh spawned process whose environment adds ``env`` to this one's."""
    saved = {key: os.environ.get(key) for key in env}
    os.environ.update(env)  # inherited by the worker when it starts
    try:
        context = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(max_workers=1, mp_context=context) as pool:
            return pool.submit(func, *args, **kwargs).result()
    finally:
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value
