"""The report folder of a prediction: HTML page with figures, CSV tables and netCDF data.

:func:`write_predict_report` writes into one folder

``report.html``
    Self-contained page: drive laws, tip kinematics and path, drive torques and power, support
    forces on the frame with their peaks, joint forces, and the sweep (table and plots).
``cycle.csv``
    One row per main-drive angle: every curve of the page.
``peaks.csv``
    Peak support forces and torques with the angles where they occur.
``sweep.csv``
    One row per sweep point (when a sweep was run).
``prediction.nc``
    The prediction (group ``/prediction``) and the sweep (``/sweep``) as an ``xarray.DataTree``.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from rigval.acquisition.outputs import StagedOutputs
from rigval.acquisition.schema import append_history
from rigval.model import Mechanism, load_mechanism
from rigval.model.predict_tables import (
    cycle_table,
    peak_table,
    rounded_degrees,
    sweep_dims,
    sweep_table,
)
from rigval.validation.report.page import Page
from rigval.validation.report.plots import (
    TITLE_PAD,
    honest_ylim,
    plot_point_kinematics,
    plot_support_forces,
)
from rigval.validation.report.sketch import place_labels, sketch_mechanism
from rigval.validation.version import rigval_version

__all__ = ["PredictReportFiles", "write_predict_report"]

logger = logging.getLogger(__name__)

_MARK_EVERY_DEG = 45


@dataclass(frozen=True)
class PredictReportFiles:
    """Paths of the files a prediction report wrote.

    Attributes
    ----------
    html, cycle_csv, peaks_csv, netcdf : pathlib.Path
        The page, the per-angle table, the peak table and the data file.
    sweep_csv : pathlib.Path or None
        The sweep table, when a sweep was run.
    """

    html: Path
    cycle_csv: Path
    peaks_csv: Path
    netcdf: Path
    sweep_csv: Path | None


def _tip_path_figure(prediction: xr.Dataset, tip: str) -> Figure:
    """Plot the tip path in the plane, the main-drive angle marked every 45 degrees.

    The axes are not to the same scale (the path is long and flat: to scale, its vertical
    range would be a line); labels are placed where they overlap neither each other nor a mark.
    """
    position = prediction["point_position"].sel(point=tip)
    x, y = position.sel(axis="x").values, position.sel(axis="y").values
    fig = Figure(figsize=(7.0, 4.6), layout="constrained")
    ax = fig.add_subplot()
    ax.plot(np.append(x, x[0]), np.append(y, y[0]), color="#c8322b", lw=1.6)
    degrees = np.degrees(prediction["angle"].values)
    marks = np.flatnonzero(np.isclose(np.mod(degrees, _MARK_EVERY_DEG), 0.0, atol=1e-9))
    ax.plot(x[marks], y[marks], "o", color="#1b1f24", ms=4)
    ax.plot(x[0], y[0], "s", color="#1b1f24", ms=6)
    ax.set_xlabel(f"$x_{{{tip}}}$ [m]")
    ax.set_ylabel(f"$y_{{{tip}}}$ [m]")
    ax.grid(True, lw=0.4, alpha=0.6)
    ax.margins(x=0.08)  # room for the labels of the outermost marks
    honest_ylim(ax, y)
    span = float(prediction["tip_vertical_range"])
    ax.set_title(f"path of {tip} (vertical range {span * 1e3:.1f} mm; labels: main shaft angle "
                 r"$\varphi_F$; axes not to scale)", fontsize=10)
    place_labels(fig, ax, x[marks], y[marks], [f"{degrees[i]:.0f}°" for i in marks],
                 avoid=np.column_stack([x, y]))
    return fig


def _angle_panels(prediction: xr.Dataset, panels: list[tuple[str, str, float]],
                  title: str) -> Figure:
    """Curves over phi_F: one panel per (variable, label, scale), one line per label of dim 1."""
    degrees = np.append(np.degrees(prediction["angle"].values), 360.0)
    fig = Figure(figsize=(9.0, 2.6 * len(panels) + 0.6), layout="constrained")
    axes = np.atleast_1d(fig.subplots(len(panels), 1, sharex=True))
    for ax, (name, label, scale) in zip(axes, panels, strict=True):
        variable = prediction[name]
        other = [d for d in variable.dims if d != "angle"]
        if not other:
            values = variable.values
            ax.plot(degrees, np.append(values, values[0]) * scale, lw=1.4)
        else:
            for item in variable[other[0]].values:
                values = variable.sel({other[0]: item}).values
                ax.plot(degrees, np.append(values, values[0]) * scale, lw=1.4, label=str(item))
        honest_ylim(ax, variable.values * scale)
        ax.set_ylabel(label)
        ax.set_xlim(0.0, 360.0)
        ax.set_xticks(np.arange(0, 361, 45))
        ax.grid(True, lw=0.4, alpha=0.6)
    axes[-1].set_xlabel(r"main shaft angle $\varphi_F$ [deg]")
    axes[0].set_title(title, loc="left", fontsize=10, pad=TITLE_PAD)
    if axes[0].get_legend_handles_labels()[0]:  # one legend, above the panels, right
        axes[0].legend(loc="lower right", bbox_to_anchor=(1.0, 1.0), ncol=6, fontsize=8,
                       frameon=False, borderaxespad=0.1)
    return fig


def _joint_force_figure(prediction: xr.Dataset) -> Figure:
    """Horizontal and vertical forces of the chosen joints over phi_F."""
    force = prediction["joint_force"]
    degrees = np.append(np.degrees(prediction["angle"].values), 360.0)
    fig = Figure(figsize=(9.0, 5.6), layout="constrained")
    axes = fig.subplots(2, 1, sharex=True)
    for ax, axis in zip(axes, ("x", "y"), strict=True):
        for joint in force["joint"].values:
            values = force.sel(joint=joint, axis=axis).values
            ax.plot(degrees, np.append(values, values[0]) / 1e3, lw=1.3, label=str(joint))
        ax.set_ylabel(f"{axis} force on first body [kN]")
        honest_ylim(ax, force.sel(axis=axis).values / 1e3)
        ax.set_xlim(0.0, 360.0)
        ax.set_xticks(np.arange(0, 361, 45))
        ax.grid(True, lw=0.4, alpha=0.6)
    axes[-1].set_xlabel(r"main shaft angle $\varphi_F$ [deg]")
    axes[0].set_title("joint forces (on the joint's first body)", loc="left", fontsize=10,
                      pad=TITLE_PAD)
    axes[0].legend(loc="lower right", bbox_to_anchor=(1.0, 1.0), ncol=6, fontsize=8,
                   frameon=False, borderaxespad=0.1)
    return fig


def _sweep_quantities(result: xr.Dataset) -> list[tuple[str, xr.DataArray, str]]:
    """Return the summaries one per panel: (title, values over the sweep dims, unit)."""
    panels = []
    for name, variable in result.data_vars.items():
        unit = variable.attrs.get("units", "")
        extra = [d for d in variable.dims if d in ("support", "driver")]
        if not extra:
            panels.append((str(name), variable, unit))
            continue
        for label in result[extra[0]].values:
            panels.append((f"{name} {label}", variable.sel({extra[0]: label}), unit))
    return panels


def _sweep_figure(result: xr.Dataset) -> Figure:
    """Line plots (one parameter) or filled contours (two parameters) of every summary."""
    dims = sweep_dims(result)
    panels = _sweep_quantities(result)
    columns = 3 if len(panels) > 4 else 2
    rows = math.ceil(len(panels) / columns)
    # Fixed spacing: constrained layout costs seconds on a grid of panels with colour bars.
    fig = Figure(figsize=(4.2 * columns, 3.3 * rows))
    fig.subplots_adjust(left=0.08, right=0.94, bottom=0.6 / (3.3 * rows),
                        top=1 - 0.35 / (3.3 * rows), wspace=0.55, hspace=0.5)
    axes = np.atleast_1d(fig.subplots(rows, columns, squeeze=False)).ravel()
    for ax, (title, values, unit) in zip(axes, panels, strict=False):
        if len(dims) == 1:
            ax.plot(_axis_values(result, dims[0]), values.values, "o-", ms=3, lw=1.3)
            ax.set_xlabel(_axis_label(result, dims[0]))
            ax.set_ylabel(f"[{unit}]")
            ax.grid(True, lw=0.4, alpha=0.6)
        else:
            data = values.transpose(dims[1], dims[0]).values
            grid = (_axis_values(result, dims[0]), _axis_values(result, dims[1]))
            filled = ax.contourf(*grid, data, levels=14, cmap="viridis")
            ax.contour(*grid, data, levels=7, colors="white", linewidths=0.5)
            fig.colorbar(filled, ax=ax, label=f"[{unit}]")
            ax.set_xlabel(_axis_label(result, dims[0]))
            ax.set_ylabel(_axis_label(result, dims[1]))
        ax.set_title(title.replace("_", " "), fontsize=9)
    for ax in axes[len(panels):]:
        ax.set_visible(False)
    return fig


def _axis_values(result: xr.Dataset, dim: str) -> np.ndarray:
    """Return a sweep coordinate for plotting: angles in degrees, the rest as stored."""
    values = result[dim].values
    return np.degrees(values) if result[dim].attrs.get("units") == "rad" else values


def _axis_label(result: xr.Dataset, dim: str) -> str:
    unit = result[dim].attrs.get("units", "")
    return f"{dim} [{'deg' if unit == 'rad' else unit}]"


def _write_netcdf(prediction: xr.Dataset, sweep: xr.Dataset | None, path: Path,
                  command: str | None) -> None:
    """Write the prediction and the sweep as groups of one netCDF file (zlib 4, docs/predict.md)."""
    children = {"prediction": prediction}
    if sweep is not None:  # netCDF names: a dot in a dimension name is avoided
        children["sweep"] = sweep.rename({d: d.replace(".", "_") for d in sweep_dims(sweep)})
    root = xr.Dataset(attrs={
        "Conventions": "CF-1.10", "title": prediction.attrs.get("title", "rigval prediction"),
        "rigval_version": rigval_version()})
    append_history(root, (command or "validation.predict").removeprefix("rigval "))
    tree = xr.DataTree.from_dict({"/": root, **{f"/{k}": v for k, v in children.items()}})
    encoding = {f"/{k}": {name: {"zlib": True, "complevel": 4} for name in v.data_vars}
                for k, v in children.items()}
    tree.to_netcdf(path, engine="netcdf4", encoding=encoding)  # core dependency, no extra


def _mechanism_sketch(prediction: xr.Dataset, mechanism: Mechanism | None,
                      tip: str) -> Figure | None:
    """Return the sketch of the predicted mechanism, or None if it cannot be had."""
    if mechanism is None:
        try:
            mechanism = load_mechanism(str(prediction.attrs.get("mechanism_source", "")))
        except (OSError, ValueError) as error:  # a mechanism given as a dict, a moved file
            logger.info("no mechanism sketch: %s", error)
            return None
    return sketch_mechanism(mechanism, highlight=[tip])


def write_predict_report(prediction: xr.Dataset, out_dir: str | Path, *,
                         sweep: xr.Dataset | None = None, command: str | None = None,
                         mechanism: Mechanism | None = None) -> PredictReportFiles:
    """Write the report folder of a prediction (and optionally a sweep).

    Parameters
    ----------
    prediction : xarray.Dataset
        A result of :func:`rigval.model.predict.predict`.
    out_dir : str or pathlib.Path
        Folder to write into (created if missing).
    sweep : xarray.Dataset, optional
        A result of :func:`rigval.model.predict.sweep`.
    command : str, optional
        The command line that produced the report (shown on the page).
    mechanism : Mechanism, optional
        The mechanism, for the sketch on the page; default read from the prediction's
        ``mechanism_source`` (no sketch if that file cannot be read).

    Returns
    -------
    PredictReportFiles
        The paths written.
    """
    out = Path(out_dir)
    tip = str(prediction.attrs.get("tip_point", "P1"))
    cycles = cycle_table(prediction)
    peaks = peak_table(prediction)
    files = PredictReportFiles(html=out / "report.html", cycle_csv=out / "cycle.csv",
                               peaks_csv=out / "peaks.csv", netcdf=out / "prediction.nc",
                               sweep_csv=out / "sweep.csv" if sweep is not None else None)
    page = Page(f"Prediction: {prediction.attrs.get('mechanism', '')}",
                subtitle=f"{prediction.attrs.get('frequency_hz', float('nan')):.4g} Hz, "
                         f"{prediction.attrs.get('n_points')} points per cycle")
    page.section("Excitation")
    page.paragraph("The model's answer to drive settings, without measurement (section 5 of "
                   "the paper). "
                   "Angles are the main-drive angle phi_F from its position at t = 0.")
    facts = {"mechanism": prediction.attrs.get("mechanism"),
             "mechanism file": prediction.attrs.get("mechanism_source"),
             "cycle frequency [Hz]": prediction.attrs.get("frequency_hz"),
             "main drive": prediction.attrs.get("main_drive")}
    if command:
        facts["command"] = command
    page.facts(facts)
    page.preformatted(str(prediction.attrs.get("drive_laws", "")))
    sketch = _mechanism_sketch(prediction, mechanism, tip)
    if sketch is not None:
        page.figure(sketch, caption="the mechanism at t = 0: bodies (letters), joints (open "
                                    "circles), ground pins (hatched: the supports), drives "
                                    f"(red arrows); the tip {tip} in red")
    page.figure(_angle_panels(prediction, [("drive_speed", "speed [rad/s]", 1.0),
                                           ("drive_acceleration", "acceleration [rad/s2]", 1.0)],
                              "drive speeds and accelerations"),
                caption="the excitation: angular speed and acceleration of every drive")
    page.section(f"Tip {tip}")
    page.facts({
        f"vertical range of the {tip} path [m]": float(prediction["tip_vertical_range"]),
        f"peak |a_{tip}| [m/s2]": float(prediction["tip_acceleration_peak"]),
        "at phi_F [deg]": rounded_degrees(float(prediction["tip_acceleration_peak_angle"])),
    })
    page.figure(plot_point_kinematics(prediction, tip),
                caption=f"{tip}: vertical position, absolute speed and acceleration over a cycle")
    page.figure(_tip_path_figure(prediction, tip), caption=f"path of {tip} in the plane")
    page.section("Drive torques and power")
    page.table(peaks[peaks["quantity"] == "drive torque"].to_dict("records"),
               columns=["where", "peak", "angle_deg", "rms", "unit"],
               caption="drive torques: peak |T|, the angle where it occurs, RMS")
    page.facts({"net drive work per cycle [J] (0 without losses)":
                float(prediction["cycle_work"])})
    page.figure(_angle_panels(prediction, [("driver_torque", "torque [kN m]", 1e-3),
                                           ("drive_power", "power [kW]", 1e-3)],
                              "drive torques (on the driven body) and drive power"),
                caption="drive torques and power over a cycle")
    page.section("Support forces on the frame")
    page.paragraph("Force exerted ON THE FRAME at each ground pin (minus the model's joint "
                   "force on the body).")
    page.table(peaks[peaks["quantity"] == "support force on frame"].to_dict("records"),
               columns=["where", "component", "peak", "angle_deg", "unit"],
               caption="peak absolute support forces and the angles where they occur")
    page.figure(plot_support_forces(prediction), caption="support forces on the frame")
    if prediction.sizes.get("joint", 0):
        page.section("Joint forces")
        page.figure(_joint_force_figure(prediction), caption="forces of the chosen joints")
    table = None if sweep is None else sweep_table(sweep)
    if sweep is not None and table is not None:
        page.section("Sweep")
        page.facts({"parameters": ", ".join(sweep_dims(sweep)),
                    "points": sweep.attrs.get("points"),
                    "model solves": sweep.attrs.get("model_solves"),
                    "elapsed [s]": sweep.attrs.get("elapsed_s"),
                    "points per cycle": sweep.attrs.get("n_points")})
        page.figure(_sweep_figure(sweep), caption="sweep summaries")
        page.wide_table(table.to_dict("records"), key=list(table.columns),
                        caption="sweep summaries per point (also in sweep.csv)")
    # every file under a temporary name first: a failure leaves no half-written folder
    with StagedOutputs(out) as stage:
        cycles.to_csv(stage.path(files.cycle_csv), index=False)
        peaks.to_csv(stage.path(files.peaks_csv), index=False)
        if table is not None and files.sweep_csv is not None:
            table.to_csv(stage.path(files.sweep_csv), index=False)
        page.write(stage.path(files.html))
        _write_netcdf(prediction, sweep, stage.path(files.netcdf), command)
    logger.info("wrote the prediction report to %s", out)
    return files
