"""``rigval demo --out DIR``: validate the sample runs shipped with rigval.

Each shipped run (:func:`rigval.sample_data.shipped_runs`, virtual-rig data at several speeds) is
validated into ``DIR/<run>/`` like ``rigval validate`` does, runs in parallel on the available
cores; ``DIR/index.html`` links the reports. Exit code 0 when every run meets its thresholds,
else 1.
"""

from __future__ import annotations

import argparse
import importlib
import os
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

__all__ = ["add_parser", "run", "validate_one"]


def add_parser(subparsers: Any) -> None:
    """Register the ``demo`` subcommand."""
    parser = subparsers.add_parser(
        "demo", help="validate the shipped sample runs and write their reports",
        description="Validate the sample runs shipped with rigval (virtual-rig data at several "
                    "speeds) and write one report folder per run plus an index page.",
        epilog="Exit codes: 0 all runs met their thresholds, 1 a threshold failed, 3 data "
               "error.")
    parser.add_argument("--out", type=Path, required=True, help="output folder (created)")
    parser.add_argument("--workers", type=int, default=None,
                        help="parallel runs (default: one per core, at most one per run)")
    parser.set_defaults(func=run)


def validate_one(scene: Path, out_dir: Path) -> dict[str, Any]:
    """Validate one scene into ``out_dir``; return a small picklable summary with its printout.

    Parameters
    ----------
    scene : pathlib.Path
        The scene file.
    out_dir : pathlib.Path
        Its report folder.
    """
    import io

    from rigval.validation.commands.validate import print_summary
    from rigval.validation.console import run_context
    from rigval.validation.pipeline import validate_scene

    start = time.perf_counter()
    with run_context(out_dir.name):
        result = validate_scene(scene, out_dir)
    text = io.StringIO()
    print_summary(result, out_dir, text)
    ratings = {c.name: c.scores.get("iso18571_periodic.rating") for c in result.comparisons}
    return {"run": out_dir.name, "title": result.scene.title, "passed": result.passed,
            "speed_rev_s": result.speed_rev_s, "cycles": result.n_cycles, "ratings": ratings,
            "seconds": time.perf_counter() - start, "summary": text.getvalue()}


def _index(out_dir: Path, rows: list[dict[str, Any]]) -> Path:
    """Write ``index.html`` linking every run's report."""
    from rigval.validation.report.page import Page, escape, format_value

    page = Page("rigval demo: the shipped sample runs",
                subtitle="PASSED" if all(r["passed"] for r in rows) else "FAILED",
                contents=False)
    page.section("Runs")
    page.paragraph("Virtual-rig runs with known truth, validated against the pendulum model. "
                   "Each row links the run's report; ratings are ISO/TS 18571 (periodic) of the "
                   "model against the measured mean.")
    names = list(dict.fromkeys(name for r in rows for name in r["ratings"]))
    head = '<th class="text">run</th>' + "".join(
        f"<th>{escape(h)}</th>" for h in ["speed [rev/s]", "revolutions", *names, "status"])
    body = []
    for r in rows:
        link = f'<a href="{escape(r["run"])}/report.html">{escape(r["title"])}</a>'
        cells = [f'<td class="text">{link}</td>', f"<td>{format_value(r['speed_rev_s'])}</td>",
                 f"<td>{r['cycles']}</td>"]
        cells += [f"<td>{format_value(r['ratings'].get(n))}</td>" for n in names]
        status = "pass" if r["passed"] else "fail"
        cells.append(f'<td class="text {"ok" if r["passed"] else "bad"}">{status}</td>')
        body.append("<tr>" + "".join(cells) + "</tr>")
    page.raw(f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table>")
    return page.write(out_dir / "index.html")


def run(args: argparse.Namespace) -> int:
    """Validate every shipped run; return 0 when all pass, else 1."""
    from rigval.acquisition.errors import DataError
    from rigval.sample_data import shipped_runs

    scenes = shipped_runs()
    if not scenes:
        raise DataError("no sample runs are shipped with this installation",
                        hint="reinstall rigval; the wheel carries sample_data/runs")
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    targets = [out / scene.name.removesuffix("_scene.toml") for scene in scenes]
    workers = args.workers or min(len(scenes), os.cpu_count() or 1)
    start = time.perf_counter()
    # imported once here: forked workers inherit the modules instead of importing them again
    importlib.import_module("rigval.validation.pipeline")
    importlib.import_module("rigval.validation.report.run_report")
    if workers > 1:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            rows = list(pool.map(validate_one, scenes, targets))
    else:
        rows = [validate_one(scene, target) for scene, target in zip(scenes, targets,
                                                                      strict=True)]
    for row in rows:
        print(row["summary"], end="")
    index = _index(out, rows)
    print(f"demo: {len(rows)} runs in {time.perf_counter() - start:.1f} s; open {index}")
    return 0 if all(r["passed"] for r in rows) else 1
