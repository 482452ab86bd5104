"""Campaigns: validate many runs at once, on Dask or in child processes.

A campaign is a list of scenes (one per measured run). :func:`run_campaign` validates every scene
into its own report folder ``OUT/<run>/`` and returns one :class:`RunOutcome` per run, in the
order the scenes were given. Where the runs execute is a choice of the caller:

* an embedded :class:`distributed.LocalCluster` of worker processes (the default when the
  ``parallel`` extra is installed; nothing to start),
* an existing Dask cluster given by its scheduler address (``"tcp://host:8786"``) or a
  :class:`distributed.Client`, through the same code path (the workers must see the scene, data
  and output paths under the same names, e.g. on a shared file system),
* a child process per run (``scheduler="processes"``, the default without Dask; standard
  library only: :mod:`~rigval.validation.campaign.processes`),
* one after the other in this process (``scheduler="none"``).

All give the same outcomes, because each run is one call of
:func:`~rigval.validation.campaign.runs.run_one`, which never raises for a problem of its run
(errors, warnings and resume: :mod:`~rigval.validation.campaign.runs`). A run's warnings are
raised again in the campaign's process when its outcome arrives, inside
:func:`~rigval.validation.console.run_context` so they name the run. Worker processes of the
embedded cluster write their own stderr (Dask's messages, a traceback if Ctrl-C hits one while it
starts) to ``OUT/dask-workers.log`` instead of the terminal; the file is removed when empty.
"""

from __future__ import annotations

import contextlib
import logging
import multiprocessing
import os
import sys
import uuid
import warnings
from collections import Counter
from collections.abc import Callable, Generator, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from rigval.acquisition.errors import ConfigError
from rigval.validation.campaign.runs import (
    MANIFEST_NAME,
    PlannedRun,
    RunError,
    RunOutcome,
    RunReport,
    RunWarning,
    ValidateFunction,
    default_run_name,
    run_one,
)
from rigval.validation.console import run_context

if TYPE_CHECKING:
    from distributed import Client

    from rigval.validation.report.drawing import Drawers

__all__ = [
    "MANIFEST_NAME",
    "RunError",
    "RunOutcome",
    "RunReport",
    "RunWarning",
    "ValidateFunction",
    "dask_available",
    "plan_runs",
    "run_campaign",
    "run_one",
    "stop_worker_processes",
]

#: Dask settings of the embedded cluster, whose tasks are runs of seconds of CPU-bound work
#: each: its workers do not sample the stack of the running task for the dashboard's profile
#: (every 10 ms by default), and the event-loop tick (20 ms), memory monitors (100 ms) and
#: system monitor (500 ms) wake up less often. Each wake-up takes the GIL from the run: a fixed
#: task took 17 % less CPU in its worker with these intervals
#: (docs/bench/history-speed-as-installed.md, demo). The tick still reports an event loop
#: blocked for 3 s, and a worker over its memory limit is still stopped, within a second.
EMBEDDED_CLUSTER_CONFIG = {"distributed.worker.profile.enabled": False,
                           "distributed.admin.tick.interval": "1s",
                           "distributed.worker.memory.monitor-interval": "1s",
                           "distributed.admin.system-monitor.interval": "2s"}
#: Where the embedded cluster's worker processes write their stderr (in the campaign folder).
WORKER_LOG_NAME = "dask-workers.log"

logger = logging.getLogger(__name__)

def dask_available() -> bool:
    """Return whether ``dask`` and ``distributed`` (the ``parallel`` extra) can be imported."""
    try:
        import dask  # noqa: F401
        import distributed  # noqa: F401
    except ImportError:
        return False
    return True


def plan_runs(scenes: Sequence[str | Path], out_dir: str | Path) -> list[tuple[str, Path, Path]]:
    """Name the runs of a campaign and give each its report folder.

    A run is named after its scene's file stem without a trailing ``_scene`` (``run_0p8_scene``
    gives ``run_0p8``; a scene called ``scene.toml`` takes its folder's name). Names that occur
    more than once are prefixed with the scene's folder name, and a number is appended if that
    still collides. The same scene given twice is validated once.

    Parameters
    ----------
    scenes : sequence of path
        Scene files.
    out_dir : path
        The campaign folder; run ``name`` reports into ``out_dir / name``.

    Returns
    -------
    list of (str, Path, Path)
        Name, scene path and report folder per run, in the order given; absolute paths, so that
        workers started elsewhere find them on a shared file system.
    """
    unique: dict[Path, Path] = {}  # resolved -> as given
    for scene in map(Path, scenes):
        if scene.resolve() in unique:
            logger.warning("scene %s is listed more than once; it is validated once", scene)
            continue
        unique[scene.resolve()] = scene
    bases = [default_run_name(scene) for scene in unique.values()]
    counts = Counter(bases)
    taken: set[str] = set()
    plan = []
    for scene, base in zip(unique.values(), bases, strict=True):
        if counts[base] > 1:
            base = f"{scene.resolve().parent.name}_{base}"
        name, number = base, 2
        while name in taken:
            name, number = f"{base}-{number}", number + 1
        taken.add(name)
        plan.append((name, scene.absolute(), Path(out_dir).absolute() / name))
    return plan


