"""``rigval validate SCENE --out DIR``: validate one run and write its report folder.

Exit codes: 0 every threshold met, 1 a threshold failed, 2 a bad scene (the message names the
key), 3 a data error (unreadable file, alignment impossible, model failure).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any, TextIO

from rigval.validation.commands.common import add_command, add_out_option, add_scene_argument

__all__ = ["add_parser", "print_summary", "run"]


def add_parser(subparsers: Any) -> None:
    """Register the ``validate`` subcommand."""
    parser = add_command(
        subparsers, run, "validate",
        help="validate one run (a scene file) and write its report folder",
        description="Read the scene's data files, align them, solve the model for the compared "
                    "quantities, compute the metrics and write report.html, metrics.csv, "
                    "metrics.json, alignment.json and the run's netCDF file into --out.",
        exit_codes="0 all thresholds met, 1 a threshold failed, 2 bad scene, 3 data "
                   "error.")
    add_scene_argument(parser)
    add_out_option(parser, "report folder (created)")


def print_summary(result: Any, out_dir: Path, stream: TextIO | None = None) -> None:
    """Print the V&V 20 verdict, one line per comparison, the report path and pass/fail.

    Parameters
    ----------
    result : rigval.validation.results.ValidationResult
        The validation.
    out_dir : pathlib.Path
        Where its report was written.
    stream : file, optional
        Where to print; default standard output.
    """
    from rigval.validation.health import comparison_health
    from rigval.validation.verdict import failure_reasons, run_verdict

    stream = stream or sys.stdout
    print(run_verdict(result)["statement"], file=stream)
    print(f"{result.scene.title}: {result.n_cycles} revolutions at {result.speed_rev_s:.3f} "
          "rev/s", file=stream)
    width = max(len(c.name) for c in result.comparisons)
    for comparison in result.comparisons:
        scores = comparison.scores
        rating = scores.get("iso18571_periodic.rating", float("nan"))
        grade = scores.get("iso18571_periodic.grade", "")
        verdict = ("pass" if comparison.passed
                   else "FAIL: " + "; ".join(failure_reasons(comparison)))
        vv20 = ("error detected" if scores.get("vv20.curve.detected") else
                "not detected" if "vv20.curve.detected" in scores else "not computed")
        ratio = scores.get("vv20.curve.normalised_error", float("nan")) / scores.get(
            "vv20.curve.k", 2.0)
        health = "".join(f"; {f.line()}"
                         for f in comparison_health(comparison.spec, result.health))
        print(f"  {comparison.name:<{width}}  V&V 20 {vv20:<14} |E|/(k u_val) {ratio:5.2f}  "
              f"ISO rating {rating:.3f} {grade:<9}  "
              f"NRMSE {scores.get('nrmse', float('nan')):.4f}  {verdict}{health}", file=stream)
    print(f"report: {out_dir / 'report.html'}", file=stream)
    print("PASSED" if result.passed else "FAILED", file=stream)


def run(args: argparse.Namespace) -> int:
    """Validate the scene; return 0 when every threshold is met, else 1."""
    from rigval.validation.report.drawing import standby_drawers

    # the drawers are forked before the pipeline's imports (a second of one core's work): they
    # import what they draw with on the core idle meanwhile
    with standby_drawers() as drawers:
        from rigval.validation.run.validate import validate_scene

        result = validate_scene(args.scene, args.out, drawers)
    print_summary(result, args.out)
    return 0 if result.passed else 1
