"""Figures read at a glance: the mechanism sketch (every point named, where the model puts it),
labels that do not overlap, titles clear of legends, honest y ranges, labelled log axes."""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.text import Annotation, Text

from rigval.model import builtin_mechanism, load_mechanism, solve
from rigval.model.predict import predict
from rigval.validation.bench.core import BenchRow
from rigval.validation.bench.report import plot_stage
from rigval.validation.report.figure_inputs import body_outlines
from rigval.validation.report.plots import honest_ylim, plot_support_forces
from rigval.validation.report.predict_report import _angle_panels, _tip_path_figure
from rigval.validation.report.sketch import sketch_mechanism


@pytest.fixture(scope="module")
def pendulum():
    return load_mechanism(builtin_mechanism("pendulum"))


@pytest.fixture(scope="module")
def prediction(pendulum):
    return predict(pendulum, n_points=72)


def _renderer(fig: Figure):
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    return canvas.get_renderer()


def _boxes(fig: Figure, texts: list[Text]) -> list:
    renderer = _renderer(fig)
    return [t.get_window_extent(renderer) for t in texts if t.get_text() and t.get_visible()]


def _overlapping(boxes: list) -> list[tuple[int, int]]:
    return [(i, j) for (i, a), (j, b) in itertools.combinations(enumerate(boxes), 2)
            if a.overlaps(b)]


def test_sketch_names_every_point_at_the_models_position(pendulum) -> None:
    fig = sketch_mechanism(pendulum, highlight=["P1"])
    fig.draw_without_rendering()
    ax = fig.axes[0]
    labels = {a.get_text(): a.xy for a in ax.texts if isinstance(a, Annotation)}
    truth = solve(pendulum, np.array([0.0]), outputs=["point_position"])["point_position"]
    for point in pendulum.point_names:
        assert point in labels, point
        np.testing.assert_allclose(labels[point], truth.sel(point=point).isel(time=0).values,
                                   atol=1e-12)
    for body in pendulum.body_names:
        assert body in labels
    for driver in pendulum.driver_names:
        assert f"drive {driver}" in labels
    ground = [j for j in pendulum.joints if j.kind == "ground"]
    for joint in ground:  # the solved position of a ground pin is where the file pins it
        np.testing.assert_allclose(labels[joint.name], joint.at, atol=1e-9)


def test_sketch_point_labels_do_not_overlap(pendulum) -> None:
    fig = sketch_mechanism(pendulum, highlight=["P1"])
    fig.draw_without_rendering()
    names = set(pendulum.point_names)
    labels = [t for t in fig.axes[0].texts if t.get_text() in names]
    assert len(labels) == len(names)
    assert _overlapping(_boxes(fig, labels)) == []


def test_body_outline_is_ordered_along_the_body(pendulum) -> None:
    positions = {"a": np.array([0.0, 0.0]), "b": np.array([2.0, 0.0]),
                 "c": np.array([1.0, 0.0])}
    mech = type("M", (), {"bodies": [type("B", (), {"name": "X", "points": {"a": 0, "b": 0,
                                                                               "c": 0}})()]})()
    line = body_outlines(mech, positions)["X"]
    assert line[:, 0].tolist() in ([0.0, 1.0, 2.0], [2.0, 1.0, 0.0])


def test_tip_path_labels_do_not_overlap_each_other(prediction) -> None:
    fig = _tip_path_figure(prediction, "P1")
    fig.draw_without_rendering()
    labels = [t for t in fig.axes[0].texts if t.get_text().endswith("°")]
    assert len(labels) == 8  # every 45 degrees
    assert _overlapping(_boxes(fig, labels)) == []


def _title_and_legend_clear(fig: Figure) -> None:
    renderer = _renderer(fig)
    ax = fig.axes[0]
    legend = ax.get_legend()
    assert legend is not None
    legend_box = legend.get_window_extent(renderer)
    titles = [t for t in (ax.title, ax._left_title, ax._right_title) if t.get_text()]
    assert titles
    for title in titles:
        assert not title.get_window_extent(renderer).overlaps(legend_box), title.get_text()
    # and no offset text (e.g. "+2.9") next to the title
    assert not ax.yaxis.get_offset_text().get_text()


