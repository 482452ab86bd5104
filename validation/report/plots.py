"""Figures of a validation, built on :class:`matplotlib.figure.Figure` without pyplot.

Every function returns a new Figure (:func:`plot_comparisons`, :func:`plot_points_kinematics`:
one figure, redrawn for each comparison or point) and keeps no global state, so it is safe in
long-running processes and worker pools. Margins are fixed rather than computed by a layout
engine, which would draw every figure twice. Angles are shown in degrees of phi_F, the main
shaft angle from the reference position; labels carry units.

Each figure draws plain arrays (:mod:`rigval.validation.report.figure_inputs`): this module
imports numpy and matplotlib alone, so that a drawer forked before the pipeline's imports
(:mod:`rigval.validation.report.drawing`) has what it draws with without xarray or scipy. The
functions also take the result's objects, whose inputs they make first.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection, PolyCollection
from matplotlib.figure import Figure
from matplotlib.ticker import MultipleLocator, ScalarFormatter
from matplotlib.transforms import ScaledTranslation

from rigval.validation.report.figure_inputs import (
    ComparisonCurves,
    PointCurves,
    ResidualOrders,
    StreamCurves,
    SupportCurves,
)

if TYPE_CHECKING:
    import xarray as xr

    from rigval.processing.alignment_summary import StreamAlignment
    from rigval.validation.results import ComparisonResult

__all__ = [
    "display_units",
    "honest_ylim",
    "plot_clock_residuals",
    "plot_comparison",
    "plot_comparisons",
    "plot_point_curves",
    "plot_point_kinematics",
    "plot_points_kinematics",
    "plot_pulse_edges",
    "plot_residual_orders",
    "plot_stream_coverage",
    "plot_support_forces",
]

MEASURED = "#1f5fa8"
MODEL = "#c8322b"
CYCLES = "#9aa5b1"
BAND = "#9ec3ea"
#: Title height in axes coordinates; fixed, so matplotlib does not measure every tick label to
#: place it.
TITLE_Y = 1.01
#: matplotlib's default distance of a title above its axes (``axes.titlepad``), points: given
#: with the height 1.0, the title stands where matplotlib would put it over axes without tick
#: labels on top, and it does not measure every tick label to place it.
PLAIN_TITLE_PAD = 6.0
#: Harmonic orders shown under each comparison.
HARMONIC_ORDERS = 10
#: Smallest y span of a panel relative to the largest absolute value shown: a curve that varies
#: by less (a constant speed, a residual of 1e-4 of the signal) is drawn flat, not magnified.
MIN_RELATIVE_SPAN = 0.02
#: Distance of a left-aligned panel title above the axes, points: room for a legend row between.
TITLE_PAD = 15.0
#: Distance of an x label's top under its axes, points: tick length 3.5, pad 3.5, a line of
#: 10 pt tick labels and the label pad 4 (matplotlib's defaults, as it would place it).
XLABEL_DROP = 21.0
#: Space between the entries of a key row (:func:`_key_row`), points.
KEY_GAP = 14.0
#: The text that stands for a peak marker in a key, by matplotlib marker.
PEAK_GLYPHS = {"o": "\u25cf", "x": "\u00d7"}
#: SI prefixes a figure may put before a unit it shows (:func:`display_units`).
_PREFIXES = ((1e9, "G"), (1e6, "M"), (1e3, "k"))
#: Units shown with a prefix when the values reach a thousand (stresses: MPa, not 1e7 Pa).
PREFIXED_UNITS = frozenset({"Pa"})


def display_units(units: str, largest: float) -> tuple[float, str]:
    """Return the factor and the unit a figure shows values of ``units`` in.

    Stresses in Pa read as MPa (or kPa, GPa): axis labels of 2.5e7 with an offset are hard to
    read. Other units are shown as they are.

    Parameters
    ----------
    units : str
        The values' unit, e.g. ``"Pa"``.
    largest : float
        The largest absolute value to be shown, in ``units``.

    Returns
    -------
    tuple of (float, str)
        Multiply the values by the factor to show them in the returned unit.
    """
    if units in PREFIXED_UNITS and np.isfinite(largest):
        for size, prefix in _PREFIXES:
            if largest >= size:
                return 1.0 / size, prefix + units
    return 1.0, units


def _figure(width: float, height: float) -> Figure:
    """Return a figure with fixed margins (in inches, independent of its size)."""
    fig = Figure(figsize=(width, height))
    fig.subplots_adjust(left=0.95 / width, right=1 - 0.25 / width, bottom=0.55 / height,
                        top=1 - 0.4 / height, hspace=0.35)
    return fig


def honest_ylim(ax: Axes, *curves: np.ndarray, exact_zero_note: bool = True) -> None:
    """Set y limits that show the curves' variation at its true size, and no offset text.

    A span below :data:`MIN_RELATIVE_SPAN` of the largest absolute value is widened to that
    (centred), so that a nearly constant curve looks nearly constant; curves that are exactly
    zero everywhere get the range -1..1 and the note "exactly 0" in the panel.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The panel.
    *curves : numpy.ndarray
        Every curve drawn in it (NaN ignored).
    exact_zero_note : bool
        Whether to write "exactly 0" into a panel whose curves are all exactly zero.
    """
    values = np.concatenate([np.ravel(np.asarray(c, dtype=float)) for c in curves] or [[]])
    values = values[np.isfinite(values)]
    formatter = ax.yaxis.get_major_formatter()
    if isinstance(formatter, ScalarFormatter):
        formatter.set_useOffset(False)  # no "+2.9" over the panel's title
    if not values.size:
        return
    low, high = float(values.min()), float(values.max())
    peak = max(abs(low), abs(high))
    if peak == 0.0:
        ax.set_ylim(-1.0, 1.0)
        if exact_zero_note:
            ax.text(0.5, 0.62, "exactly 0", transform=ax.transAxes, ha="center", fontsize=9,
                    color="#57606a")
        return
    span = high - low
    least = MIN_RELATIVE_SPAN * peak
    if span < least:
        middle = 0.5 * (low + high)
        ax.set_ylim(middle - 0.55 * least, middle + 0.55 * least)


def _xlabel(ax: Axes, text: str) -> None:
    """Set the x label at a fixed distance under the axes (where matplotlib would put it).

    Matplotlib places an x label under the bounding box of the tick labels, which it measures
    once more on every draw; tick labels of one line of 10 pt digits always end
    :data:`XLABEL_DROP` points under the axes.
    """
    ax.set_xlabel(text)
    inches = ax.figure.dpi_scale_trans  # type: ignore[union-attr]
    ax.xaxis.set_label_coords(0.5, 0.0, transform=ax.transAxes + ScaledTranslation(
        0.0, -XLABEL_DROP / 72.0, inches))


def _angle_axis(ax: Axes, label: bool = True) -> None:
    ax.set_xlim(0.0, 360.0)
    ax.xaxis.set_major_locator(MultipleLocator(45.0))
    ax.grid(True, lw=0.4, alpha=0.6)
    if label:
        _xlabel(ax, "main shaft angle \u03c6F [deg]")


def _closed(angle: np.ndarray, *values: np.ndarray) -> tuple[np.ndarray, ...]:
    """Append the first point at 360 degrees so that a periodic curve spans the whole axis."""
    degrees = np.append(np.degrees(angle), 360.0)
    return (degrees, *(np.concatenate([v, v[..., :1]], axis=-1) for v in values))


def _harmonics(values: np.ndarray, orders: int) -> np.ndarray:
    """Amplitudes of the orders 1 ... ``orders`` of a signal sampled over one revolution."""
    spectrum = np.fft.rfft(values) * (2.0 / values.size)
    return np.abs(spectrum[1:orders + 1])


def plot_comparison(result: ComparisonResult | ComparisonCurves, *, width: float = 9.0,
                    orders: int = HARMONIC_ORDERS) -> Figure:
    """Overlay of measured cycles, measured mean with its band and the model; residual; orders.

    Parameters
    ----------
    result : ComparisonResult or ComparisonCurves
        The comparison, or its curves.
    width : float
        Figure width in inches.
    orders : int
        Harmonic orders of the shaft speed shown in the bottom panel.

    Returns
    -------
    matplotlib.figure.Figure
        Top: the cycles (light; at most
        :data:`~rigval.validation.report.figure_inputs.MAX_DRAWN_CYCLES`), the measured mean
        with its P5-P95 band, the model, the peaks of both marked. Middle: the residual model minus
        measured mean, with the band around the mean. Bottom: amplitudes of the first harmonic
        orders, measured mean and model (rigid-body errors often sit in particular orders).
    """
    return _ComparisonFigure(width, orders).show(result)


def plot_comparisons(results: Iterable[ComparisonResult | ComparisonCurves], *,
                     width: float = 9.0, orders: int = HARMONIC_ORDERS) -> Iterator[Figure]:
    """Yield :func:`plot_comparison` of each comparison, drawn into one reused figure.

    Building a figure's axes and tick marks takes a good part of its rendering time; this
    generator builds them once and redraws only the data, titles and key rows for each
    comparison. The rendered images equal those of :func:`plot_comparison`.

    Parameters
    ----------
    results : iterable of ComparisonResult or ComparisonCurves
        The comparisons, or their curves.
    width : float
        Figure width in inches.
    orders : int
        Harmonic orders of the shaft speed shown in the bottom panel.

    Yields
    ------
    matplotlib.figure.Figure
        The figure of the current comparison. It is the same object every time: render or save
        it before asking for the next one.
    """
    figure = _ComparisonFigure(width, orders)
    for result in results:
        yield figure.show(result)


class _ComparisonFigure:
    """The three panels of :func:`plot_comparison`, redrawn for one comparison after another."""

    def __init__(self, width: float, orders: int) -> None:
        self.orders = orders
        self.fig = _figure(width, 7.0)
        self.fig.subplots_adjust(top=1 - 0.62 / 7.0)  # the title above the legend row
        grid = self.fig.add_gridspec(3, 1, height_ratios=[3, 1.6, 1.5], hspace=0.45)
        self.top = self.fig.add_subplot(grid[0])
        self.bottom = self.fig.add_subplot(grid[1], sharex=self.top)
        self.spectrum = self.fig.add_subplot(grid[2])
        _angle_axis(self.top, label=False)
        self.top.tick_params(labelbottom=False)  # the residual panel below shows the angles
        _angle_axis(self.bottom)
        order = np.arange(1, orders + 1)
        self.spectrum.set_xticks(order)
        _xlabel(self.spectrum, "order (harmonic of the shaft speed)")
        self.spectrum.grid(True, axis="y", lw=0.4, alpha=0.6)
        # the keys of the lower panels stand above them, never over a curve or a bar
        _key_row(self.bottom, (("band: measured P5-P95 about the mean", MEASURED),
                               ("model - measured mean", MODEL)))
        _key_row(self.spectrum, (("measured mean", MEASURED), ("model", MODEL)))
        self.drawn: list[object] = []

    def _clear(self) -> None:
        """Remove the previous comparison's artists and forget their data limits."""
        for artist in self.drawn:
            artist.remove()  # type: ignore[attr-defined]
        self.drawn.clear()
        for ax in (self.top, self.bottom, self.spectrum):
            ax.relim()  # data limits of what is left (nothing): autoscaling starts afresh

    def show(self, result: ComparisonResult | ComparisonCurves) -> Figure:
        """Draw one comparison (see :func:`plot_comparison`) and return the figure."""
        if not isinstance(result, ComparisonCurves):
            result = ComparisonCurves.of(result)
        self._clear()
        top, bottom, spectrum, orders = self.top, self.bottom, self.spectrum, self.orders
        factor, units = display_units(result.units, result.peak)
        low, high = factor * result.low, factor * result.high
        mean, model = factor * result.mean, factor * result.model
        x, cycles, mean_c, low_c, high_c, model_c = _closed(result.angle, factor * result.drawn,
                                                            mean, low, high, model)
        cycles_text = (f"{result.n_cycles} cycles" if len(cycles) == result.n_cycles
                       else f"{result.n_cycles} cycles, {len(cycles)} drawn")
        drawn = self.drawn
        drawn.append(top.add_collection(LineCollection(
            [np.column_stack([x, c]) for c in cycles], colors=CYCLES, linewidths=0.5,
            alpha=0.45)))
        drawn.append(top.fill_between(x, low_c, high_c, color=BAND, alpha=0.6, lw=0,
                                      label=f"measured P5-P95 ({cycles_text})"))
        drawn += top.plot(x, mean_c, color=MEASURED, lw=1.8, label="measured mean")
        model_label = ("model" if result.offset == 0
                       else f"model {factor * result.offset:+.3g} {units}")
        drawn += top.plot(x, model_c, color=MODEL, lw=1.6, ls="--", label=model_label)
        for values, color, marker in ((mean, MEASURED, "o"), (model, MODEL, "x")):
            peak = int(np.argmax(np.abs(values)))
            drawn += top.plot(x[peak], values[peak], marker, color=color, ms=7, mew=2)
        top.set_ylabel(f"{result.name} [{units}]")
        top.set_title(f"{result.name} against {result.model_name}", loc="left", fontsize=10,
                      y=1.0, pad=TITLE_PAD)
        for ax in (top, bottom, spectrum):
            formatter = ax.yaxis.get_major_formatter()
            if isinstance(formatter, ScalarFormatter):
                formatter.set_useOffset(False)
        drawn += _key_row(top, ((f"band: measured P5-P95 ({cycles_text})",
                                 MEASURED), ("measured mean", MEASURED),
                                (f"{model_label} (dashed)", MODEL),
                                (f"{PEAK_GLYPHS['o']} peak of the mean", MEASURED),
                                (f"{PEAK_GLYPHS['x']} model peak", MODEL)))
        drawn.append(bottom.fill_between(x, low_c - mean_c, high_c - mean_c, color=BAND,
                                         alpha=0.6, lw=0,
                                         label="measured P5-P95 about the mean"))
        drawn += bottom.plot(x, model_c - mean_c, color=MODEL, lw=1.2,
                             label="model - measured mean")
        drawn.append(bottom.axhline(0.0, color="black", lw=0.6))
        bottom.set_ylabel(f"residual [{units}]")
        order = np.arange(1, orders + 1)
        drawn.append(_bars(spectrum, order - 0.4, _harmonics(mean, orders), 0.4, MEASURED,
                           "measured mean"))
        drawn.append(_bars(spectrum, order, _harmonics(model, orders), 0.4, MODEL, "model"))
        spectrum.set_ylabel(f"amplitude [{units}]")
        return self.fig


