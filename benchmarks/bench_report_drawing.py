"""CPU time of building one run report page, and of each of its figures.

Validates the first shipped sample run once, builds its report page (``_build_page``: tables
and every figure rendered as the report embeds it, inline SVG) once to warm up and then
REPEATS times, and prints the minimum and median CPU time per page (``time.process_time``,
this process only), then the CPU time per figure (drawing the figure up to its
``Page.figure`` call, and rendering it there), averaged over the repeats.

With ``--formats``, the page is built alternately with every figure embedded as PNG (96 dpi,
as the report did before) and as inline SVG, REPEATS times each in one process, and the
minimum and median CPU time per page and the size of the page of each are printed.

With ``--against FILE``, FILE is another version of ``rigval/validation/report/plots.py`` (for
instance ``git show 132f4c9:validation/report/plots.py > /tmp/old_plots.py``): the page is then
built alternately with it and with the installed module, REPEATS times each in one process
(the order swapped every round, so that a change in the machine's load hits both alike), and
the minimum and median CPU time per page of each are printed.

Usage: ``python benchmarks/bench_report_drawing.py [REPEATS] [--against FILE | --formats]``
(default 5).
"""

from __future__ import annotations

import argparse
import collections
import functools
import importlib.util
import statistics
import time
from pathlib import Path

from rigval.sample_data import shipped_runs
from rigval.validation.pipeline import run_scene
from rigval.validation.report import page as page_module
from rigval.validation.report import plots, run_report
from rigval.validation.report.run_report import _build_page
from rigval.validation.results import ValidationResult


def per_figure(result: ValidationResult, repeats: int) -> None:
    """Print the CPU time per page and per figure."""
    seconds = collections.defaultdict(float)
    figure = page_module.Page.figure
    mark = [0.0]

    def timed_figure(self, fig, *, caption=None, **options):  # type: ignore[no-untyped-def]
        start = time.process_time()
        seconds[(caption or "figure")[:45], "draw"] += start - mark[0]
        figure(self, fig, caption=caption, **options)
        mark[0] = time.process_time()
        seconds[(caption or "figure")[:45], "render"] += mark[0] - start

    pages = []
    page_module.Page.figure = timed_figure  # type: ignore[method-assign]
    try:
        for _ in range(repeats):
            start = mark[0] = time.process_time()
            _build_page(result)
            pages.append(time.process_time() - start)
    finally:
        page_module.Page.figure = figure  # type: ignore[method-assign]
    print(f"report page of {result.scene.path.name}: CPU min {min(pages):.3f} s, "
          f"median {statistics.median(pages):.3f} s over {repeats} builds")
    print(f"figures: {sum(seconds.values()) / repeats:.3f} s CPU per page "
          "(draw: from the previous figure's end, tables in between included)")
    for (caption, part), total in sorted(seconds.items(), key=lambda kv: -kv[1]):
        print(f"{total / repeats:7.3f} s  {part:6s}  {caption}")


def against(result: ValidationResult, repeats: int, other: Path) -> None:
    """Print the CPU time per page with another plots module and with the installed one."""
    spec = importlib.util.spec_from_file_location("rigval.validation.report._plots_other",
                                                  other)
    if spec is None or spec.loader is None:
        raise SystemExit(f"cannot load {other} as a Python module")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    versions = {str(other): module, "installed": plots}
    times: dict[str, list[float]] = {name: [] for name in versions}
    try:
        for version in versions.values():  # warm up both
            run_report.plots = version
            _build_page(result)
        for round_ in range(repeats):
            order = list(versions.items())
            for name, version in order if round_ % 2 == 0 else order[::-1]:
                run_report.plots = version
                start = time.process_time()
                _build_page(result)
                times[name].append(time.process_time() - start)
    finally:
        run_report.plots = plots
    for name, values in times.items():
        print(f"{name}: CPU min {min(values):.3f} s, median {statistics.median(values):.3f} s "
              f"per page over {repeats} builds")


def formats(result: ValidationResult, repeats: int) -> None:
    """Print the CPU time and size of the page with PNG and with inline SVG figures."""
    figure = page_module.Page.figure
    times: dict[str, list[float]] = {"png": [], "svg": []}
    sizes = {}
    try:
        for round_ in range(repeats + 1):  # round 0 warms up
            for fmt in ("png", "svg") if round_ % 2 == 0 else ("svg", "png"):
                page_module.Page.figure = functools.partialmethod(figure, fmt=fmt)  # type: ignore[method-assign,assignment]
                start = time.process_time()
                page = _build_page(result)
                if round_:
                    times[fmt].append(time.process_time() - start)
                sizes[fmt] = len(page.render().encode())
    finally:
        page_module.Page.figure = figure  # type: ignore[method-assign]
    for fmt, values in times.items():
        print(f"{fmt}: CPU min {min(values):.3f} s, median {statistics.median(values):.3f} s "
              f"per page over {repeats} builds; page {sizes[fmt] / 1e6:.2f} MB")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("repeats", type=int, nargs="?", default=5)
    parser.add_argument("--against", type=Path, help="another version of report/plots.py")
    parser.add_argument("--formats", action="store_true", help="PNG against SVG figures")
    args = parser.parse_args()
    result = run_scene(shipped_runs()[0])
    if args.formats:
        formats(result, args.repeats)
    elif args.against:
        against(result, args.repeats, args.against)
    else:
        _build_page(result)
        per_figure(result, args.repeats)


if __name__ == "__main__":
    main()