def test_titles_do_not_overlap_legends(prediction) -> None:
    _title_and_legend_clear(plot_support_forces(prediction))
    _title_and_legend_clear(_angle_panels(prediction, [("drive_speed", "speed [rad/s]", 1.0)],
                                          "a long title for the drive speeds of every drive"))


def test_nearly_constant_curve_is_not_magnified_and_zero_is_marked() -> None:
    fig = Figure()
    flat, zero = fig.subplots(2, 1)
    values = 6.2832 + 1e-4 * np.sin(np.linspace(0, 6, 50))
    flat.plot(values)
    honest_ylim(flat, values)
    low, high = flat.get_ylim()
    assert (high - low) >= 0.02 * 6.2832 and low < values.min() and high > values.max()
    zero.plot(np.zeros(50))
    honest_ylim(zero, np.zeros(50))
    assert zero.get_ylim() == (-1.0, 1.0)
    assert [t.get_text() for t in zero.texts] == ["exactly 0"]
    varied = Figure().subplots()
    honest_ylim(varied, np.array([1.0, 5.0]))  # a curve that varies keeps autoscaling
    assert varied.get_autoscaley_on()


def _bench_row(choice: str, cpu: float, error: float, bound: float) -> BenchRow:
    return BenchRow(stage="model", case="k", choice=choice, metric="m", unit="1", error=error,
                    bound=bound, time_s=cpu, cpu_s=cpu, n=1, baseline="exact")


def test_bench_plot_labels_log_axes_draws_bounds_and_marks_exact_zeros() -> None:
    rows = [_bench_row("exact", 3e-4, 0.0, 1e-10), _bench_row("fast", 1.2e-4, 3e-12, 1e-10),
            _bench_row("faster", 1.5e-4, 2e-11, 1e-10)]
    fig = plot_stage(rows, "model")
    fig.draw_without_rendering()
    ax = fig.axes[0]
    # the x data span less than a decade: the axis still has labelled ticks
    shown = [t.get_text() for t in ax.get_xticklabels() if t.get_text()
             and ax.get_xlim()[0] <= t.get_position()[0] <= ax.get_xlim()[1]]
    assert len(shown) >= 2, shown
    assert "µs" in ax.get_xlabel() and "us" not in ax.get_xlabel().replace("µs", "")
    bound_lines = [line for line in ax.get_lines() if "bound" in line.get_label()]
    assert bound_lines and math.isclose(bound_lines[0].get_ydata()[0], 1e-10)
    exact = [line for line in ax.get_lines() if "exact 0" in line.get_label()]
    assert len(exact) == 1 and exact[0].get_xdata()[0] == pytest.approx(300.0)


def test_comparison_title_sits_above_its_key_row() -> None:
    from types import SimpleNamespace

    from rigval.validation.report.plots import plot_comparison
    from rigval.validation.results import ComparisonResult

    angle = np.arange(120) * 2 * np.pi / 120
    shape = 2.9 + 1e-4 * np.sin(angle)  # a signal that would get an offset text
    comparison = ComparisonResult(
        spec=SimpleNamespace(name="acc1", model="point_acceleration[P1].x"), units="m s-2",
        long_name="acc1", angle=angle, cycles=np.vstack([shape, shape * 1.00001]),
        model=shape, offset=3.21, scores={}, baseline={}, checks=())
    fig = plot_comparison(comparison)
    renderer = _renderer(fig)
    top = fig.axes[0]
    title = top._left_title.get_window_extent(renderer)
    # the key row: five coloured texts above the panel, left to right, none overlapping
    row = sorted((t.get_window_extent(renderer) for t in top.texts), key=lambda box: box.x0)
    assert [t.get_text() for t in sorted(top.texts, key=lambda t: t.get_window_extent(
        renderer).x0)] == ["band: measured P5-P95 (2 cycles)", "measured mean",
                           "model +3.21 m s-2 (dashed)", "\u25cf peak of the mean",
                           "\u00d7 model peak"]
    assert all(left.x1 < right.x0 for left, right in itertools.pairwise(row))
    assert row[-1].x1 == pytest.approx(top.bbox.x1, abs=1.0)  # ends at the panel's right edge
    for box in row:
        assert box.y0 >= top.bbox.y1  # above the panel
        assert not title.overlaps(box) and title.y0 >= box.y0
    assert title.y1 <= fig.bbox.y1  # inside the figure
    # no offset ("+2.9"); a power-of-ten multiplier may stay but never under the title
    multiplier = top.yaxis.get_offset_text()
    assert "+" not in multiplier.get_text()
    if multiplier.get_text():
        assert not multiplier.get_window_extent(renderer).overlaps(title)


