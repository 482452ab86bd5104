"""Figures drawn by standby drawers equal those drawn in one process, and failures fall back.

The reference is the plain route: every figure drawn in this process by ``svg_text``, one after
the other.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
from matplotlib.figure import Figure

from rigval.validation.report import drawing
from rigval.validation.report.page import Page, svg_text
from tests.validation.fresh_process import REPO, no_fork_here, run_in_a_fresh_process

#: Figure groups: name -> (seed, figures).
GROUPS = {"three": (1, 3), "one": (2, 1), "two": (3, 2), "none": (4, 0)}


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


def draw_curves(inputs: dict[str, tuple[int, int]], names: tuple[str, ...]) -> list[list[str]]:
    """A group function: each named group's curves."""
    return [drawing.draw_texts(_curves(*inputs[name])) for name in names]


def draw_where(inputs: int, names: tuple[str, ...]) -> list[list[str]]:
    """A group function whose figure names the process that drew it."""
    fig = Figure(figsize=(2, 1))
    fig.text(0.1, 0.5, f"pid {os.getpid()}")
    return [[svg_text(fig)] for _ in names]


def fails_away(parent: int, names: tuple[str, ...]) -> list[list[str]]:
    """Fail in any process but ``parent``; draw the curves there."""
    if os.getpid() != parent:
        raise RuntimeError("only in the child")
    return draw_curves(GROUPS, names)


def draw_broken(inputs: object, names: tuple[str, ...]) -> list[list[str]]:
    raise ValueError("no data to draw")


def _plain() -> dict[str, list[str]]:
    return {name: [svg_text(fig) for fig in _curves(*spec)] for name, spec in GROUPS.items()}


def _drawn(drawers, splits) -> dict[str, list[str]]:
    page = drawing.Drawing(drawers)
    for names in splits:
        page.start(draw_curves, GROUPS, names)
    return {name: page.texts(name) for name in GROUPS}


SPLITS = ([("three", "one", "two", "none")], [("three",), ("one", "two", "none")],
          [("none", "two"), ("one",), ("three",)])


def test_texts_here_equal_the_plain_route_for_every_split():
    plain = _plain()
    assert [len(texts) for texts in plain.values()] == [3, 1, 2, 0]
    for splits in SPLITS:
        assert _drawn(None, splits) == plain


def _drawers_equal_the_plain_route() -> None:
    if no_fork_here():
        return
    plain = _plain()
    for splits in SPLITS:
        with drawing.standby_drawers() as drawers:
            assert _drawn(drawers, splits) == plain


def _drawn_by_other_processes() -> None:
    if no_fork_here():
        return
    with drawing.standby_drawers() as drawers:
        page = drawing.Drawing(drawers)
        page.start(draw_where, 0, ("a",))
        page.start(draw_where, 0, ("b", "c"))
        a, b, c = (page.texts(name)[0] for name in "abc")
    assert f"pid {os.getpid()}" not in a + b + c
    assert b == c and a != b  # one drawer each: two processes


def _failing_drawer_drawn_here() -> None:
    if no_fork_here():
        return
    with drawing.standby_drawers() as drawers:
        page = drawing.Drawing(drawers)
        page.start(fails_away, os.getpid(), ("three", "two"))
        page.start(draw_curves, GROUPS, ("one",))
        plain = _plain()
        assert [page.texts(name) for name in ("three", "two", "one")] == [
            plain["three"], plain["two"], plain["one"]]


def test_drawers_draw_what_this_process_draws():
    run_in_a_fresh_process("test_report_drawing", "_drawers_equal_the_plain_route")


def test_each_drawer_is_another_process():
    run_in_a_fresh_process("test_report_drawing", "_drawn_by_other_processes")


def test_a_group_failing_in_a_drawer_is_drawn_again_here():
    run_in_a_fresh_process("test_report_drawing", "_failing_drawer_drawn_here")


def test_an_error_of_a_group_shows_in_this_process():
    with drawing.standby_drawers() as drawers:
        page = drawing.Drawing(drawers)
        page.start(draw_broken, None, ("broken",))
        with pytest.raises(ValueError, match="no data to draw"):
            page.texts("broken")


def test_a_page_embeds_a_drawn_text_as_it_embeds_the_figure():
    fig = next(_curves(5, 1))
    direct, drawn = Page("t", figure_format="svg"), Page("t", figure_format="svg")
    direct.figure(fig, caption="c")
    drawn.figure(svg_text(fig), caption="c")
    assert direct._parts == drawn._parts