def _bars(ax: Axes, left: np.ndarray, heights: np.ndarray, width: float, color: str,
          label: str) -> PolyCollection:
    """Draw bars from 0 as one collection (one artist, not one rectangle patch per bar).

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The panel; its y autoscaling keeps 0 at the bottom edge, as for :meth:`Axes.bar`.
    left : numpy.ndarray
        Left edge of each bar, data units.
    heights : numpy.ndarray
        Height of each bar, data units.
    width : float
        Bar width, data units.
    color : str
        Fill colour.
    label : str
        The collection's label.

    Returns
    -------
    matplotlib.collections.PolyCollection
        The bars, one closed rectangle each, in the order of ``left``.
    """
    right = left + width
    zero = np.zeros_like(heights)
    rectangles = np.stack([np.column_stack(corner) for corner in (
        (left, zero), (left, heights), (right, heights), (right, zero))], axis=1)
    bars = PolyCollection(rectangles, facecolors=color, edgecolors="none", linewidths=0,
                          label=label)
    bars.sticky_edges.y.append(0.0)
    return ax.add_collection(bars)


def _key_row(ax: Axes, entries: Sequence[tuple[str, str]]) -> list[object]:
    """Write a key as one row of coloured texts above the panel, ending at its right edge.

    Each text is placed to the left of the next one when the figure is drawn (positioned
    relative to that text's box), so no text is measured in advance, and the row costs a few
    texts instead of a :meth:`Axes.legend` with its handles and boxes.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The panel.
    entries : sequence of (str, str)
        Text and colour of each entry, left to right.

    Returns
    -------
    list
        The text artists, right to left.
    """
    texts: list[object] = []
    for text, color in reversed(entries):
        if texts:  # right-aligned KEY_GAP points left of the entry to its right
            where: dict[str, Any] = {"xy": (0.0, 0.0), "xycoords": texts[-1],
                                     "xytext": (-KEY_GAP, 0.0)}
        else:
            where = {"xy": (1.0, 1.0), "xycoords": "axes fraction", "xytext": (0.0, 3.0)}
        texts.append(ax.annotate(text, **where, textcoords="offset points", ha="right",
                                 va="bottom", fontsize=8, color=color))
    return texts


