"""The rows every sweep of ``rigval bench`` returns, and how a sweep times its work.

A sweep (one function per stage, in the ``*_cases`` modules) runs one stage's main choices on a
synthetic case whose truth is known and returns :class:`BenchRow` objects: the choice, its
time, its error against the truth, the stated bound that error must stay below, the physical
limit where one is known, and the baseline the row is compared to (another row of the same
stage, case and metric; :func:`with_baseline`). :func:`measure` times a call: best of a few
repeats, wall clock (``time.perf_counter``) and CPU of this process (``time.process_time``,
less disturbed by other work on a shared machine).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, fields, replace
from typing import Any, TypeVar

__all__ = ["STAGES", "BenchRow", "Measured", "measure", "with_baseline"]

T = TypeVar("T")

#: Stage names in the order :func:`run_bench` runs them.
STAGES: tuple[str, ...] = ("model", "alignment", "resampling", "derivatives", "reading",
                           "identification", "comparison", "diagnosis")


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
