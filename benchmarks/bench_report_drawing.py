"""CPU time of building one run report page, and of each of its figures.

Validates the first shipped sample run once, builds its report page (``_build_page``: tables
and every figure rendered to PNG) once to warm up and then REPEATS times, and prints the
minimum and median CPU time per page (``time.process_time``, this process only), then the CPU
time per figure (drawing the figure up to its ``Page.figure`` call, and rendering it there),
averaged over the repeats.

Usage: ``python benchmarks/bench_report_drawing.py [REPEATS]`` (default 5).
"""

from __future__ import annotations

import collections
import statistics
import sys
import time

from rigval.sample_data import shipped_runs
from rigval.validation.pipeline import run_scene
from rigval.validation.report import page as page_module
from rigval.validation.report.run_report import _build_page


def main(repeats: int) -> None:
    result = run_scene(shipped_runs()[0])
    _build_page(result)
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


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 5)
