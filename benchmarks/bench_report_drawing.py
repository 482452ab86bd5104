"""CPU time of building one run report page, and of each of its figure groups.

Validates the first shipped sample run once, builds its report page (``_build_page``: tables and
every figure drawn as the report embeds it, inline SVG text) once to warm up and then REPEATS
times, all in this process (no forked child, so that the CPU time is the page's whole cost), and
prints the minimum and median CPU time per page (``time.process_time``), then the CPU time of
each figure group of :func:`rigval.validation.report.run_report.start_figures`, averaged over
the repeats.

With ``--against FILE``, FILE is another version of ``rigval/validation/report/plots.py`` (for
instance ``git show 132f4c9:validation/report/plots.py > /tmp/old_plots.py``): the page is then
built alternately with it and with the installed module, REPEATS times each in one process
(the order swapped every round, so that a change in the machine's load hits both alike), and
the minimum and median CPU time per page of each are printed.

Usage: ``python benchmarks/bench_report_drawing.py [REPEATS] [--against FILE]`` (default 5).
"""

from __future__ import annotations

import argparse
import collections
import importlib.util
import statistics
import sys
import time
from pathlib import Path

from rigval.sample_data import shipped_runs
from rigval.validation.diagnosis.explain import attach_diagnosis
from rigval.validation.pipeline import run_scene
from rigval.validation.report import figure_groups, plots, run_report
from rigval.validation.results import ValidationResult

PLOTS = "rigval.validation.report.plots"


def _page_seconds(result: ValidationResult) -> float:
    """CPU time of one page built in this process, its figures included."""
    start = time.process_time()
    run_report._build_page(result, run_report.start_figures(result))
    return time.process_time() - start


def per_group(result: ValidationResult, repeats: int) -> None:
    """Print the CPU time per page and per figure group."""
    pages = [_page_seconds(result) for _ in range(repeats)]
    print(f"report page of {result.scene.path.name}: CPU min {min(pages):.3f} s, "
          f"median {statistics.median(pages):.3f} s over {repeats} builds")
    seconds: dict[str, float] = collections.defaultdict(float)
    for _ in range(repeats):
        data = run_report._data(result)
        for name in figure_groups.RUN_GROUPS:
            start = time.process_time()
            figure_groups.draw_figure_groups((data[name][0],), (name,))
            seconds[name] += time.process_time() - start
    print(f"figures: {sum(seconds.values()) / repeats:.3f} s CPU per page; by group:")
    for name, total in sorted(seconds.items(), key=lambda kv: -kv[1]):
        print(f"{total / repeats:7.3f} s  {name}")


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
            sys.modules[PLOTS] = version
            _page_seconds(result)
        for round_ in range(repeats):
            order = list(versions.items())
            for name, version in order if round_ % 2 == 0 else order[::-1]:
                sys.modules[PLOTS] = version
                times[name].append(_page_seconds(result))
    finally:
        sys.modules[PLOTS] = plots
    for name, values in times.items():
        print(f"{name}: CPU min {min(values):.3f} s, median {statistics.median(values):.3f} s "
              f"per page over {repeats} builds")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("repeats", type=int, nargs="?", default=5)
    parser.add_argument("--against", type=Path, help="another version of report/plots.py")
    args = parser.parse_args()
    result = attach_diagnosis(run_scene(shipped_runs()[0]))
    if args.against:
        against(result, args.repeats, args.against)
    else:
        _page_seconds(result)
        per_group(result, args.repeats)


if __name__ == "__main__":
    main()
