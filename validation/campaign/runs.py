"""One run of a campaign: validate a scene, describe the outcome, record it for resume.

:func:`run_one` is the unit of work of every scheduler (:mod:`~rigval.validation.campaign.engine`
in this process or on Dask, :mod:`~rigval.validation.campaign.processes` in a child process). It
never raises for a problem of its run: a bad file, a failed alignment or even a bug in rigval
becomes an outcome with status ``"error"`` and a :class:`RunError` (class, message, where, hint,
traceback). rigval's errors pickle with their fields, so the original exception object crosses the
process boundary intact. The run's warnings are collected where it runs (:class:`RunWarning` in
its outcome); the campaign raises them again in its own process.

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
import os
import pickle
import re
import time
import traceback
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, Literal

from rigval.acquisition.errors import RigvalError
from rigval.acquisition.json_values import json_ready
from rigval.acquisition.outputs import write_text_atomic
from rigval.acquisition.schema import file_sha256
from rigval.validation.console import run_context
from rigval.validation.version import rigval_version as _rigval_version

__all__ = [
    "MANIFEST_NAME",
    "PlannedRun",
    "RunError",
    "RunOutcome",
    "RunReport",
    "RunWarning",
    "ValidateFunction",
    "default_run_name",
    "run_one",
    "run_reason",
]

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


def run_reason(outcome: RunOutcome, *, limit: int = 3) -> str:
    """Return why a run did not pass, in one line ("" for a run that passed).

    Parameters
    ----------
    outcome : RunOutcome
        The run.
    limit : int
        Missed thresholds listed before "and N more".

    Returns
    -------
    str
        For an error its class, message and place; for a failed run the missed thresholds
        (comparison, metric, value and what it needed).
    """
    if outcome.error is not None:
        where = ", ".join(f"{k}: {v}" for k, v in outcome.error.where.items())
        text = " ".join(f"{outcome.error.kind}: {outcome.error.message}".split())
        return text + (f" ({where})" if where else "")
    missed = [row for row in outcome.metrics
              if row.get("row", "model") == "model" and row.get("passed") is False]
    if outcome.status != "failed" and not missed:
        return ""
    parts = []
    for row in missed[:limit]:
        value = row.get("value")
        shown = f"{value:.4g}" if isinstance(value, int | float) else str(value)
        parts.append(f"{row.get('comparison')} {row.get('metric')} {shown} "
                     f"(needs {row.get('threshold')})")
    if len(missed) > limit:
        parts.append(f"and {len(missed) - limit} more")
    return "missed " + "; ".join(parts) if parts else "a threshold was missed"


@dataclass(frozen=True)
class PlannedRun:
    """One planned run: its name, scene and report folder."""

    name: str
    scene: Path
    run_dir: Path


def default_run_name(scene: Path) -> str:
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
    name = name or default_run_name(scene)
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
            # every warning of this run is recorded, whatever filters or "once" registries
            # earlier work in this process left behind
            warnings.simplefilter("always")
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
    """Return recorded warnings as :class:`RunWarning`, each distinct one once, in order.

    Classes that do not pickle become UserWarning.
    """
    kept: dict[RunWarning, None] = {}
    for item in caught:
        category = item.category if _picklable(item.category) else UserWarning
        kept.setdefault(RunWarning(category, " ".join(str(item.message).split())))
    return tuple(kept)


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
    from rigval.validation.run.validate import validate_scene

    result = validate_scene(scene, run_dir)
    return RunReport(passed=result.passed, metrics=tuple(result.metric_rows()),
                     outputs=tuple(result.outputs), inputs=tuple(result.inputs),
                     speed_rev_s=result.speed_rev_s)
