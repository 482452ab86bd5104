"""``rigval demo --out DIR``: validate the sample runs shipped with rigval.

The shipped runs (:func:`rigval.sample_data.shipped_runs`, virtual-rig data at several speeds)
form a campaign (:func:`rigval.validation.campaign.engine.run_campaign`): each run is validated
into ``DIR/<run>/`` like ``rigval validate`` does, each in a process of its own forked from
this one, one per core (``--workers 1``: one after the other in this process), and a run whose
inputs and outputs are unchanged since an earlier demo is reused. ``DIR/index.html`` (a
:class:`~rigval.validation.report.page.Page`) links the reports. Exit code 0 when every run
meets its thresholds, 1 when one misses a threshold, 3 when one cannot be validated.
"""

from __future__ import annotations

import argparse
import atexit
import gc
import io
import json
import sys
import time
import tomllib
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rigval.validation.commands.common import add_command, add_out_option

if TYPE_CHECKING:
    from rigval.validation.campaign.engine import RunOutcome, RunReport

__all__ = ["SUMMARY_NAME", "add_parser", "run", "validate_one"]

#: The printed summary of a run (``rigval validate``'s console output), kept in its folder.
SUMMARY_NAME = "summary.txt"
#: The score shown per comparison in the index page.
_RATING = "iso18571_periodic.rating"


def add_parser(subparsers: Any) -> None:
    """Register the ``demo`` subcommand."""
    parser = add_command(
        subparsers, run, "demo", help="validate the shipped sample runs and write their reports",
        description="Validate the sample runs shipped with rigval (virtual-rig data at several "
                    "speeds) and write one report folder per run plus an index page.",
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
    from rigval.validation.report.validate import validate_scene

    result = validate_scene(scene, out_dir)
    text = io.StringIO()
    print_summary(result, out_dir, text)
    summary = write_text_atomic(out_dir / SUMMARY_NAME, text.getvalue())
    return RunReport(passed=result.passed, metrics=tuple(result.metric_rows()),
                     outputs=(*result.outputs, summary), inputs=tuple(result.inputs),
                     speed_rev_s=result.speed_rev_s)


def _title(outcome: RunOutcome) -> str:
    """Return the scene's title (its ``title`` key), or the run name without one."""
    try:
        title = tomllib.loads(outcome.scene.read_text(encoding="utf-8")).get("title")
    except (OSError, ValueError):  # it was validated: only a file changed since could fail
        title = None
    return title if isinstance(title, str) and title else outcome.name


def _cycles(outcome: RunOutcome) -> int | None:
    """Return the run's number of revolutions from its ``metrics.json`` (None without one)."""
    path = outcome.output("metrics.json")
    try:
        return int(json.loads(path.read_text(encoding="utf-8"))["cycles"]) if path else None
    except (OSError, ValueError, KeyError, TypeError):
        return None


def _index(out_dir: Path, outcomes: Sequence[RunOutcome]) -> Path:
    """Write ``index.html``: one row per run, linking its report."""
    from rigval.validation.report.page import Link, Page

    passed = all(o.status == "passed" for o in outcomes)
    page = Page("rigval demo: the shipped sample runs",
                subtitle="PASSED" if passed else "FAILED", contents=False)
    page.section("Runs")
    page.paragraph("Virtual-rig runs with known truth, validated against the pendulum model. "
                   "Each row links the run's report; ratings are ISO/TS 18571 (periodic) of the "
                   "model against the measured mean.")
    rows = []
    for outcome in outcomes:
        ratings = {m["comparison"]: m["value"] for m in outcome.metrics
                   if m.get("row") == "model" and m.get("metric") == _RATING}
        report = outcome.output("report.html")
        title = _title(outcome)
        rows.append({"run": Link(title, f"{outcome.name}/report.html") if report else title,
                     "speed [rev/s]": outcome.speed_rev_s, "revolutions": _cycles(outcome),
                     **ratings,
                     "status": {"passed": "pass", "failed": "fail"}.get(outcome.status,
                                                                        "error")})
    page.table(rows)
    return page.write(out_dir / "index.html")


def run(args: argparse.Namespace) -> int:
    """Validate every shipped run; return 0 when all pass, 1 when one fails, 3 on an error."""
    from rigval.acquisition.errors import DataError
    from rigval.sample_data import shipped_runs
    from rigval.validation.campaign.engine import run_campaign, stop_worker_processes
    from rigval.validation.campaign.processes import preload_pipeline
    from rigval.validation.campaign.report import run_reason
    from rigval.validation.console import interrupt_quietly

    # The interpreter's exit would walk the objects of every imported module (numpy, scipy,
    # xarray, matplotlib, rigval) looking for garbage: 0.4-0.5 s. Frozen, they are skipped.
    atexit.register(gc.freeze)
    scenes = shipped_runs()
    if not scenes:
        raise DataError("no sample runs are shipped with this installation",
                        hint="reinstall rigval; the wheel carries sample_data/runs")
    start = time.perf_counter()
    # a child process per run (forked, so faster than a Dask cluster's start, also with Dask)
    in_process = args.workers == 1 or len(scenes) == 1
    if not in_process:
        preload_pipeline()  # once here, not in each forked process
    with interrupt_quietly(stop_worker_processes):
        outcomes = run_campaign(scenes, args.out, scheduler="none" if in_process else "processes",
                                workers=args.workers, validate=validate_one, force=args.force)
    for outcome in outcomes:
        summary = outcome.output(SUMMARY_NAME)
        if summary is not None:
            print(summary.read_text(encoding="utf-8"), end="")
        reason = run_reason(outcome)
        if outcome.status == "error":
            print(f"rigval: run {outcome.name} error: {reason}", file=sys.stderr)
    index = _index(Path(args.out), outcomes)
    print(f"demo: {len(outcomes)} runs in {time.perf_counter() - start:.1f} s; open {index}")
    if any(o.status == "error" for o in outcomes):
        return 3
    return 0 if all(o.status == "passed" for o in outcomes) else 1
