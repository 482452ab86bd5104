"""What a run report's figures show: plain arrays, small whatever the record's length.

The figures are drawn in other processes (:mod:`rigval.validation.report.drawing`), to which
their inputs travel pickled. Each input here holds numbers, texts and numpy arrays only, so
that a drawer needs numpy and matplotlib and nothing else: it is forked at the start of a
command, before this process imports xarray, scipy or the pipeline, and imports what it
draws with on the core that is idle meanwhile. A comparison's figure draws at most
:data:`MAX_DRAWN_CYCLES` revolutions and statistics of all (:class:`ComparisonCurves`). Each
input is built in this process with its ``of``, from the result's objects (a
:class:`~rigval.validation.results.ComparisonResult`, a
:class:`~rigval.processing.alignment_summary.StreamAlignment`, the predictions'
:class:`xarray.Dataset`), which this module reads but does not import: it imports numpy alone.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import xarray as xr

    from rigval.model.mechanism_types import Mechanism
    from rigval.processing.alignment_summary import StreamAlignment
    from rigval.validation.results import ComparisonResult

__all__ = ["MAX_DRAWN_CYCLES", "ComparisonCurves", "MechanismSketch", "PointCurves",
           "ResidualOrders", "StreamCurves", "SupportCurves", "body_outlines", "shown_points"]

#: Most revolutions a comparison's figure draws as light lines, evenly chosen; its band and mean
#: are of all of them. A four-hour record has 14,400: every one drawn made a page of 360 MB.
MAX_DRAWN_CYCLES = 100


@dataclass(frozen=True)
class ComparisonCurves:
    """What a comparison's figure shows: some of its revolutions and statistics of all of them.

    Build it with :meth:`of`. Angles in rad of phi_F, values in ``units``.
    """

    name: str
    model_name: str
    units: str
    angle: np.ndarray
    drawn: np.ndarray
    n_cycles: int
    peak: float
    mean: np.ndarray
    low: np.ndarray
    high: np.ndarray
    model: np.ndarray
    offset: float

    @classmethod
    def of(cls, result: ComparisonResult, max_drawn: int = MAX_DRAWN_CYCLES
           ) -> ComparisonCurves:
        """Return the curves of a comparison, at most ``max_drawn`` revolutions drawn.

        Parameters
        ----------
        result : ComparisonResult
            The comparison.
        max_drawn : int
            Most revolutions drawn (evenly chosen, the first and the last among them).
        """
        count = result.cycles.shape[0]
        chosen = np.unique(np.round(np.linspace(0, count - 1, min(count, max_drawn))).astype(int))
        low, high = result.band
        return cls(result.name, str(result.spec.model), result.units, result.angle,
                   result.cycles[chosen], count, float(np.max(np.abs(result.cycles))),
                   result.mean, low, high, result.model, result.offset)


@dataclass(frozen=True)
class StreamCurves:
    """What the alignment's figures show of one stream: its pulse, clock residuals and span.

    Build it with :meth:`of`. Times in s on the reference timeline but ``gaps``, which are on
    the stream's own clock from its first sample.

    Attributes
    ----------
    stream, device : str
        The stream's name and device kind.
    is_reference : bool
        True for the reference stream (no clock fit).
    pulse_time, pulse_signal : numpy.ndarray
        A stretch of the raw pulse channel around one reference pulse (s; ``pulse_units``).
    pulse_units : str
        The pulse channel's unit as read.
    edge_times : numpy.ndarray
        Rising edges detected in that stretch, s.
    residual_time, residual_s : numpy.ndarray
        The clock fit's residual at each matched event, and the events' times, s.
    residual_rms_s : float
        RMS of the residuals, s.
    events_matched : int
        Events the clock was fitted on.
    span_s : tuple of float
        First and last sample, s.
    gaps : tuple of (float, float)
        Each gap's start after the first sample and duration, s.
    """

    stream: str
    device: str
    is_reference: bool
    pulse_time: np.ndarray
    pulse_signal: np.ndarray
    pulse_units: str
    edge_times: np.ndarray
    residual_time: np.ndarray
    residual_s: np.ndarray
    residual_rms_s: float
    events_matched: int
    span_s: tuple[float, float]
    gaps: tuple[tuple[float, float], ...]

    @classmethod
    def of(cls, alignment: StreamAlignment | StreamCurves) -> StreamCurves:
        """Return the curves of a stream's alignment (curves are returned as they are)."""
        if isinstance(alignment, StreamCurves):
            return alignment
        a = alignment
        return cls(a.stream, a.device, a.is_reference, a.pulse_time, a.pulse_signal,
                   a.pulse_units, a.edge_times, a.residual_time, a.residual_s,
                   a.residual_rms_s, a.events_matched, a.span_s,
                   tuple((g["after_s"], g["duration_s"]) for g in a.gaps))