def _raise_again(outcome: RunOutcome) -> None:
    """Raise a run's recorded warnings in this process, each naming the run.

    ``warn_explicit`` with a fresh registry shows each one even when another run raised the same
    text (the default filter shows a message once per place); the filters still apply.
    """
    with run_context(outcome.name):
        for item in outcome.warnings:
            warnings.warn_explicit(item.message, item.category, f"run {outcome.name}", 0,
                                   registry={})


def run_campaign(
    scenes: Sequence[str | Path],
    out_dir: str | Path,
    *,
    scheduler: str | Client | None = None,
    workers: int | None = None,
    validate: ValidateFunction | None = None,
    force: bool = False,
    on_result: Callable[[RunOutcome], None] | None = None,
    drawers: Sequence[Drawers] = (),
) -> list[RunOutcome]:
    """Validate every scene of a campaign, in parallel when Dask is available.

    Parameters
    ----------
    scenes : sequence of path
        Scene files, one per run.
    out_dir : path
        Campaign folder; each run reports into ``out_dir/<run name>/`` (see :func:`plan_runs`).
    scheduler : str or distributed.Client, optional
        Where the runs execute: ``None`` (default) ``"local"`` if Dask is installed, else
        ``"processes"``; ``"local"`` an embedded Dask cluster (Dask required); ``"processes"``
        a child process per run, ``workers`` at a time (standard library only,
        :mod:`~rigval.validation.campaign.processes`); ``"none"`` one after the other in this
        process; an address such as ``"tcp://host:8786"`` or a :class:`distributed.Client` an
        existing cluster (not closed afterwards).
    workers : int, optional
        Runs at a time: worker processes of the embedded cluster (one thread each) or child
        processes; default the number of CPUs, at most the number of runs (one: in this
        process). Ignored for an existing cluster.
    validate : callable, optional
        ``validate(scene, run_dir) -> RunReport``; default the rigval validation pipeline. On a
        cluster, or in processes that are not forked, it must be picklable (module level).
    force : bool
        Recompute every run, even those whose outputs are up to date.
    on_result : callable, optional
        Called in this process with each :class:`RunOutcome` as soon as its run ends (for a
        progress display), in completion order.
    drawers : sequence of rigval.validation.report.drawing.Drawers
        With ``"processes"``: drawers this process forked for the runs' processes, one each
        for the first runs (:meth:`~rigval.validation.report.drawing.Drawers.each`); the others
        draw their figures themselves.

    Returns
    -------
    list of RunOutcome
        One per run, in the order of ``scenes``.

    Raises
    ------
    ConfigError
        If ``scheduler`` is not understood, or asks for Dask and Dask is not installed.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    runs = [PlannedRun(name, scene, run_dir) for name, scene, run_dir in plan_runs(scenes, out_dir)]
    notify = on_result or (lambda outcome: None)
    if not runs:
        return []
    if scheduler is None:
        scheduler = "local" if dask_available() else "processes"
    if scheduler == "processes":
        n_workers = min(workers or os.cpu_count() or 1, len(runs))
        if n_workers > 1:
            from rigval.validation.campaign.processes import run_in_processes

            return _collect(runs, run_in_processes(runs, validate, force, n_workers,
                                                   drawers), notify)
        scheduler = "none"
    if scheduler == "none":
        return _collect(runs, (run_one(run.scene, run.run_dir, validate=validate, name=run.name,
                                       force=force) for run in runs), notify)
    with _client(scheduler, workers, len(runs), out_dir / WORKER_LOG_NAME) as client:
        return _collect(runs, _run_on_cluster(client, runs, validate, force), notify)


def _collect(runs: Sequence[PlannedRun], completed: Generator[RunOutcome, None, None],
             notify: Callable[[RunOutcome], None]) -> list[RunOutcome]:
    """Raise each outcome's warnings again and notify, in completion order; return scene order."""
    outcomes = {}
    with contextlib.closing(completed):  # on Ctrl-C at once: the schedulers clean up
        for outcome in completed:
            outcomes[outcome.name] = outcome
            _raise_again(outcome)
            notify(outcome)
    return [outcomes[run.name] for run in runs]


