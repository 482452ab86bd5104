"""``rigval campaign SCENE... --out DIR``: validate many runs at once and summarise them.

Exit codes: 0 every run passed; 1 every run was validated but at least one missed a threshold;
3 at least one run could not be validated (its error is in the summary; the other runs still
completed); 2 a usage error (e.g. ``--scheduler`` needs Dask and it is not installed).
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from typing import TYPE_CHECKING, Any, TextIO

from rigval.validation.commands.common import add_command, add_out_option, scene_file

if TYPE_CHECKING:
    from rigval.validation.campaign.engine import RunOutcome

__all__ = ["add_parser", "run"]


def add_parser(subparsers: Any) -> None:
    """Register the ``campaign`` subcommand."""
    parser = add_command(
        subparsers, run, "campaign",
        help="validate many runs (scenes) at once, in parallel (on Dask if installed)",
        description="Validate every scene into OUT/<run>/ and write a campaign summary "
                    "(index.html, campaign_metrics.csv, campaign.json) beside them. Runs "
                    "whose inputs and outputs are unchanged since the last campaign are reused.",
        exit_codes="0 all passed, 1 some run failed its thresholds, 2 usage error, "
                   "3 some run could not be validated (the others still complete).",
    )
    parser.add_argument("scenes", nargs="+", type=scene_file, metavar="SCENE",
                        help="scene files, one per run")
    add_out_option(parser, "campaign folder")
    parser.add_argument("--title", default="rigval campaign", help="title of the summary page")
    parser.add_argument("--force", action="store_true",
                        help="recompute every run, even those that are up to date")
    parser.add_argument("--workers", type=_positive_int, metavar="N",
                        help="runs at a time: worker processes of the embedded Dask cluster or "
                             "child processes (default: CPUs, at most the runs; 1 child "
                             "process: the runs go one after the other in this process)")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help='"local" (default with Dask: an embedded cluster), "processes" '
                             '(default without Dask: a child process per run), "none" (one run '
                             'after the other here), or an existing cluster (tcp://host:8786)')
    parser.add_argument("--no-progress", action="store_true", help="no progress line")


def run(args: argparse.Namespace) -> int:
    """Run the campaign and return the exit code (see the module docstring)."""
    from rigval.validation.campaign.engine import (
        dask_available,
        run_campaign,
        stop_worker_processes,
    )
    from rigval.validation.campaign.report import run_reason, write_campaign_report
    from rigval.validation.console import interrupt_quietly, progress_display

    # Dask logs its cluster's start and stop at INFO; show that only with -vv. Importing
    # distributed (dask_available does) sets its loggers' levels, so this comes after.
    has_dask = dask_available()
    scheduler = args.scheduler or ("local" if has_dask else "processes")
    verbose = logging.getLogger().getEffectiveLevel() <= logging.DEBUG
    logging.getLogger("distributed").setLevel(logging.INFO if verbose else logging.WARNING)

    progress = _ProgressLine(len(args.scenes), sys.stderr,
                             enabled=not (args.no_progress or getattr(args, "quiet", False))
                             and sys.stderr.isatty())
    start = time.perf_counter()
    try:
        with progress_display(progress), interrupt_quietly(stop_worker_processes):
            outcomes = run_campaign(args.scenes, args.out, scheduler=args.scheduler,
                                    workers=args.workers, force=args.force,
                                    on_result=progress.update)
    finally:
        progress.close()
    many = args.workers or "one per CPU, at most one per run"
    workers = {"none": "1 (this process)", "local": many, "processes": many}.get(
        scheduler, "those of the cluster")
    details = {"scheduler": scheduler, "workers": workers,
               "wall time [s]": round(time.perf_counter() - start, 2)}
    files = write_campaign_report(outcomes, args.out, title=args.title, details=details)
    _print_runs(outcomes)
    errors = [o for o in outcomes if o.status == "error"]
    for outcome in outcomes:  # why each run that did not pass did not
        reason = run_reason(outcome)
        if reason:
            word = "error" if outcome.status == "error" else "failed"
            print(f"rigval: run {outcome.name} {word}: {reason}", file=sys.stderr)
    failed = sum(o.status == "failed" for o in outcomes)
    print(f"{len(outcomes) - failed - len(errors)} passed, {failed} failed, {len(errors)} errors; "
          f"summary: {files.html}")
    if errors:
        return 3
    return 1 if failed else 0


def _positive_int(text: str) -> int:
    """Parse a worker count (argparse type)."""
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive number of workers, got {value}")
    return value


def _print_runs(outcomes: list[RunOutcome]) -> None:
    """Print one line per run: name, status, speed, time, and the error class if any."""
    width = max([len(o.name) for o in outcomes] + [3])
    print(f"{'run':<{width}}  {'status':<6}  {'rev/s':>6}  {'time s':>7}  note")
    for o in outcomes:
        speed = "-" if o.speed_rev_s is None else f"{o.speed_rev_s:.3f}"
        note = o.error.kind if o.error else ("reused" if o.reused else "")
        print(f"{o.name:<{width}}  {o.status:<6}  {speed:>6}  {o.elapsed_s:7.1f}  {note}")


class _ProgressLine:
    """A one-line progress display over runs on a terminal (redrawn in place)."""

    def __init__(self, total: int, stream: TextIO, *, enabled: bool) -> None:
        self.total, self.stream, self.enabled = total, stream, enabled
        self.counts = {"passed": 0, "failed": 0, "error": 0}
        self.start = time.perf_counter()
        self._show()

    def clear(self) -> None:
        """Erase the line (a warning is printed in its place, then :meth:`redraw`)."""
        if self.enabled:
            self.stream.write("\r\033[K")
            self.stream.flush()

    def redraw(self) -> None:
        """Draw the line again."""
        self._show()

    def update(self, outcome: RunOutcome) -> None:
        """Count a finished run and redraw the line."""
        self.counts[outcome.status] += 1
        self._show()

    def _show(self) -> None:
        if not self.enabled:
            return
        done = sum(self.counts.values())
        elapsed = time.perf_counter() - self.start
        left = ""
        if 0 < done < self.total:
            left = f", ~{elapsed / done * (self.total - done):.0f} s left"
        width = 24
        filled = width * done // max(self.total, 1)
        self.stream.write(
            f"\rcampaign [{'#' * filled}{'.' * (width - filled)}] {done}/{self.total} runs "
            f"({self.counts['passed']} passed, {self.counts['failed']} failed, "
            f"{self.counts['error']} errors) {elapsed:.0f} s{left}   ")
        self.stream.flush()

    def close(self) -> None:
        """End the line."""
        if self.enabled:
            self.stream.write("\n")
            self.stream.flush()
