"""Speed against error: the sweep runner of ``rigval bench``.

Each sweep (one function per stage, in the ``*_cases`` modules) runs one stage's main choices
on a synthetic case whose truth is known and returns rows
(:class:`~rigval.validation.bench.rows.BenchRow`, re-exported here with the timing helpers).
:func:`run_bench` runs the sweeps; :mod:`rigval.validation.bench.report` writes the CSV,
Markdown and PNG files.
"""

from __future__ import annotations

import logging
import math
import multiprocessing
import os
import platform
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from typing import Any, TypeVar

from rigval.acquisition.errors import ConfigError
from rigval.validation.bench.rows import STAGES, BenchRow, Measured, measure, with_baseline

__all__ = ["SINGLE_THREAD_ENV", "STAGES", "BenchRow", "Measured", "machine_note", "measure",
           "run_bench", "with_baseline"]

logger = logging.getLogger(__name__)

T = TypeVar("T")


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
        compare_cases,
        diagnosis_cases,
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
            "identification": identify_cases.identification_rows,
            "comparison": compare_cases.comparison_rows,
            "diagnosis": diagnosis_cases.diagnosis_rows}


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