def plot_pulse_edges(alignment: Mapping[str, StreamAlignment | StreamCurves], *,
                     width: float = 9.0) -> Figure:
    """Plot one reference pulse as each stream recorded it, with the detected edges marked.

    After alignment the edges of all streams fall at the same time (the pulses fire at the same
    shaft angle): the figure shows the alignment at a glance.

    Parameters
    ----------
    alignment : mapping of str to StreamAlignment or StreamCurves
        Per stream, a stretch of its pulse channel and the edges found in it.
    width : float
        Figure width in inches.
    """
    streams = [a for a in map(StreamCurves.of, alignment.values()) if a.pulse_time.size]
    fig = _figure(width, 1.2 + 1.5 * max(len(streams), 1))
    axes = np.atleast_1d(fig.subplots(max(len(streams), 1), 1, sharex=True, squeeze=False)[:, 0])
    for ax, stream in zip(axes, streams, strict=False):
        ax.plot(stream.pulse_time, stream.pulse_signal, color=MEASURED, lw=0.8)
        for edge in stream.edge_times:
            ax.axvline(edge, color=MODEL, lw=0.9, ls="--")
        ax.set_ylabel(f"{stream.stream} [{stream.pulse_units}]")
        ax.grid(True, lw=0.4, alpha=0.6)
        edges = ", ".join(f"{edge:.5f} s" for edge in stream.edge_times)
        ax.set_title(f"{stream.stream} ({stream.device}): edge at {edges or 'none'}", y=TITLE_Y,
                     fontsize=9, loc="left")
    _xlabel(axes[-1], "time on the reference timeline [s]")
    return fig


