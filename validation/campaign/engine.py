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

All give the same outcomes, because each run is one call of :func:`run_one`, which never
raises for a problem of its run: a bad file, a failed alignment or even a bug in rigval becomes an
outcome with status ``"error"`` and a :class:`RunError` (class, message, where, hint, traceback),
and the other runs go on. rigval's errors pickle with their fields, so the original exception
object crosses the process boundary intact.

Warnings: a run's warnings are collected where it runs (:class:`RunWarning` in its outcome) and
raised again in the campaign's process when the outcome arrives, inside
:func:`~rigval.validation.console.run_context` so they name the run. Worker processes of the
embedded cluster write their own stderr (Dask's messages, a traceback if Ctrl-C hits one while it
starts) to ``OUT/dask-workers.log`` instead of the terminal; the file is removed when empty.

Resume: after a run is validated (passed or failed), :func:`run_one` writes
``OUT/<run>/manifest.json`` with the SHA-256 of the scene and of every input file the validation
read, the rigval version, the size of every output file and the run's metrics. A later
campaign skips the run (status as before, ``reused`` True) while all of these are unchanged and
the outputs are all present.
"""

from __future__ import annotations

import contextlib
import json
import logging
import multiprocessing
import os
import pickle
import re
import sys
import time
import traceback
import uuid
import warnings
from collections import Counter
from collections.abc import Callable, Generator, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from rigval.acquisition.errors import ConfigError, RigvalError
from rigval.acquisition.json_values import json_ready
from rigval.acquisition.outputs import write_text_atomic
from rigval.acquisition.schema import file_sha256
from rigval.validation.console import run_context
from rigval.validation.version import rigval_version as _rigval_version

if TYPE_CHECKING:
    from distributed import Client

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
#: task took 17 % less CPU in its worker with these intervals (docs/performance.md, Demo). The
#: tick still reports an event loop blocked for 3 s, and a worker over its memory limit is still
#: stopped, within a second.
EMBEDDED_CLUSTER_CONFIG = {"distributed.worker.profile.enabled": False,
                           "distributed.admin.tick.interval": "1s",
                           "distributed.worker.memory.monitor-interval": "1s",
                           "distributed.admin.system-monitor.interval": "2s"}
#: Where the embedded cluster's worker processes write their stderr (in the campaign folder).
WORKER_LOG_NAME = "dask-workers.log"

logger = logging.getLogger(__name__)

#: File name of the per-run manifest that makes a run resumable.
MANIFEST_NAME = "manifest.json"
_MANIFEST_SCHEMA = "rigval-run-manifest/1"

RunStatus = Literal["passed", "failed", "error"]


@dataclass(frozen=True)
class RunReport:
    """What validating one scene produced (the return value of a :data:`ValidateFunction`).

    Parameters
    ----------
    passed : bool
        Whether every pass/fail threshold of the scene was met.
    metrics : tuple of mapping
        One row per comparison and metric, with keys ``comparison``, ``metric``, ``value``
        (in the metric's unit, NaN when undefined) and optionally ``threshold`` (text such as
        ``">= 0.8"``) and ``passed`` (bool, or None without a threshold).
    outputs : tuple of Path
        Files written into the run's folder (report, tables, netCDF).
    inputs : tuple of Path
        Data files the validation read, besides the scene itself (hashed for resume).
    speed_rev_s : float or None
        Mean main-shaft running speed of the run in rev/s (the x axis of the campaign plot).
    """

    passed: bool
    metrics: tuple[Mapping[str, Any], ...]
    outputs: tuple[Path, ...]
    inputs: tuple[Path, ...]
    speed_rev_s: float | None = None


#: Validates the scene at the first path into the folder at the second path.
ValidateFunction = Callable[[Path, Path], RunReport]


@dataclass(frozen=True)
class RunError:
    """Why a run could not be validated.

    Parameters
    ----------
    kind : str
        Class name of the exception (``"DataFileError"``, ``"AlignmentError"``, ...).
    message : str
        What went wrong.
    where : dict
        Where it went wrong (file, channel, key, time in s, ...); empty for non-rigval errors.
    hint : str or None
        How to fix it.
    traceback : str
        The formatted traceback, from the process that ran the validation.
    exception : BaseException or None
        The exception itself when it could be carried over (rigval errors always can).
    """

    kind: str
    message: str
    where: dict[str, Any]
    hint: str | None
    traceback: str
    exception: BaseException | None = field(default=None, compare=False, repr=False)

    @classmethod
    def from_exception(cls, error: BaseException, tb: Any = None) -> RunError:
        """Describe an exception; ``tb`` is its traceback object or text (default its own)."""
        if isinstance(tb, str):
            tb_text = tb
        else:
            tb_text = "".join(traceback.format_exception(type(error), error,
                                                         tb or error.__traceback__))
        if isinstance(error, RigvalError):
            message, where, hint = error.message, dict(error.where), error.hint
        else:
            message, where = str(error) or type(error).__name__, {}
            hint = ("this is not a rigval data error; the traceback shows where it came from "
                    "(please report it if it looks like a bug in rigval)")
        return cls(kind=type(error).__name__, message=message, where=where, hint=hint,
                   traceback=tb_text, exception=error if _picklable(error) else None)

    def to_dict(self) -> dict[str, Any]:
        """Return the error as JSON-ready data (without the exception object)."""
        return {"kind": self.kind, "message": self.message, "where": json_ready(self.where),
                "hint": self.hint, "traceback": self.traceback}

    def __str__(self) -> str:
        text = f"{self.kind}: {self.message}"
        if self.where:
            text += " (" + ", ".join(f"{k}: {v}" for k, v in self.where.items()) + ")"
        if self.hint:
            text += f". How to fix: {self.hint}"
        return text


@dataclass(frozen=True)
class RunWarning:
    """A warning raised while a run was validated.

    Parameters
    ----------
    category : type
        The warning class (``DataWarning``, ``NumericsWarning``, ...; ``UserWarning`` for a class
        that cannot cross a process boundary).
    message : str
        Its text.
    """

    category: type[Warning]
    message: str

    def __str__(self) -> str:
        return f"{self.category.__name__}: {self.message}"


@dataclass(frozen=True)
class RunOutcome:
    """The result of one run of a campaign.

    Parameters
    ----------
    name : str
        Run name, unique in the campaign (the scene's file stem, made unique).
    scene : Path
        The scene file.
    run_dir : Path
        The run's report folder.
    status : {"passed", "failed", "error"}
        ``"failed"``: validated, but a threshold was missed; ``"error"``: could not be validated.
    metrics : tuple of dict
        Metric rows (see :class:`RunReport`); empty for an error.
    speed_rev_s : float or None
        Mean running speed in rev/s.
    outputs : tuple of str
        Output files, relative to ``run_dir``.
    elapsed_s : float
        Wall time of the validation in s (of the original computation for a reused run).
    cpu_s : float
        CPU time of the validating process during the validation in s (all its threads; same
        convention as ``elapsed_s`` for a reused run). On a busy machine ``elapsed_s`` grows,
        ``cpu_s`` hardly does.
    reused : bool
        True when the outputs of an earlier campaign were up to date and nothing was recomputed.
    error : RunError or None
        Why the run could not be validated (status ``"error"`` only).
    warnings : tuple of RunWarning
        Warnings the validation raised, in order (none for a reused run).
    """

    name: str
    scene: Path
    run_dir: Path
    status: RunStatus
    metrics: tuple[dict[str, Any], ...] = ()
    speed_rev_s: float | None = None
    outputs: tuple[str, ...] = ()
    elapsed_s: float = 0.0
    cpu_s: float = 0.0
    reused: bool = False
    error: RunError | None = None
    warnings: tuple[RunWarning, ...] = ()

    def output(self, suffix: str) -> Path | None:
        """Return the first output file whose name ends with ``suffix`` (e.g. ``".nc"``)."""
        for name in self.outputs:
            if name.endswith(suffix):
                return self.run_dir / name
        return None

    def to_dict(self) -> dict[str, Any]:
        """Return the outcome as JSON-ready data (paths as text, NaN as None)."""
        return {
            "name": self.name, "scene": str(self.scene), "run_dir": str(self.run_dir),
            "status": self.status, "speed_rev_s": json_ready(self.speed_rev_s),
            "elapsed_s": self.elapsed_s, "cpu_s": self.cpu_s, "reused": self.reused,
            "outputs": list(self.outputs), "metrics": json_ready(list(self.metrics)),
            "error": self.error.to_dict() if self.error else None,
            "warnings": [str(w) for w in self.warnings],
        }


@dataclass(frozen=True)
class _Run:
    """One planned run: its name, scene and report folder."""

    name: str
    scene: Path
    run_dir: Path


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
    bases = [_run_name(scene) for scene in unique.values()]
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


def _run_name(scene: Path) -> str:
    """Return a scene's run name before de-duplication (see :func:`plan_runs`)."""
    return re.sub(r"[_.-]?scene$", "", scene.stem) or scene.resolve().parent.name or "run"


def run_one(scene: str | Path, run_dir: str | Path, *, validate: ValidateFunction | None = None,
            name: str | None = None, force: bool = False) -> RunOutcome:
    """Validate one scene into ``run_dir``, or reuse its earlier outputs if they are up to date.

    This is the unit of work of a campaign; it runs in a worker process on a Dask cluster. It
    does not raise for problems of the run: any exception of the validation becomes an outcome
    with status ``"error"``.

    Parameters
    ----------
    scene : path
        The scene file.
    run_dir : path
        The run's report folder (created if needed).
    validate : callable, optional
        ``validate(scene, run_dir) -> RunReport``; default the rigval validation pipeline.
    name : str, optional
        Run name; default the name :func:`plan_runs` would give.
    force : bool
        Recompute even when the manifest says the outputs are up to date.

    Returns
    -------
    RunOutcome
        What happened to the run.
    """
    scene, run_dir = Path(scene), Path(run_dir)
    name = name or _run_name(scene)
    if not force:
        reused = _reuse(name, scene, run_dir)
        if reused is not None:
            logger.info("run %s is up to date; not recomputed", name)
            return reused
    validate = validate or _validate_with_pipeline
    start, cpu_start = time.perf_counter(), time.process_time()
    caught: list[warnings.WarningMessage] = []
    try:
        run_dir.mkdir(parents=True, exist_ok=True)
        (run_dir / MANIFEST_NAME).unlink(missing_ok=True)  # invalid until this run completes
        with _local_dask(), run_context(name), \
                warnings.catch_warnings(record=True) as caught:
            report = validate(scene, run_dir)
        outcome = RunOutcome(
            name=name, scene=scene, run_dir=run_dir,
            status="passed" if report.passed else "failed",
            metrics=tuple(json_ready(dict(row)) for row in report.metrics),
            speed_rev_s=json_ready(report.speed_rev_s),
            outputs=tuple(os.path.relpath(path, run_dir) for path in report.outputs),
            elapsed_s=time.perf_counter() - start, cpu_s=time.process_time() - cpu_start,
            warnings=_run_warnings(caught),
        )
        _write_manifest(outcome, report.inputs)
    except Exception as error:  # one run's failure must not stop the campaign
        logger.info("run %s: %s: %s", name, type(error).__name__, error)
        return RunOutcome(name=name, scene=scene, run_dir=run_dir, status="error",
                          elapsed_s=time.perf_counter() - start,
                          cpu_s=time.process_time() - cpu_start,
                          error=RunError.from_exception(error), warnings=_run_warnings(caught))
    return outcome


def _run_warnings(caught: Sequence[warnings.WarningMessage]) -> tuple[RunWarning, ...]:
    """Return recorded warnings as :class:`RunWarning` (classes that do not pickle: UserWarning)."""
    kept = []
    for item in caught:
        category = item.category if _picklable(item.category) else UserWarning
        kept.append(RunWarning(category, " ".join(str(item.message).split())))
    return tuple(kept)


def _raise_again(outcome: RunOutcome) -> None:
    """Raise a run's recorded warnings in this process, each naming the run.

    ``warn_explicit`` with a fresh registry shows each one even when another run raised the same
    text (the default filter shows a message once per place); the filters still apply.
    """
    with run_context(outcome.name):
        for item in outcome.warnings:
            warnings.warn_explicit(item.message, item.category, f"run {outcome.name}", 0,
                                   registry={})


def _local_dask() -> contextlib.AbstractContextManager[Any]:
    """Keep a validation's own xarray/dask work inside its process.

    On a Dask worker, xarray takes the cluster's scheduler as the one to use and guards every
    netCDF variable it writes with a distributed lock, one round trip to the scheduler each:
    measured, a run took 7.2 s on a worker against 4.9 s with the synchronous scheduler. A run
    is one task on one worker thread, so the synchronous scheduler and thread locks are right.
    """
    try:
        import dask
    except ImportError:
        return contextlib.nullcontext()
    return dask.config.set(scheduler="synchronous")


def run_campaign(
    scenes: Sequence[str | Path],
    out_dir: str | Path,
    *,
    scheduler: str | Client | None = None,
    workers: int | None = None,
    validate: ValidateFunction | None = None,
    force: bool = False,
    on_result: Callable[[RunOutcome], None] | None = None,
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
    runs = [_Run(name, scene, run_dir) for name, scene, run_dir in plan_runs(scenes, out_dir)]
    notify = on_result or (lambda outcome: None)
    if not runs:
        return []
    if scheduler is None:
        scheduler = "local" if dask_available() else "processes"
    if scheduler == "processes":
        n_workers = min(workers or os.cpu_count() or 1, len(runs))
        if n_workers > 1:
            from rigval.validation.campaign.processes import run_in_processes

            return _collect(runs, run_in_processes(runs, validate, force, n_workers), notify)
        scheduler = "none"
    if scheduler == "none":
        return _collect(runs, (run_one(run.scene, run.run_dir, validate=validate, name=run.name,
                                       force=force) for run in runs), notify)
    with _client(scheduler, workers, len(runs), out_dir / WORKER_LOG_NAME) as client:
        return _collect(runs, _run_on_cluster(client, runs, validate, force), notify)


def _collect(runs: Sequence[_Run], completed: Generator[RunOutcome, None, None],
             notify: Callable[[RunOutcome], None]) -> list[RunOutcome]:
    """Raise each outcome's warnings again and notify, in completion order; return scene order."""
    outcomes = {}
    with contextlib.closing(completed):  # on Ctrl-C at once: the schedulers clean up
        for outcome in completed:
            outcomes[outcome.name] = outcome
            _raise_again(outcome)
            notify(outcome)
    return [outcomes[run.name] for run in runs]


def _run_on_cluster(client: Client, runs: Sequence[_Run], validate: ValidateFunction | None,
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


def _reuse(name: str, scene: Path, run_dir: Path) -> RunOutcome | None:
    """Return the recorded outcome if the run's manifest says its outputs are up to date."""
    try:
        manifest = json.loads((run_dir / MANIFEST_NAME).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    try:
        stale = _stale_reason(manifest, scene, run_dir)
        result = manifest["result"]
        outcome = RunOutcome(name=name, scene=scene, run_dir=run_dir, status=result["status"],
                             metrics=tuple(result["metrics"]), speed_rev_s=result["speed_rev_s"],
                             outputs=tuple(manifest["outputs"]), elapsed_s=result["elapsed_s"],
                             cpu_s=result["cpu_s"], reused=True)
    except (KeyError, TypeError, AttributeError):
        stale = "the manifest is not in the expected format"
    except OSError as error:
        stale = f"the outputs cannot be checked: {error}"
    if stale:
        logger.info("run %s is recomputed: %s", name, stale)
        return None
    return outcome


def _stale_reason(manifest: Mapping[str, Any], scene: Path, run_dir: Path) -> str | None:
    """Return why a manifest's outputs are out of date, or None if they are up to date."""
    if manifest["schema"] != _MANIFEST_SCHEMA:
        return f"manifest schema {manifest['schema']!r} is not {_MANIFEST_SCHEMA!r}"
    if manifest["rigval_version"] != _rigval_version():
        return f"rigval {manifest['rigval_version']} wrote it, this is {_rigval_version()}"
    for relative, size in manifest["outputs"].items():
        path = run_dir / relative
        if not path.is_file() or path.stat().st_size != size:
            return f"output {relative} is missing or incomplete"
    recorded = [(scene, manifest["scene_sha256"])]
    recorded += [(scene.parent / name, digest) for name, digest in manifest["inputs"].items()]
    for path, digest in recorded:
        try:
            current = file_sha256(path)
        except OSError:
            return f"input {path} cannot be read"
        if current != digest:
            return f"input {path} changed"
    return None


def _write_manifest(outcome: RunOutcome, inputs: Sequence[Path]) -> None:
    """Record what a completed run read and wrote (written last, atomically)."""
    base = outcome.scene.parent
    manifest = {
        "schema": _MANIFEST_SCHEMA,
        "rigval_version": _rigval_version(),
        "written": datetime.now(UTC).isoformat(timespec="seconds"),
        "scene": str(outcome.scene),
        "scene_sha256": file_sha256(outcome.scene),
        "inputs": {os.path.relpath(path, base): file_sha256(path) for path in inputs},
        "outputs": {name: (outcome.run_dir / name).stat().st_size for name in outcome.outputs},
        "result": {"status": outcome.status, "metrics": list(outcome.metrics),
                   "speed_rev_s": outcome.speed_rev_s, "elapsed_s": outcome.elapsed_s,
                   "cpu_s": outcome.cpu_s},
    }
    target = outcome.run_dir / MANIFEST_NAME
    write_text_atomic(target, json.dumps(manifest, indent=1, allow_nan=False))


def _picklable(error: BaseException) -> bool:
    """Return whether an exception survives a pickle round trip (rigval errors always do)."""
    try:
        pickle.loads(pickle.dumps(error))
    except Exception:  # any failure means: do not ship the object
        return False
    return True


def _validate_with_pipeline(scene: Path, run_dir: Path) -> RunReport:
    """Validate one scene with rigval's pipeline and write its report (the default)."""
    from rigval.validation.report.validate import validate_scene

    result = validate_scene(scene, run_dir)
    return RunReport(passed=result.passed, metrics=tuple(result.metric_rows()),
                     outputs=tuple(result.outputs), inputs=tuple(result.inputs),
                     speed_rev_s=result.speed_rev_s)