def _run_on_cluster(client: Client, runs: Sequence[PlannedRun], validate: ValidateFunction | None,
                    force: bool) -> Generator[RunOutcome, None, None]:
    """Submit one task per run to a Dask cluster; yield the outcomes as they finish."""
    from distributed import as_completed

    token = uuid.uuid4().hex[:8]
    futures = {
        client.submit(run_one, run.scene, run.run_dir, validate=validate, name=run.name,
                      force=force, key=f"rigval-run-{run.name}-{token}", pure=False): run
        for run in runs
    }
    for future in as_completed(futures):
        run = futures[future]
        try:
            outcome = future.result()
        except Exception as error:  # a lost worker or task, not the run's data
            outcome = RunOutcome(name=run.name, scene=run.scene, run_dir=run.run_dir,
                                 status="error", error=RunError.from_exception(error))
        future.release()
        yield outcome


@contextlib.contextmanager
def _client(scheduler: str | Client, workers: int | None, n_runs: int, worker_log: Path
            ) -> Iterator[Client]:
    """Yield a Dask client for ``scheduler``; close what was opened here afterwards.

    The embedded cluster's worker processes write their stderr to ``worker_log``.
    """
    if not isinstance(scheduler, str):  # an existing distributed.Client
        yield scheduler
        return
    if scheduler != "local" and "://" not in scheduler:
        raise ConfigError(f"unknown scheduler {scheduler!r}", where={"option": "--scheduler"},
                          hint='give "local", "processes", "none" or an address such as '
                               'tcp://host:8786')
    if not dask_available():
        raise ConfigError(f"scheduler {scheduler!r} needs Dask, which is not installed",
                          where={"option": "--scheduler"},
                          hint='pip install "rigval[parallel]", or use --scheduler processes')
    from distributed import Client, LocalCluster

    if scheduler != "local":
        if workers is not None:
            logger.info("--workers is ignored with an existing cluster at %s", scheduler)
        try:
            client = Client(scheduler)
        except OSError as error:
            raise ConfigError(f"cannot reach the Dask scheduler at {scheduler}: {error}",
                              where={"option": "--scheduler"},
                              hint="check the address and that the scheduler is running "
                                   "(`dask scheduler` prints its address)") from error
        with client:
            yield client
        return
    import dask

    n_workers = max(1, min(workers or os.cpu_count() or 1, n_runs))
    # No dashboard; the scheduler's small HTTP server (health checks) on a free local port, so
    # that two campaigns on one machine do not compete for port 8787. Without a dashboard
    # nobody reads the workers' statistical profiles: no sampling of the running run's stack
    # every 10 ms, and fewer wake-ups of the workers' event loops (EMBEDDED_CLUSTER_CONFIG).
    with contextlib.ExitStack() as stack:
        with _children_stderr(worker_log), dask.config.set(EMBEDDED_CLUSTER_CONFIG):
            cluster = stack.enter_context(LocalCluster(
                n_workers=n_workers, threads_per_worker=1, processes=True,
                dashboard_address=None, scheduler_kwargs={"dashboard_address": "localhost:0"}))
        client = stack.enter_context(Client(cluster))
        stack.callback(_remove_if_empty, worker_log)
        logger.info("local Dask cluster with %d worker processes (their stderr: %s)", n_workers,
                    worker_log)
        yield client


@contextlib.contextmanager
def _children_stderr(log: Path) -> Iterator[None]:
    """Give processes started inside the block ``log`` as their stderr, not the terminal.

    File descriptor 2 points at ``log`` while the block runs (children inherit it: what a worker
    prints, even a traceback when Ctrl-C hits it while it imports, goes there); this process's
    own ``sys.stderr`` writes to the terminal meanwhile. Afterwards both are restored, unless
    something else (the Ctrl-C handler of :func:`~rigval.validation.console.interrupt_quietly`)
    replaced ``sys.stderr`` in the meantime.
    """
    sys.stderr.flush()
    saved = os.dup(2)
    with open(log, "ab") as file:
        os.dup2(file.fileno(), 2)
    previous = sys.stderr
    terminal = os.fdopen(os.dup(saved), "w", buffering=1, encoding=previous.encoding,
                         errors="backslashreplace")
    sys.stderr = terminal
    try:
        yield
    finally:
        if sys.stderr is terminal:
            sys.stderr = previous
            os.dup2(saved, 2)
            terminal.close()
        os.close(saved)


def _remove_if_empty(path: Path) -> None:
    """Delete ``path`` if it exists and is empty."""
    with contextlib.suppress(OSError):
        if path.stat().st_size == 0:
            path.unlink()


def stop_worker_processes() -> None:
    """Kill this process's child processes (the runs' processes, a cluster's workers) at once.

    For Ctrl-C: their runs are lost either way, and killed they cannot print Dask's
    CancelledError and heartbeat messages. Multiprocessing's resource tracker is not among them
    (it cleans up after them).
    """
    for child in multiprocessing.active_children():
        child.kill()