def plot_clock_residuals(alignment: Mapping[str, StreamAlignment | StreamCurves], *,
                         width: float = 9.0) -> Figure:
    """Residuals of each stream's clock fit (offset + drift) at its matched events, in µs.

    Parameters
    ----------
    alignment : mapping of str to StreamAlignment or StreamCurves
        Per stream; the reference stream has no fit and is left out.
    width : float
        Figure width in inches.
    """
    fig = _figure(width, 3.2)
    ax = fig.subplots()
    for stream in map(StreamCurves.of, alignment.values()):
        if stream.is_reference or not stream.residual_s.size:
            continue
        ax.plot(stream.residual_time, stream.residual_s * 1e6, ".", ms=3,
                label=f"{stream.stream}: rms {stream.residual_rms_s * 1e6:.1f} µs, "
                      f"{stream.events_matched} events")
    ax.axhline(0.0, color="black", lw=0.6)
    _xlabel(ax, "time on the reference timeline [s]")
    ax.set_ylabel("clock-fit residual [µs]")
    ax.grid(True, lw=0.4, alpha=0.6)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper right", fontsize=8)
    return fig


def plot_stream_coverage(alignment: Mapping[str, StreamAlignment | StreamCurves], *,
                         width: float = 9.0) -> Figure:
    """Each stream's span on the reference timeline with its gaps (dropouts, restarts) in red.

    Parameters
    ----------
    alignment : mapping of str to StreamAlignment or StreamCurves
        Per stream.
    width : float
        Figure width in inches.
    """
    names = list(alignment)
    fig = _figure(width, 1.1 + 0.45 * len(names))
    ax = fig.subplots()
    for row, name in enumerate(names):
        stream = StreamCurves.of(alignment[name])
        start, end = stream.span_s
        ax.broken_barh([(start, end - start)], (row - 0.3, 0.6), color=BAND)
        # gap times are on the stream's own clock from its first sample; drift is negligible here
        spans = [(start + after, max(duration, 1e-3)) for after, duration in stream.gaps]
        if spans:
            ax.broken_barh(spans, (row - 0.3, 0.6), color=MODEL)
    ax.set_yticks(range(len(names)), names)
    _xlabel(ax, "time on the reference timeline [s]  (red: gaps)")
    ax.grid(True, axis="x", lw=0.4, alpha=0.6)
    return fig