def test_validating_with_drawers_never_imports_matplotlib_here(tmp_path):
    """validate_scene's drawers draw every figure: this process only places their texts.

    Run in a new interpreter, where nothing imported matplotlib before; the report it writes
    must hold every figure (16 for the shipped run) as inline SVG.
    """
    from rigval.sample_data import shipped_runs

    code = ("import sys; from rigval.validation.beside import can_fork; "
            "from rigval.validation.run.validate import validate_scene; "
            f"validate_scene({str(shipped_runs()[0])!r}, {str(tmp_path / 'out')!r}); "
            "print('fork' if can_fork() else 'no fork', 'matplotlib' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True,
                          text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stderr
    if "no fork" in done.stdout:
        pytest.skip("no fork here: no fork start method or one CPU")
    assert done.stdout.split() == ["fork", "False"]
    page = (tmp_path / "out" / "report.html").read_text(encoding="utf-8")
    assert page.count("<svg ") >= 16


#: The calls of draw_counted, by its inputs.
COUNTED: list[object] = []


def draw_counted(inputs: dict[str, tuple[int, int]], names: tuple[str, ...]) -> list[list[str]]:
    COUNTED.append(inputs)
    return draw_curves(inputs, names)


def test_a_part_equal_to_an_earlier_one_is_drawn_once_for_both_pages():
    COUNTED.clear()
    drawers = drawing.Drawers(())
    pages = [drawing.Drawing(drawers) for _ in range(3)]
    other = {**GROUPS, "two": (9, 2)}
    for page, inputs in zip(pages, (GROUPS, dict(GROUPS), other), strict=True):
        page.start(draw_counted, inputs, ("three", "two"))
    texts = [[page.texts(name) for name in ("three", "two")] for page in pages]
    assert [GROUPS, other] == COUNTED  # the equal inputs of the second page: not drawn again
    plain = _plain()
    assert texts[0] == texts[1] == [plain["three"], plain["two"]]
    assert texts[2][0] == plain["three"] and texts[2][1] != plain["two"]


def test_the_model_figures_handed_after_the_model_stage_are_not_drawn_again():
    """start_sketch hands the sketch when the mechanism is assembled, start_model_figures the
    alignment's and model's parts (the sketch again); start_figures reuses them all.

    Drawers without children draw nothing until asked, so the test sees what is handed: the
    parts handed early are the very drawings the page's start gets back, and their texts equal
    those of a page whose figures all start after the run.
    """
    from rigval.sample_data import shipped_runs
    from rigval.validation.pipeline import run_scene
    from rigval.validation.report.run_report import (
        FIGURE_PARTS,
        start_figures,
        start_model_figures,
        start_sketch,
    )

    drawers = drawing.Drawers(())
    handed = []
    submit = drawers.submit

    def recording(*args, **kwargs):
        handed.append(submit(*args, **kwargs))
        return handed[-1]

    drawers.submit = recording
    result = run_scene(shipped_runs()[0],
                       after_assembly=lambda assembly: start_sketch(assembly, drawers),
                       after_model=lambda run: start_model_figures(run, drawers))
    sketch, *early = handed
    assert len(early) == len(FIGURE_PARTS)
    assert early[FIGURE_PARTS.index(("sketch",))] is sketch  # not handed twice
    page = start_figures(result, drawers)
    assert all(later is first for later, first in zip(handed[-len(early):], early, strict=True))
    plain = start_figures(result)
    for names in FIGURE_PARTS:
        for name in names:
            assert page.texts(name) == plain.texts(name)


#: What a drawer must not need to draw a run's page: the libraries and modules of the pipeline.
PIPELINE_ONLY = ("xarray", "pandas", "scipy", "netCDF4", "nptdms", "rigval.model",
                 "rigval.processing", "rigval.validation.pipeline", "rigval.validation.results")

DRAW_AFRESH = """
import hashlib, pickle, sys
calls = pickle.loads(open(sys.argv[1], "rb").read())
texts = [function(inputs, names) for function, inputs, names in calls]
print(hashlib.sha256(pickle.dumps(texts)).hexdigest())
print(" ".join(m for m in {watch!r} if m in sys.modules))
"""


def test_a_new_drawer_draws_a_run_page_with_numpy_and_matplotlib_alone(tmp_path):
    """The figures' inputs are plain arrays: a drawer forked before the pipeline's imports
    unpickles and draws every group of a run's page (and the "Why" figure) with numpy and
    matplotlib alone, and draws what this process draws."""
    import hashlib
    import pickle

    from rigval.sample_data import shipped_runs
    from rigval.validation.pipeline import run_scene
    from rigval.validation.report.figure_groups import WHY_GROUP, draw_why_figures
    from rigval.validation.report.figure_inputs import ResidualOrders
    from rigval.validation.report.run_report import start_figures

    calls = []
    drawers = drawing.Drawers(())
    submit = drawers.submit

    def recording(function, inputs, names, figures):
        calls.append((function, inputs, names))
        return submit(function, inputs, names, figures)

    drawers.submit = recording
    start_figures(run_scene(shipped_runs()[0]), drawers)
    rows = (ResidualOrders("acc1", "m/s^2", np.linspace(1.0, 0.1, 20), np.full(20, 0.05),
                           np.ones((20, 2)) * 0.1, "a gain"),)
    calls.append((draw_why_figures, rows, (WHY_GROUP,)))
    assert {name for _, _, names in calls for name in names} >= {
        "comparisons", "pulse_edges", "sketch", "points", "support_forces", WHY_GROUP}
    (tmp_path / "calls.pkl").write_bytes(pickle.dumps(calls))
    script = DRAW_AFRESH.format(watch=PIPELINE_ONLY)
    done = subprocess.run([sys.executable, "-c", script, str(tmp_path / "calls.pkl")], cwd=REPO,
                          capture_output=True, text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stderr
    digest, *imported = done.stdout.splitlines()
    assert imported == [""]  # none of the pipeline's modules
    here = [function(inputs, names) for function, inputs, names in calls]
    assert digest == hashlib.sha256(pickle.dumps(here)).hexdigest()
