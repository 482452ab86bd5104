"""A sketch of a mechanism drawn from its file: bodies, joints, named points and drives.

The sketch shows the mechanism assembled at one instant (default t = 0 of the file's drive
laws), so that point names used in reports (the tip P1, the supports P3, P10, P11) can be found
on the machine: each body is a bar through its points, labelled with its name; a revolute joint
is an open circle; a ground pin a hatched triangle; a driven body carries a curved arrow with
the driver's name; every named point is labelled. The figure is built without pyplot, from
the mechanism's assembled geometry (:class:`~rigval.validation.report.figure_inputs.
MechanismSketch`), so that a drawer draws it without the model or xarray.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.patches import FancyArrowPatch, Polygon

from rigval.validation.report.figure_inputs import MechanismSketch
from rigval.validation.report.plots import PLAIN_TITLE_PAD

if TYPE_CHECKING:
    import xarray as xr

    from rigval.model import Mechanism

__all__ = ["draw_sketch", "place_labels", "sketch_mechanism"]

_BODY = "#4a6fa5"
_GROUND = "#57606a"
_DRIVE = "#c8322b"
_HIGHLIGHT = "#c8322b"
#: Figure margins left, right, bottom, top in inches: room for tick labels, axis labels, title.
_MARGINS = (0.85, 0.2, 0.6, 0.4)


def sketch_mechanism(mechanism: Mechanism, *, time: float = 0.0,
                     highlight: Iterable[str] = (), title: str | None = None,
                     width: float = 8.0, configuration: xr.Dataset | None = None) -> Figure:
    """Draw the mechanism at one instant of its file's drive laws.

    Parameters
    ----------
    mechanism : Mechanism
        The mechanism (from :func:`rigval.model.load_mechanism`).
    time : float
        Instant of the drive laws, s.
    highlight : iterable of str
        Point names drawn in red (the tip, the points a report talks about).
    title : str, optional
        Figure title; default names the mechanism and the instant.
    width : float
        Figure width in inches (the height follows the mechanism's extent).
    configuration : xarray.Dataset, optional
        The mechanism solved at ``time`` with the outputs ``position`` and ``point_position``
        (a validation's result carries it); default: solved here.

    Returns
    -------
    matplotlib.figure.Figure
        The sketch (:func:`draw_sketch` of the mechanism's :class:`MechanismSketch`).
    """
    return draw_sketch(MechanismSketch.of(mechanism, configuration, time=time), time=time,
                       highlight=highlight, title=title, width=width)


def draw_sketch(sketch: MechanismSketch, *, time: float = 0.0, highlight: Iterable[str] = (),
                title: str | None = None, width: float = 8.0) -> Figure:
    """Draw a mechanism's sketch from its assembled geometry.

    Parameters
    ----------
    sketch : MechanismSketch
        The mechanism assembled at ``time``.
    time : float
        That instant of the drive laws, s (the default title names it).
    highlight, title, width
        As for :func:`sketch_mechanism`.

    Returns
    -------
    matplotlib.figure.Figure
        The sketch.
    """
    names, xy = sketch.names, sketch.xy
    positions = dict(zip(names, xy, strict=True))
    span = np.ptp(xy, axis=0)
    aspect = (span[1] + 0.4) / max(span[0] + 0.4, 1e-9)
    height = float(np.clip(0.85 * width * aspect + 0.6, 3.5, 1.4 * width))
    fig = Figure(figsize=(width, height))
    # fixed margins (inches) instead of a layout engine, which would draw the figure once more
    # to measure it; the equal aspect then shrinks the axes inside this box
    fig.subplots_adjust(left=_MARGINS[0] / width, right=1 - _MARGINS[1] / width,
                        bottom=_MARGINS[2] / height, top=1 - _MARGINS[3] / height)
    ax = fig.add_subplot()
    ax.set_aspect("equal")
    for body, points, centre in zip(sketch.bodies, sketch.outlines, sketch.centres, strict=True):
        ax.plot(points[:, 0], points[:, 1], "-", color=_BODY, lw=5, alpha=0.55,
                solid_capstyle="round", zorder=1)
        ax.plot(*centre, "+", color=_BODY, ms=6, zorder=2)
        ax.annotate(body, centre, xytext=(-4, -11), textcoords="offset points",
                    fontsize=9, fontstyle="italic", color=_BODY, fontweight="bold")
    size = 0.025 * max(float(span.max()), 1e-6)
    for joint, grounded in zip(sketch.joints, sketch.grounded, strict=True):
        x, y = positions[joint]
        if grounded:
            _ground_symbol(ax, x, y, size)
        ax.plot(x, y, "o", mfc="white", mec="#1b1f24", ms=6, mew=1.3, zorder=4)
    free = [p for p in names if p not in set(sketch.joints)]
    if free:
        ax.plot(*np.array([positions[p] for p in free]).T, "o", color="#1b1f24", ms=4, zorder=4)
    marked = set(highlight)
    for point in (p for p in names if p in marked):  # in the names' order: the same SVG every run
        ax.plot(*positions[point], "o", color=_HIGHLIGHT, ms=8, zorder=5)
    for driver, centre in zip(sketch.drivers, sketch.driver_centres, strict=True):
        _drive_arrow(ax, centre, 4.0 * size, driver)
    ax.margins(0.08)
    place_labels(fig, ax, xy[:, 0], xy[:, 1], names,
                 avoid=np.vstack([_densify(o) for o in sketch.outlines]),
                 colors=[_HIGHLIGHT if n in marked else "#1b1f24" for n in names])
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(True, lw=0.3, alpha=0.5)
    ax.set_title(title or f"mechanism at t = {time:g} s of its file's drive laws (red: "
                          f"{', '.join(sorted(marked)) or 'no point'})", loc="left", fontsize=10,
                 y=1.0, pad=PLAIN_TITLE_PAD)
    return fig


def _densify(points: np.ndarray, per_segment: int = 24) -> np.ndarray:
    """Return points along the polyline through ``points`` (for label placement)."""
    if len(points) < 2:
        return points
    steps = np.linspace(0.0, 1.0, per_segment)[:, None]
    return np.vstack([a + steps * (b - a) for a, b in itertools.pairwise(points)])


def _ground_symbol(ax: Axes, x: float, y: float, size: float) -> None:
    """Draw a hatched triangle under a ground pin."""
    triangle = np.array([[x, y], [x - size, y - 1.6 * size], [x + size, y - 1.6 * size]])
    ax.add_patch(Polygon(triangle, closed=True, facecolor="#d0d7de", edgecolor=_GROUND,
                         hatch="///", lw=1.0, zorder=3))


def _drive_arrow(ax: Axes, centre: np.ndarray, radius: float, name: str) -> None:
    """Draw a counter-clockwise arrow around the driven body's pivot, with the driver's name."""
    start = centre + radius * np.array([np.cos(np.radians(200)), np.sin(np.radians(200))])
    end = centre + radius * np.array([np.cos(np.radians(-20)), np.sin(np.radians(-20))])
    ax.add_patch(FancyArrowPatch(start, end, connectionstyle="arc3,rad=0.9", color=_DRIVE,
                                 arrowstyle="-|>", mutation_scale=12, lw=1.4, zorder=3))
    ax.annotate(f"drive {name}", start, xytext=(-3, 2), textcoords="offset points",
                ha="right", va="top", fontsize=8, color=_DRIVE)


#: Label offsets tried around a mark, points (right, left, above, below, then farther out).
_OFFSETS = [(6, 4), (6, -12), (-30, 4), (-30, -12), (-12, 10), (-12, -18), (6, 16), (6, -24),
            (-30, 16), (-30, -24), (20, 4), (-44, 4)]


def place_labels(fig: Figure, ax: Axes, x: np.ndarray, y: np.ndarray, labels: Sequence[str], *,
                 avoid: np.ndarray | None = None, colors: Sequence[str] | None = None,
                 fontsize: float = 8.0) -> None:
    """Annotate marks, each label clear of other labels, marks and (if possible) curves.

    Positions are compared in points on the figure as laid out now; labels are anchored at their
    marks in data coordinates, so a later resolution does not move them.

    Parameters
    ----------
    fig, ax : Figure, Axes
        Where the marks are drawn (limits final).
    x, y : numpy.ndarray
        The marks, data coordinates.
    labels : sequence of str
        One label per mark.
    avoid : numpy.ndarray, optional
        (n, 2) points of curves the labels should not cover, data coordinates.
    colors : sequence of str, optional
        Label colours.
    fontsize : float
        Label font size, points.
    """
    if fig.get_layout_engine() is not None:  # the engine moves the axes when it draws
        fig.draw_without_rendering()
    else:  # fixed axes box: final limits and aspect give data -> display without drawing
        ax.autoscale_view()
        ax.apply_aspect()
    scale = 72.0 / fig.dpi  # points per pixel
    marks = ax.transData.transform(np.column_stack([x, y])) * scale
    curve = (ax.transData.transform(avoid) * scale if avoid is not None and len(avoid)
             else np.empty((0, 2)))
    taken: list[tuple[float, float, float, float]] = []
    char = 0.62 * fontsize

    def covers(box: tuple[float, float, float, float], points: np.ndarray,
               margin: float) -> bool:
        return bool(np.any((points[:, 0] > box[0] - margin) & (points[:, 0] < box[2] + margin)
                           & (points[:, 1] > box[1] - margin) & (points[:, 1] < box[3] + margin)))

    for i, ((px, py), text) in enumerate(zip(marks, labels, strict=True)):
        width, height = char * len(text) + 2.0, 1.1 * fontsize
        others = np.delete(marks, i, axis=0)
        chosen = None
        for strict in (True, False):  # also clear of the curves, then of marks and labels only
            for dx, dy in _OFFSETS:
                box = (px + dx, py + dy, px + dx + width, py + dy + height)
                if (not any(_overlap(box, other) for other in taken)
                        and not covers(box, others, 3.0) and not covers(box, marks[i:i + 1], 1.0)
                        and not (strict and covers(box, curve, 1.0))):
                    chosen = (dx, dy, box)
                    break
            if chosen is not None:
                break
        if chosen is None:
            dx, dy = _OFFSETS[0]
            chosen = (dx, dy, (px + dx, py + dy, px + dx + width, py + dy + height))
        taken.append(chosen[2])
        ax.annotate(text, (x[i], y[i]), xytext=chosen[:2], textcoords="offset points",
                    fontsize=fontsize, color=colors[i] if colors is not None else "#1b1f24")


def _overlap(a: tuple[float, float, float, float], b: tuple[float, float, float, float]) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]