def plot_support_forces(predictions: xr.Dataset | SupportCurves, *,
                        width: float = 9.0) -> Figure:
    """Support forces on the frame over phi_F, horizontal and vertical (the paper's figs. 16, 17).

    Parameters
    ----------
    predictions : xarray.Dataset or SupportCurves
        With ``support_force`` (angle, support, axis) in N and the coordinate ``angle`` in rad;
        or its curves.
    width : float
        Figure width in inches.
    """
    curves = SupportCurves.of(predictions)
    fig = _figure(width, 5.6)
    fig.subplots_adjust(top=1 - 0.62 / 5.6)
    axes = fig.subplots(2, 1, sharex=True)
    for ax, values, label in zip(axes, (curves.horizontal, curves.vertical),
                                 ("horizontal", "vertical"), strict=True):
        for row, support in enumerate(curves.supports):
            x, y = _closed(curves.angle, values[row])
            ax.plot(x, y / 1e3, lw=1.3, label=support)
        ax.set_ylabel(f"{label} force on frame [kN]")
        honest_ylim(ax, values / 1e3)
        _angle_axis(ax, label=ax is axes[-1])
    axes[0].legend(loc="lower right", bbox_to_anchor=(1.0, 1.0), ncol=len(curves.supports),
                   fontsize=8, frameon=False, borderaxespad=0.1)
    axes[0].set_title("support forces on the frame (model prediction)", loc="left", y=1.0,
                      pad=TITLE_PAD, fontsize=10)
    return fig


