"""The campaign scheduler of the standard library: each run in a child process of its own.

Where the platform has ``fork`` (Linux) and this process runs one thread, a child is a fork of
this process and starts in milliseconds with its modules imported (with the default validation,
:data:`PIPELINE_MODULES` are imported first); otherwise (macOS, Windows, a multi-threaded caller,
where forking can deadlock) children start by ``forkserver``, whose server imports
:data:`PIPELINE_MODULES` once, or ``spawn``, and the validate function must be picklable. A child
runs one BLAS thread, ends on Ctrl-C without a traceback and sends its outcome through a pipe;
one that ends without sending it (killed by a signal, e.g. by the out-of-memory killer, or
crashed) becomes an error outcome of its run naming how it ended, and the other runs go on.
"""

from __future__ import annotations

import contextlib
import importlib
import logging
import multiprocessing
import os
import signal
import threading
from collections.abc import Generator, Sequence
from multiprocessing.connection import Connection, wait
from typing import TYPE_CHECKING

from rigval.acquisition.threads import single_blas_thread
from rigval.validation.campaign.runs import RunError, RunOutcome, run_one
from rigval.validation.report.drawing import DRAWING_MODULES, Drawers, hand_drawers

if TYPE_CHECKING:
    from multiprocessing.process import BaseProcess

    from rigval.validation.campaign.runs import PlannedRun, ValidateFunction

__all__ = ["PIPELINE_MODULES", "PLOTTING_MODULES", "WORKER_DIED", "preload_pipeline",
           "run_in_processes"]

logger = logging.getLogger(__name__)

#: Modules a validation imports, some only when it first needs them (the TDMS reader, netCDF4,
#: and dask.array if Dask is installed, which xarray imports when it first checks for dask
#: arrays: about 0.7 s of CPU alone).
PIPELINE_MODULES = ("rigval.validation.pipeline", "rigval.validation.run.validate",
                    "rigval.validation.commands.validate", "rigval.acquisition.reader",
                    "rigval.acquisition.tdms", "rigval.acquisition.text_csv",
                    "rigval.acquisition.lvm", "dask.array", "netCDF4", "threadpoolctl")
#: The plotting modules a run imports where it draws its figures itself (a run process
#: without drawers: a run's own process leaves them to its drawers).
PLOTTING_MODULES = ("matplotlib.backends.backend_agg", *DRAWING_MODULES)

#: ``RunError.kind`` of a run whose process ended without a result.
WORKER_DIED = "WorkerDied"


def start_method() -> str:
    """Return how to start the children: ``fork`` if it is safe here, else forkserver or spawn."""
    methods = multiprocessing.get_all_start_methods()
    if "fork" in methods and threading.active_count() == 1:
        return "fork"
    return "forkserver" if "forkserver" in methods else "spawn"


def preload_pipeline(*, plotting: bool = True) -> None:
    """Import :data:`PIPELINE_MODULES`: done before forking, once instead of once per child.

    ``plotting``: :data:`PLOTTING_MODULES` too; without, where drawers forked for the
    children draw their figures (:func:`run_in_processes`'s ``drawers``), which import them.
    """
    for name in (*PIPELINE_MODULES, *(PLOTTING_MODULES if plotting else ())):
        with contextlib.suppress(ModuleNotFoundError):  # dask.array without the parallel extra
            importlib.import_module(name)


def run_in_processes(runs: Sequence[PlannedRun], validate: ValidateFunction | None, force: bool,
                     workers: int, drawers: Sequence[Drawers] = ()
                     ) -> Generator[RunOutcome, None, None]:
    """Validate each run in a child process, ``workers`` at a time; yield outcomes as they end.

    ``validate`` and ``force`` are passed on to :func:`~rigval.validation.campaign.runs.run_one`.
    Outcomes come in completion order; when the caller stops early (Ctrl-C), the children still
    running are killed. ``drawers``: forked by this process (before it imported the pipeline)
    for the first runs' processes, one each (:func:`~rigval.validation.report.drawing.
    hand_drawers`): a drawer serves one process, as values it sent to a process that failed
    could reach the next one; the other runs draw in their own process.
    """
    method = start_method()
    if method == "fork" and validate is None:
        preload_pipeline()
    context = multiprocessing.get_context(method)
    if method == "forkserver":  # its server imports these once; its children have them
        context.set_forkserver_preload(["__main__", *PIPELINE_MODULES, *PLOTTING_MODULES])
    logger.info("%d runs in up to %d child processes (%s)", len(runs), workers, method)
    waiting = list(reversed(runs))
    unused = list(drawers)
    running: dict[Connection, tuple[PlannedRun, BaseProcess]] = {}
    try:
        while waiting or running:
            while waiting and len(running) < workers:
                run = waiting.pop()
                receiver, sender = context.Pipe(duplex=False)
                handed = unused.pop(0) if unused and method == "fork" else None
                process = context.Process(target=_child,
                                          args=(sender, run, validate, force, handed),
                                          name=f"rigval run {run.name}")
                process.start()
                sender.close()  # the child holds the only sending end: its exit means EOF
                running[receiver] = run, process
            for receiver in wait(list(running)):
                run, process = running[receiver]
                try:
                    outcome = receiver.recv()
                except EOFError:  # the child ended without sending its outcome
                    outcome = None
                except Exception as error:  # an outcome that cannot be unpickled here
                    outcome = _error(run, RunError.from_exception(error))
                del running[receiver]
                receiver.close()
                process.join()
                yield outcome or _error(run, _died(run, process))
    finally:
        for receiver, (_, process) in running.items():
            process.kill()
            process.join()
            receiver.close()


def _child(sender: Connection, run: PlannedRun, validate: ValidateFunction | None, force: bool,
           drawers: Drawers | None) -> None:
    """Validate one run in the child process and send its outcome to the parent."""
    if drawers is not None:
        hand_drawers(drawers)
    if signal.getsignal(signal.SIGINT) is not signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.SIG_DFL)  # Ctrl-C ends the child, no traceback
    # numpy started one BLAS thread per core before the fork: two children on two cores would
    # run four; the variables tell the child's own children
    os.environ["OMP_NUM_THREADS"] = os.environ["OPENBLAS_NUM_THREADS"] = "1"
    with single_blas_thread():
        outcome = run_one(run.scene, run.run_dir, validate=validate, name=run.name, force=force)
    with sender:
        try:
            sender.send(outcome)
        except Exception as error:  # e.g. a metric value that does not pickle
            sender.send(_error(run, RunError.from_exception(error)))


def _died(run: PlannedRun, process: BaseProcess) -> RunError:
    """Describe a child that ended without sending its run's outcome."""
    code = process.exitcode or 0
    names = {-number: number.name for number in signal.Signals}  # exit code -N: signal N
    how = (f"was killed by signal {names.get(code, -code)}" if code < 0
           else f"exited with code {code}")
    hint = ("SIGKILL usually means the system ran out of memory and the kernel's out-of-memory "
            "killer ended the largest process; run fewer runs at once (--workers 1)"
            if code == -signal.SIGKILL else "run it alone (--workers 1) to see if it recurs")
    return RunError(kind=WORKER_DIED, message=f"the process validating run {run.name} {how} "
                    "before it finished", where={"run": run.name, "process id": process.pid},
                    hint=hint, traceback="")


def _error(run: PlannedRun, error: RunError) -> RunOutcome:
    """Return an error outcome of ``run``."""
    return RunOutcome(name=run.name, scene=run.scene, run_dir=run.run_dir, status="error",
                      error=error)
