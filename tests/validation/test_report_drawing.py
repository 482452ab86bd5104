"""Figures drawn by a forked child equal those drawn in one process, and failures fall back.

The reference is the plain route: every figure drawn in this process by ``svg_text``, one after
the other.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure

from rigval.validation.beside import can_fork
from rigval.validation.report import drawing
from rigval.validation.report.page import Page, svg_text

REPO = Path(__file__).resolve().parents[2]


def _curves(seed: int, count: int):
    """Yield ``count`` figures redrawn into one reused figure, as the report's groups do."""
    rng = np.random.default_rng(seed)
    fig = Figure(figsize=(4, 3))
    ax = fig.add_subplot()
    for k in range(count):
        for line in list(ax.lines):
            line.remove()
        ax.plot(np.cumsum(rng.standard_normal(200)), lw=0.8)
        ax.set_title(f"curve {seed}.{k}: \u03c6F [deg]")
        ax.relim()
        ax.autoscale_view()
        yield fig


def _groups():
    return [lambda: _curves(1, 3), lambda: [next(_curves(2, 1))], lambda: _curves(3, 2), list]


def _plain():
    return [[svg_text(fig) for fig in group()] for group in _groups()]


def test_texts_equal_the_plain_route_for_every_choice_of_background_groups():
    plain = _plain()
    assert [len(texts) for texts in plain] == [3, 1, 2, 0]
    for background in ([], [0], [1, 3], [0, 1, 2, 3]):
        assert drawing.draw_svgs(_groups(), background=background) == plain


def _in_a_fresh_process(check: str) -> None:
    """Run ``check`` of this module in a new interpreter; skip where it cannot fork.

    A new interpreter runs one thread; this test process may not: an earlier test (a Dask
    cluster) can leave threads behind, and with them ``beside`` rightly draws here.
    """
    code = f"from tests.validation import test_report_drawing as t; t.{check}()"
    done = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True,
                          text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stderr
    if "no fork" in done.stdout:
        pytest.skip("no fork here: no fork start method or one CPU")


def _drawn_by_another_process() -> None:
    if not can_fork():
        print("no fork")
        return

    def where():
        fig = Figure(figsize=(2, 1))
        fig.text(0.1, 0.5, f"pid {os.getpid()}")
        return [fig]

    here, away = drawing.draw_svgs([where, where], background=[1])
    assert f"pid {os.getpid()}" in here[0]
    assert "pid " in away[0] and f"pid {os.getpid()}" not in away[0]


def _failing_child_drawn_here() -> None:
    if not can_fork():
        print("no fork")
        return
    parent = os.getpid()

    def fails_away():
        if os.getpid() != parent:
            raise RuntimeError("only in the child")
        return _curves(1, 3)

    groups = _groups()
    groups[0] = fails_away
    assert drawing.draw_svgs(groups, background=[0, 2]) == _plain()


def test_background_groups_are_drawn_by_another_process():
    _in_a_fresh_process("_drawn_by_another_process")


def test_a_group_failing_in_the_child_is_drawn_again_here():
    _in_a_fresh_process("_failing_child_drawn_here")


def test_an_error_of_a_group_shows_in_this_process():
    def broken():
        raise ValueError("no data to draw")

    with pytest.raises(ValueError, match="no data to draw"):
        drawing.draw_svgs([*_groups(), broken], background=[4])


def test_a_page_embeds_a_drawn_text_as_it_embeds_the_figure():
    fig = next(_curves(5, 1))
    direct, drawn = Page("t", figure_format="svg"), Page("t", figure_format="svg")
    direct.figure(fig, caption="c")
    drawn.figure(svg_text(fig), caption="c")
    assert direct._parts == drawn._parts