def plot_point_kinematics(predictions: xr.Dataset, point: str, *,
                          width: float = 9.0) -> Figure:
    """Position, absolute speed and absolute acceleration of a point over phi_F (paper fig. 15).

    Parameters
    ----------
    predictions : xarray.Dataset
        With ``point_position``, ``point_velocity``, ``point_acceleration`` (angle, point, axis).
    point : str
        The point, e.g. ``"P1"``.
    width : float
        Figure width in inches.
    """
    return _KinematicsFigure(width).show(PointCurves.of(predictions, [point])[0])


def plot_points_kinematics(predictions: xr.Dataset, points: Iterable[str], *,
                           width: float = 9.0) -> Iterator[Figure]:
    """Yield :func:`plot_point_kinematics` of each point, drawn into one reused figure.

    As :func:`plot_comparisons`: the axes and their tick marks are built once; the figure is
    the same object every time, so render or save it before asking for the next one.

    Parameters
    ----------
    predictions : xarray.Dataset
        As for :func:`plot_point_kinematics`.
    points : iterable of str
        The points.
    width : float
        Figure width in inches.
    """
    return plot_point_curves(PointCurves.of(predictions, points), width=width)


def plot_point_curves(curves: Iterable[PointCurves], *, width: float = 9.0
                      ) -> Iterator[Figure]:
    """Yield the kinematics figure of each point's curves, drawn into one reused figure.

    :func:`plot_points_kinematics` of the points' :class:`PointCurves`.
    """
    figure = _KinematicsFigure(width)
    for one in curves:
        yield figure.show(one)


