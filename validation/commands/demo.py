"""``rigval demo --out DIR``: validate the sample runs shipped with rigval.

The shipped runs (:func:`rigval.sample_data.shipped_runs`, virtual-rig data at several speeds)
form a campaign (:func:`rigval.validation.campaign.engine.run_campaign`): each run is validated
into ``DIR/<run>/`` like ``rigval validate`` does, each in a process of its own forked from
this one, one per core (``--workers 1``: one after the other in this process), and a run whose
inputs and outputs are unchanged since an earlier demo is reused. ``DIR/index.html`` is the
campaign summary page (:func:`rigval.validation.campaign.report.write_campaign_report`, the
page ``rigval campaign`` writes): the V&V 20 verdict, one row per run linking its report, the
metrics over the runs. Exit code 0 when every run meets its thresholds, 1 when one misses a
threshold, 3 when one cannot be validated.

Drawers (:class:`rigval.validation.beside.Standby` children) are forked first, before this
process imports the pipeline, and import matplotlib on the core left idle meanwhile: with runs
in processes one draws each run's figures (:func:`rigval.validation.report.drawing.
hand_drawers`) and the last the summary page's, so this process and the runs' processes never
import matplotlib.
"""

from __future__ import annotations

import argparse
import io
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rigval.validation.commands.common import add_command, add_out_option

if TYPE_CHECKING:
    from rigval.validation.campaign.engine import RunOutcome, RunReport
    from rigval.validation.report.drawing import Drawers

__all__ = ["SUMMARY_NAME", "add_parser", "run", "validate_one"]

#: The printed summary of a run (``rigval validate``'s console output), kept in its folder.
SUMMARY_NAME = "summary.txt"


def add_parser(subparsers: Any) -> None:
    """Register the ``demo`` subcommand."""
    parser = add_command(
        subparsers, run, "demo", help="validate the shipped sample runs and write their reports",
        description="Validate the sample runs shipped with rigval (virtual-rig data at several "
                    "speeds) and write one report folder per run plus the campaign summary page "
                    "(index.html, as rigval campaign writes it).",
        exit_codes="0 all runs met their thresholds, 1 a threshold failed, 3 data error.")
    add_out_option(parser)
    parser.add_argument("--workers", type=int, default=None,
                        help="parallel runs (default: one per core, at most one per run; 1: "
                             "one after the other in this process)")
    parser.add_argument("--force", action="store_true",
                        help="recompute runs whose earlier outputs in --out are up to date")


def validate_one(scene: Path, out_dir: Path) -> RunReport:
    """Validate one scene into ``out_dir`` and keep its printed summary there.

    The campaign's validate function (module level, so that a worker process can call it):
    the pipeline's validation plus :data:`SUMMARY_NAME`, the lines ``rigval validate`` prints.

    Parameters
    ----------
    scene : pathlib.Path
        The scene file.
    out_dir : pathlib.Path
        Its report folder.

    Returns
    -------
    RunReport
        What the campaign records of the run (the summary file among its outputs).
    """
    from rigval.acquisition.outputs import write_text_atomic
    from rigval.validation.campaign.engine import RunReport
    from rigval.validation.commands.validate import print_summary
    from rigval.validation.run.validate import validate_scene

    result = validate_scene(scene, out_dir)
    text = io.StringIO()
    print_summary(result, out_dir, text)
    summary = write_text_atomic(out_dir / SUMMARY_NAME, text.getvalue())
    return RunReport(passed=result.passed, metrics=tuple(result.metric_rows()),
                     outputs=(*result.outputs, summary), inputs=tuple(result.inputs),
                     speed_rev_s=result.speed_rev_s)


def run(args: argparse.Namespace) -> int:
    """Validate every shipped run; return 0 when all pass, 1 when one fails, 3 on an error."""
    from rigval.acquisition.errors import DataError
    from rigval.sample_data import shipped_runs
    from rigval.validation.beside import Standby
    from rigval.validation.report.drawing import DRAWING_MODULES, Drawers

    scenes = shipped_runs()
    if not scenes:
        raise DataError("no sample runs are shipped with this installation",
                        hint="reinstall rigval; the wheel carries sample_data/runs")
    start = time.perf_counter()
    # a child process per run (forked, so faster than a Dask cluster's start, also with Dask)
    workers = 1 if args.workers == 1 else min(args.workers or os.cpu_count() or 1, len(scenes))
    # forked first, while this process has imported little: the drawers import matplotlib on
    # the core left idle while this process imports the pipeline; one draws each run's
    # figures (runs in processes: one drawer per run, as a drawer serves one process and a run
    # without one would import matplotlib itself), the last the summary page's
    standbys = Standby.group(len(scenes) + 1 if workers > 1 else 1,
                             (*DRAWING_MODULES, "rigval.validation.campaign.figure_groups",
                              "rigval.validation.campaign.speed_plot"))
    *runs_drawers, summary_drawer = Drawers(standbys).each()
    with standbys[0]:  # closing the first closes the others
        outcomes = _validate_runs(args, scenes, workers, runs_drawers)
        from rigval.validation.campaign.report import write_campaign_report
        from rigval.validation.campaign.runs import run_reason

        for outcome in outcomes:
            summary = outcome.output(SUMMARY_NAME)
            if summary is not None:
                print(summary.read_text(encoding="utf-8"), end="")
            if outcome.status == "error":
                print(f"rigval: run {outcome.name} error: {run_reason(outcome)}",
                      file=sys.stderr)
        details = {"runs": "the virtual-rig runs shipped with rigval (known truth), validated "
                           "against the pendulum model",
                   "workers": "1 (this process)" if workers == 1 else args.workers or
                   "one per CPU, at most one per run",
                   "wall time [s]": round(time.perf_counter() - start, 2)}
        files = write_campaign_report(outcomes, args.out, title="rigval demo: the shipped "
                                      "sample runs", details=details,
                                      drawers=summary_drawer)
    print(f"demo: {len(outcomes)} runs in {time.perf_counter() - start:.1f} s; open {files.html}")
    if any(o.status == "error" for o in outcomes):
        return 3
    return 0 if all(o.status == "passed" for o in outcomes) else 1


def _validate_runs(args: argparse.Namespace, scenes: Sequence[Path], workers: int,
                   drawers: Sequence[Drawers]) -> list[RunOutcome]:
    """Validate the scenes, ``workers`` at a time (1: here).

    The runs' processes draw their figures with ``drawers``, one each.
    """
    from rigval.validation.campaign.engine import run_campaign, stop_worker_processes
    from rigval.validation.campaign.processes import preload_pipeline
    from rigval.validation.console import interrupt_quietly

    if workers > 1:
        preload_pipeline(plotting=not drawers)  # once here, not in each forked process
    with interrupt_quietly(stop_worker_processes):
        return run_campaign(scenes, args.out, scheduler="processes" if workers > 1 else "none",
                            workers=workers, validate=validate_one, force=args.force,
                            drawers=drawers)