@dataclass(frozen=True)
class PointCurves:
    """What a point's kinematics figure shows: y, absolute speed and acceleration over phi_F.

    Build them with :meth:`of`.

    Attributes
    ----------
    point : str
        The point, e.g. ``"P1"``.
    angle : numpy.ndarray
        phi_F over one revolution, rad.
    y, speed, acceleration : numpy.ndarray
        The point's vertical position (m), absolute speed (m/s) and absolute acceleration
        (m/s²) at each angle.
    """

    point: str
    angle: np.ndarray
    y: np.ndarray
    speed: np.ndarray
    acceleration: np.ndarray

    @classmethod
    def of(cls, predictions: xr.Dataset, points: Iterable[str]) -> tuple[PointCurves, ...]:
        """Return the curves of each of ``points``, in their order.

        Parameters
        ----------
        predictions : xarray.Dataset
            With ``point_position``, ``point_velocity``, ``point_acceleration`` (angle, point,
            axis) and the coordinate ``angle``.
        points : iterable of str
            The points.
        """
        angle = predictions["angle"].values

        def magnitude(name: str, point: str) -> np.ndarray:
            return np.hypot(*(predictions[name].sel(point=point, axis=a).values
                              for a in ("x", "y")))

        return tuple(cls(point, angle,
                         predictions["point_position"].sel(point=point, axis="y").values,
                         magnitude("point_velocity", point),
                         magnitude("point_acceleration", point)) for point in points)


@dataclass(frozen=True)
class SupportCurves:
    """What the support forces' figure shows: each support's force on the frame over phi_F.

    Build it with :meth:`of`.

    Attributes
    ----------
    angle : numpy.ndarray
        phi_F over one revolution, rad.
    supports : tuple of str
        The supports, in the predictions' order.
    horizontal, vertical : numpy.ndarray
        (support, angle) force on the frame along x and y, N.
    """

    angle: np.ndarray
    supports: tuple[str, ...]
    horizontal: np.ndarray
    vertical: np.ndarray

    @classmethod
    def of(cls, predictions: xr.Dataset | SupportCurves) -> SupportCurves:
        """Return the curves of ``support_force`` (angle, support, axis) in ``predictions``."""
        if isinstance(predictions, SupportCurves):
            return predictions
        force = predictions["support_force"]
        values = force.transpose("support", "axis", "angle").to_numpy()
        axes = list(force["axis"].values)
        return cls(predictions["angle"].to_numpy(),
                   tuple(str(s) for s in force["support"].values),
                   values[:, axes.index("x")], values[:, axes.index("y")])