class _KinematicsFigure:
    """The three panels of :func:`plot_point_kinematics`, redrawn for one point after another."""

    def __init__(self, width: float) -> None:
        self.fig = _figure(width, 6.4)
        self.axes = self.fig.subplots(3, 1, sharex=True)
        for ax in self.axes:
            _angle_axis(ax, label=ax is self.axes[-1])
        self.drawn: list[object] = []

    def show(self, curves: PointCurves) -> Figure:
        """Draw one point (see :func:`plot_point_kinematics`) and return the figure."""
        for artist in self.drawn:
            artist.remove()  # type: ignore[attr-defined]
        self.drawn.clear()
        point = curves.point
        panels: Sequence[tuple[np.ndarray, str]] = (
            (curves.y, f"y of {point} [m]"),
            (curves.speed, f"|v| of {point} [m/s]"),
            (curves.acceleration, f"|a| of {point} [m/s\u00b2]"),
        )
        for ax, (values, label) in zip(self.axes, panels, strict=True):
            ax.relim()
            ax.set_autoscaley_on(True)  # honest_ylim may have fixed the previous point's limits
            x, y = _closed(curves.angle, values)
            self.drawn += ax.plot(x, y, color=MODEL, lw=1.5)
            ax.set_ylabel(label)
            texts = len(ax.texts)
            honest_ylim(ax, values)
            self.drawn += ax.texts[texts:]  # the "exactly 0" note, if any
        self.axes[0].set_title(f"{point}: position, speed and acceleration (model prediction)",
                               y=TITLE_Y)
        return self.fig


def plot_residual_orders(rows: Sequence[ResidualOrders], *, width: float = 9.0) -> Figure:
    """Draw each comparison's residual amplitude per order beside what the causes explain.

    The "Why" section's figure (:mod:`rigval.validation.report.why`).

    Parameters
    ----------
    rows : sequence of ResidualOrders
        The comparisons drawn (one panel each;
        :func:`~rigval.validation.report.why.residual_orders`).
    width : float
        Figure width, inches.

    Returns
    -------
    matplotlib.figure.Figure
        Bars: ``|c_k|`` of the mean residual (measured minus model), orders 1 to
        :data:`~rigval.validation.report.why.ORDERS`, with whiskers of twice the
        revolution-to-revolution standard uncertainty of the mean; dots: the chosen causes'
        fitted contribution.
    """
    fig = Figure(figsize=(width, 1.9 * len(rows) + 0.6))
    fig.subplots_adjust(left=0.95 / width, right=1 - 0.25 / width, hspace=0.6)
    axes = fig.subplots(len(rows), 1, squeeze=False)[:, 0]
    for ax, row in zip(axes, rows, strict=True):
        k = np.arange(1, row.amplitude.size + 1)
        ax.bar(k, row.amplitude, width=0.6, color="#9bb7d4", label="residual |c_k|")
        ax.errorbar(k, row.amplitude, yerr=row.spread, fmt="none", ecolor="#333333", lw=0.8,
                    capsize=2, label="2 u (scatter)")
        if np.any(row.fitted):
            ax.plot(k, np.hypot(row.fitted[:, 0], row.fitted[:, 1]), "o", color="#c0392b",
                    ms=4, label=f"explained: {row.cause}")
        ax.set_title(f"{row.name}: residual per order of the main shaft", fontsize=9,
                     loc="left", y=1.0, pad=PLAIN_TITLE_PAD)
        ax.set_ylabel(row.units, fontsize=8)
        ax.set_xticks(k)
        ax.tick_params(labelsize=7)
        ax.legend(fontsize=7, frameon=False, loc="upper right")
    axes[-1].set_xlabel("order (per revolution of the main shaft)", fontsize=8)
    return fig