def _stress_comparison() -> object:
    """A strain comparison in Pa, peaks of 7 MPa, model 2 % high, as str1 of the shipped run."""
    from types import SimpleNamespace

    from rigval.validation.results import ComparisonResult

    angle = np.arange(180) * 2 * np.pi / 180
    shape = 7.0e6 * np.sin(angle) + 1.0e6 * np.sin(2 * angle + 0.3)
    return ComparisonResult(
        spec=SimpleNamespace(name="str1", model="joint_force[P5].x"), units="Pa",
        long_name="str1", angle=angle, cycles=np.vstack([shape * 0.999, shape * 1.001]),
        model=1.02 * shape, offset=0.0, scores={}, baseline={}, checks=())


def test_stress_is_drawn_in_mpa_with_its_values_scaled() -> None:
    from rigval.validation.report.plots import display_units, plot_comparison

    assert display_units("Pa", 7.2e6) == (1e-6, "MPa")
    assert display_units("Pa", 3.0e4) == (1e-3, "kPa")
    assert display_units("Pa", 12.0) == (1.0, "Pa")
    assert display_units("N m", 3.0e3) == (1.0, "N m")  # torques stay as the scene gives them
    comparison = _stress_comparison()
    fig = plot_comparison(comparison)
    top, bottom, spectrum = fig.axes
    _renderer(fig)
    assert top.get_ylabel() == "str1 [MPa]" and bottom.get_ylabel() == "residual [MPa]"
    assert spectrum.get_ylabel() == "amplitude [MPa]"
    mean = next(line for line in top.get_lines() if line.get_label() == "measured mean")
    # the curve is the mean in MPa: 1e-6 of the Pa values (closed over 360 deg: one more point)
    np.testing.assert_allclose(mean.get_ydata()[:-1], comparison.mean * 1e-6, rtol=1e-12)
    labels = [t.get_text() for t in top.get_yticklabels() if t.get_text()]
    assert labels and all(abs(float(s.replace("\u2212", "-"))) <= 10 for s in labels)
    assert top.yaxis.get_offset_text().get_text() == ""  # no "1e7" above the axis


def test_lower_keys_stand_above_their_panels_and_peaks_are_keyed() -> None:
    from matplotlib.colors import to_hex

    from rigval.validation.report.plots import PEAK_GLYPHS, plot_comparison

    fig = plot_comparison(_stress_comparison())
    renderer = _renderer(fig)
    top, bottom, spectrum = fig.axes
    for ax, count in ((bottom, 2), (spectrum, 2)):
        boxes = [t.get_window_extent(renderer) for t in ax.texts]
        assert len(boxes) == count
        assert all(box.y0 >= ax.bbox.y1 for box in boxes)  # never over a curve or a bar
    # the spectrum's key clears the residual panel's x label above it
    xlabel = bottom.xaxis.label.get_window_extent(renderer)
    assert all(not xlabel.overlaps(t.get_window_extent(renderer)) for t in spectrum.texts)
    # each peak marker has a key entry that shows its glyph in the marker's colour
    keyed = {t.get_text()[0]: to_hex(t.get_color()) for t in top.texts}
    markers = [line for line in top.get_lines() if line.get_marker() in PEAK_GLYPHS]
    assert len(markers) == 2
    for line in markers:
        assert keyed[PEAK_GLYPHS[line.get_marker()]] == to_hex(line.get_color())