@dataclass(frozen=True)
class MechanismSketch:
    """What the mechanism's sketch shows: the mechanism assembled at one instant.

    Build it with :meth:`of`; :func:`rigval.validation.report.sketch.draw_sketch` draws it.
    Positions in m, global frame.

    Attributes
    ----------
    names : tuple of str
        Every named point, in the solution's order.
    xy : numpy.ndarray
        (point, 2) their positions.
    bodies : tuple of str
        The bodies, in the mechanism's order.
    outlines : tuple of numpy.ndarray
        Per body, its points' positions ordered along its long axis (:func:`body_outlines`).
    centres : tuple of numpy.ndarray
        Per body, the position of its reference point.
    joints : tuple of str
        The joints' points, in the mechanism's order.
    grounded : tuple of bool
        Per joint, whether it pins a body to the ground.
    drivers : tuple of str
        The drivers, in the mechanism's order.
    driver_centres : tuple of numpy.ndarray
        Per driver, the pivot its arrow turns about: the driven body's ground pin, else its
        reference point.
    """

    names: tuple[str, ...]
    xy: np.ndarray
    bodies: tuple[str, ...]
    outlines: tuple[np.ndarray, ...]
    centres: tuple[np.ndarray, ...]
    joints: tuple[str, ...]
    grounded: tuple[bool, ...]
    drivers: tuple[str, ...]
    driver_centres: tuple[np.ndarray, ...]

    @classmethod
    def of(cls, mechanism: Mechanism, configuration: xr.Dataset | None = None, *,
           time: float = 0.0) -> MechanismSketch:
        """Return the sketch of ``mechanism`` assembled at ``time`` of its drive laws.

        Parameters
        ----------
        mechanism : Mechanism
            The mechanism.
        configuration : xarray.Dataset, optional
            It solved at ``time``, with the outputs ``position`` and ``point_position`` (a
            validation's result carries it); default: solved here (:func:`rigval.model.solve`).
        time : float
            The instant, s.
        """
        if configuration is None:
            from rigval.model import solve

            configuration = solve(mechanism, np.array([float(time)]),
                                  outputs=["position", "point_position"])
        names = tuple(str(p) for p in configuration["point"].values)
        xy = configuration["point_position"].isel(time=0).transpose("point", "axis").values
        positions = dict(zip(names, xy, strict=True))
        body_xy = configuration["position"].isel(time=0).sel(coord=["x", "y"]).values
        centres = dict(zip((str(b) for b in configuration["body"].values), body_xy,
                           strict=True))
        outlines = body_outlines(mechanism, positions)

        def pivot(body: str) -> np.ndarray:
            pin = next((j.name for j in mechanism.joints
                        if j.kind == "ground" and j.bodies == (body,)), None)
            return positions[pin] if pin is not None else centres[body]

        return cls(names, xy, tuple(b.name for b in mechanism.bodies),
                   tuple(outlines[b.name] for b in mechanism.bodies),
                   tuple(centres[b.name] for b in mechanism.bodies),
                   tuple(j.name for j in mechanism.joints),
                   tuple(j.kind == "ground" for j in mechanism.joints),
                   tuple(d.name for d in mechanism.drivers),
                   tuple(pivot(d.body) for d in mechanism.drivers))


def body_outlines(mechanism: Mechanism, positions: dict[str, np.ndarray]
                  ) -> dict[str, np.ndarray]:
    """Return, per body, its points' global positions ordered along the body's long axis.

    Parameters
    ----------
    mechanism : Mechanism
        The mechanism.
    positions : dict of str to numpy.ndarray
        Global position (x, y) of every named point, m.

    Returns
    -------
    dict of str to numpy.ndarray
        Body name -> (n, 2) array of its points, sorted along the principal direction.
    """
    outlines = {}
    for body in mechanism.bodies:
        points = np.array([positions[name] for name in body.points])
        if len(points) > 1:
            centred = points - points.mean(axis=0)
            direction = np.linalg.svd(centred, full_matrices=False)[2][0]
            points = points[np.argsort(centred @ direction)]
        outlines[body.name] = points
    return outlines


@dataclass(frozen=True)
class ResidualOrders:
    """What the "Why" section's figure shows of one comparison: its residual per shaft order.

    :func:`rigval.validation.report.why.residual_orders` makes it.

    Attributes
    ----------
    name, units : str
        The comparison and its unit.
    amplitude : numpy.ndarray
        ``|c_k|`` of the mean residual (measured minus model), orders 1 to
        :data:`rigval.validation.report.why.ORDERS`.
    spread : numpy.ndarray
        Twice the revolution-to-revolution standard uncertainty of the mean, per order.
    fitted : numpy.ndarray
        The chosen causes' fitted contribution, (orders, 2) cosine and sine parts.
    cause : str
        The most likely cause's name.
    """

    name: str
    units: str
    amplitude: np.ndarray
    spread: np.ndarray
    fitted: np.ndarray
    cause: str


def shown_points(predictions: xr.Dataset) -> tuple[str, ...]:
    """Return the points whose kinematics the report shows (red in the sketch).

    Parameters
    ----------
    predictions : xarray.Dataset
        The run's predictions (:attr:`~rigval.validation.results.ValidationResult.predictions`).
    """
    if "point" not in predictions.coords:
        return ()
    return tuple(str(p) for p in predictions.coords["point"].values)