def test_bench_log_axis_ticks_are_few_plain_and_apart() -> None:
    # CPU times 6.5-8.2 us (a fifth of a decade, as the BLAS-thread rows), errors 1e-15-1e-10
    rows = [_bench_row("one thread", 6.5e-6, 2.5e-13, 1e-10),
            _bench_row("two threads", 8.2e-6, 2.4e-13, 1e-10),
            _bench_row("exact", 7.0e-6, 1e-15, 1e-10)]
    fig = plot_stage(rows, "model")
    renderer = _renderer(fig)
    ax = fig.axes[0]
    low, high = ax.get_xlim()
    shown = [t for t in ax.get_xticklabels() if t.get_text() and low <= t.get_position()[0] <= high]
    assert 2 <= len(shown) <= 6, [t.get_text() for t in shown]
    values = [float(t.get_text()) for t in shown]  # plain numbers, no "x10^0"
    assert all(low <= v <= high for v in values)
    boxes = sorted((t.get_window_extent(renderer) for t in shown), key=lambda b: b.x0)
    assert all(a.x1 < b.x0 for a, b in itertools.pairwise(boxes))  # never run together
    # the error axis spans decades below 0.001: powers of ten
    labels = [t.get_text() for t in ax.get_yticklabels() if t.get_text()]
    assert labels and all(text.startswith("$10^{") for text in labels), labels


def test_a_long_record_draws_some_revolutions_and_its_band_of_all() -> None:
    """A four-hour record has 14,400 revolutions: the figure draws MAX_DRAWN_CYCLES of them,
    evenly chosen from the first to the last, and says so; the band and mean are of all."""
    from types import SimpleNamespace

    from rigval.validation.report.figure_inputs import MAX_DRAWN_CYCLES, ComparisonCurves
    from rigval.validation.report.plots import plot_comparison
    from rigval.validation.results import ComparisonResult

    rng = np.random.default_rng(7)
    angle = np.arange(90) * 2 * np.pi / 90
    count = 1234
    cycles = np.sin(angle) + 0.1 * rng.standard_normal((count, angle.size))
    cycles[-1] += 5.0  # the last revolution, with the record's peak, is among those drawn
    comparison = ComparisonResult(
        spec=SimpleNamespace(name="acc1", model="point_acceleration[P1].x"), units="m s-2",
        long_name="acc1", angle=angle, cycles=cycles, model=np.sin(angle), offset=0.0,
        scores={}, baseline={}, checks=())
    curves = ComparisonCurves.of(comparison)
    assert curves.drawn.shape == (MAX_DRAWN_CYCLES, angle.size)
    np.testing.assert_array_equal(curves.drawn[[0, -1]], cycles[[0, -1]])
    steps = np.diff([int(np.flatnonzero((cycles == row).all(axis=1))[0])
                     for row in curves.drawn])
    assert steps.min() >= 12 and steps.max() <= 13  # evenly: 1233 / 99 = 12.45
    low, high = np.percentile(cycles, [5.0, 95.0], axis=0)
    np.testing.assert_array_equal(curves.low, low)
    np.testing.assert_array_equal(curves.high, high)
    np.testing.assert_array_equal(curves.mean, cycles.mean(axis=0))
    assert curves.peak == np.abs(cycles).max() and curves.n_cycles == count
    top = plot_comparison(comparison).axes[0]
    assert len(top.collections[0].get_segments()) == MAX_DRAWN_CYCLES
    assert f"band: measured P5-P95 ({count} cycles, {MAX_DRAWN_CYCLES} drawn)" in [
        t.get_text() for t in top.texts]
    few = ComparisonCurves.of(dataclasses.replace(comparison, cycles=cycles[:15]))
    np.testing.assert_array_equal(few.drawn, cycles[:15])  # a short record: every revolution


@pytest.mark.parametrize("lines", [1, 2])
def test_a_plain_title_stands_where_matplotlib_places_one(lines):
    # the figures give their titles y = 1.0 and PLAIN_TITLE_PAD so that matplotlib does not
    # measure every tick label to place them; it must be the place it would have chosen
    from matplotlib.backends.backend_agg import FigureCanvasAgg as Canvas

    from rigval.validation.report.plots import PLAIN_TITLE_PAD

    boxes = []
    for fixed in (False, True):
        fig = Figure(figsize=(4, 3))
        ax = fig.add_subplot()
        ax.plot([0.0, 360.0], [-2.5e3, 7.0e3])
        where = {"y": 1.0, "pad": PLAIN_TITLE_PAD} if fixed else {}
        title = ax.set_title("\n".join(["a title"] * lines), loc="left", **where)
        Canvas(fig).draw()
        boxes.append(title.get_window_extent().bounds)
    assert boxes[0] == boxes[1]
