"""The report folder of one validation.

:func:`write_report` writes, from a :class:`~rigval.validation.results.ValidationResult` alone:

``report.html``
    Self-contained (figures inlined as SVG, style inline; opens offline): summary and pass/fail,
    per comparison the overlay against phi_F, the residual and the metric table with the baseline
    rows; alignment diagnostics; predictions of what was not measured (support forces, point
    kinematics, as the paper's figs. 15-17); numerics; the scene and input files for reproduction.
``metrics.csv``, ``metrics.json``
    One row per comparison, row kind (model, baseline median, baseline worst) and metric.
``alignment.json``
    Per stream: offset, drift, residual, events matched, missing and spurious, gaps.
``<scene>.nc``
    The run's netCDF file (docs/formats.md).
"""

from __future__ import annotations

import csv
import dataclasses
import json
import logging
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import xarray as xr

from rigval.acquisition.json_values import json_ready
from rigval.acquisition.outputs import atomic_output, staged_folder, write_text_atomic
from rigval.validation.diagnosis.rigidity import (
    RigidityEvidence,
    evidence_record,
    run_rigidity,
)
from rigval.validation.health import health_dataset
from rigval.validation.metrics.iso18571 import IsoParameters
from rigval.validation.nc_summary import root_summary
from rigval.validation.report.drawing import Drawers, Drawing
from rigval.validation.report.figure_groups import RUN_GROUPS, draw_figure_groups
from rigval.validation.report.figure_inputs import (
    ComparisonCurves,
    MechanismSketch,
    PointCurves,
    StreamCurves,
    SupportCurves,
    shown_points,
)
from rigval.validation.report.page import Page
from rigval.validation.report.why import start_why_figures, why_section
from rigval.validation.results import (
    Assembly,
    ComparisonResult,
    ModelledRun,
    ValidationResult,
)
from rigval.validation.verdict import failure_reasons, run_verdict
from rigval.validation.version import rigval_version

if TYPE_CHECKING:
    from collections.abc import Mapping

__all__ = ["HELD_BYTES", "file_groups", "start_figures", "start_model_figures", "start_sketch",
           "write_metrics", "write_netcdf", "write_report"]

logger = logging.getLogger(__name__)

#: The page's figures drawn as SVG text (:func:`start_figures`), by group name.
_Figures = dict[str, list[str]]

#: Scores in each comparison's main table (all scores follow in a folded table).
_PREFERRED = ("iso18571_periodic.rating", "iso18571_periodic.grade",
              "iso18571_periodic.corridor", "iso18571_periodic.phase",
              "iso18571_periodic.magnitude", "iso18571_periodic.slope", "sprague_geers.magnitude",
              "sprague_geers.phase", "sprague_geers.comprehensive", "russell.comprehensive",
              "nrmse", "pearson_r", "peak_error.relative_error", "peak_error.shift",
              "circular_lag.lag_deg", "vv20.peak.error", "vv20.peak.u_val",
              "vv20.peak.resolved", "vv20.rms.error", "vv20.rms.u_val", "vv20.rms.resolved")


def write_metrics(result: ValidationResult, out_dir: Path) -> list[Path]:
    """Write ``metrics.csv`` and ``metrics.json`` and return their paths."""
    rows = result.metric_rows()
    csv_path = out_dir / "metrics.csv"
    columns = ["comparison", "row", "metric", "value", "threshold", "passed"]
    with atomic_output(csv_path) as partial, partial.open("w", newline="",
                                                          encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=columns)
        writer.writeheader()
        for row in rows:
            writer.writerow({k: "" if row[k] is None else row[k] for k in columns})
    json_path = out_dir / "metrics.json"
    document = {
        "verdict": json_ready(run_verdict(result)),
        "scene": str(result.scene.path), "scene_sha256": result.scene.sha256,
        "passed": result.passed, "speed_rev_s": result.speed_rev_s, "cycles": result.n_cycles,
        "rows": [{k: json_ready(v) for k, v in row.items()} for row in rows],
        "diagnosis": result.diagnosis.as_dict() if result.diagnosis is not None else None,
    }
    write_text_atomic(json_path, json.dumps(document, indent=2) + "\n")
    return [csv_path, json_path]


def write_rigidity(result: ValidationResult, out_dir: Path,
                   rigidity: Mapping[str, RigidityEvidence] | None = None) -> Path:
    """Write ``rigidity.json``: each comparison's residual spectra and resonances.

    See :func:`rigval.validation.diagnosis.rigidity.evidence_record` and docs/diagnosis.md.

    Parameters
    ----------
    result : ValidationResult
        The validation.
    out_dir : pathlib.Path
        The folder.
    rigidity : mapping of str to RigidityEvidence, optional
        The run's evidence by comparison, analysed before (``rigval identify``:
        :func:`~rigval.validation.diagnosis.rigidity.run_rigidity_pair`); default: its
        diagnosis's, else :func:`~rigval.validation.diagnosis.rigidity.run_rigidity` here.
    """
    if rigidity is None:
        found = result.diagnosis.rigidity if result.diagnosis is not None else {}
        rigidity = found or run_rigidity(result)
    document = {name: evidence_record(evidence) for name, evidence in rigidity.items()}
    return write_text_atomic(out_dir / "rigidity.json", json.dumps(document, indent=1) + "\n")


def write_alignment(result: ValidationResult, out_dir: Path) -> Path:
    """Write ``alignment.json``: per stream offset, drift, residual, events, gaps, health.

    ``health`` lists the sensor health findings of the stream's channels
    (:meth:`rigval.processing.health.Finding.record`).
    """
    path = out_dir / "alignment.json"
    document = {name: {k: json_ready(v) for k, v in a.summary().items()}
                for name, a in result.alignment.items()}
    for name, summary in document.items():
        summary["health"] = [f.record() for f in result.health
                             if f.channel.split(".")[0] == name]
    return write_text_atomic(path, json.dumps(document, indent=2) + "\n")


def _encoding(ds: xr.Dataset) -> dict[str, dict[str, Any]]:
    """Return the encoding: zlib level 4 with shuffle for numeric variables (docs/formats.md)."""
    return {name: {"zlib": True, "complevel": 4, "shuffle": True}
            for name, var in ds.variables.items()
            if var.dtype.kind in "fiub" and var.ndim > 0}


def write_netcdf(result: ValidationResult, path: Path) -> Path:
    """Write the run's DataTree to netCDF-4 (groups, zlib 4, provenance in global attributes).

    The root group holds a summary (verdicts, inputs, group paths;
    :func:`rigval.validation.nc_summary.root_summary`) for readers that open it with plain
    ``xr.open_dataset``.

    Parameters
    ----------
    result : ValidationResult
        Its ``tree`` holds ``/raw/<stream>``, ``/aligned``, ``/angle``, ``/model``,
        ``/validation``; measured values are float32 there, derived ones float64.
    path : pathlib.Path
        The file to write.
    """
    groups, encoding = file_groups(result)
    with atomic_output(path) as partial:
        _write_groups(groups, partial, encoding)
    return path


def _depth(path: str) -> int:
    """Return a group's depth in the file: 0 for the root ``/``, 1 for ``/angle``, ..."""
    return path.rstrip("/").count("/")


def file_groups(result: ValidationResult
                ) -> tuple[dict[str, xr.Dataset], dict[str, dict[str, Any]]]:
    """Return the groups of the run's netCDF file and their encodings (:func:`write_netcdf`).

    The run's tree's groups with ``/health`` and the root's summary and provenance, breadth
    first as ``xr.DataTree.from_dict`` of them lists its groups (which would hold the same
    Datasets: the run's tree is one already, and the root has no coordinates to inherit);
    numeric variables zlib level 4 with shuffle (:func:`_encoding`).
    """
    scene = result.scene
    nodes = {node.path: node.to_dataset(inherit=False) for node in result.tree.subtree}
    nodes["/health"] = health_dataset(result.health)
    # breadth first: /health among the root's children
    nodes = dict(sorted(nodes.items(), key=lambda item: _depth(item[0])))
    groups = [path for path, ds in nodes.items() if path != "/" and ds.variables]
    # what plain xr.open_dataset shows
    nodes["/"] = root_summary(result, nodes["/"], groups, result.input_digests).assign_attrs({
        "Conventions": "CF-1.13",
        "title": scene.title,
        "rigval_version": rigval_version(),
        "scene_toml": scene.text,
        "scene_sha256": scene.sha256,
        "scene_file": str(scene.path),
        "validation_passed": int(result.passed),
    })
    encoding = {path: _encoding(ds) for path, ds in nodes.items() if ds.variables}
    return nodes, encoding


#: Bytes of variable data :class:`_DeferredWrites` holds at most before writing them: the
#: encoded copies it keeps (times as numbers, strings) stay small beside a long record's groups.
HELD_BYTES = 2**26


class _DeferredWrites:
    """The data of a file's variables, written when many are defined or at the end.

    Takes the place of xarray's ``ArrayWriter`` in :meth:`xarray.Dataset.dump_to_store`, which
    writes each variable's data as soon as it is defined: netCDF-C then leaves define mode for
    each write and writes the metadata of the whole file again on entering it for the next
    variable (about 0.5 ms per variable of a run's file, most of its writing time). Held data
    reaching :data:`HELD_BYTES` are written at once (one switch of mode per such batch).
    """

    def __init__(self) -> None:
        self._writes: list[tuple[Any, Any]] = []
        self._held = 0

    def add(self, source: Any, target: Any, region: Any = None) -> None:
        """Hold ``source`` for ``target`` (a whole variable); write what is held when it is much.

        Parameters
        ----------
        source : array-like
            The variable's encoded data.
        target : array-like
            Where it goes (xarray's wrapper of the netCDF4 variable).
        region : None
            Whole variables only (xarray passes none when writing a new file).
        """
        if region is not None:
            raise NotImplementedError("deferred writes are of whole variables")
        self._writes.append((source, target))
        self._held += int(getattr(source, "nbytes", 0))
        if self._held >= HELD_BYTES:
            self.write()

    def write(self) -> None:
        """Write the held data, in the order the variables were defined."""
        for source, target in self._writes:
            target[...] = source
        self._writes.clear()
        self._held = 0


def _write_groups(groups: Mapping[str, xr.Dataset], path: Path,
                  encoding: Mapping[str, Mapping[str, Any]]) -> None:
    """Write groups to netCDF-4 as ``DataTree.to_netcdf(path, engine="netcdf4")`` writes a tree.

    The tree ``xr.DataTree.from_dict(groups)`` whose nodes hold ``groups``' Datasets, written
    with the same groups, dimensions, variables, attributes, encodings and data, in the same
    order, without building it; the variables defined before their data is written
    (:class:`_DeferredWrites`).

    Parameters
    ----------
    groups : mapping of str to xarray.Dataset
        Each group's own variables by path, the root ``/`` first, every group after its parent
        (breadth first, as such a tree lists them).
    path : pathlib.Path
        The file to write (overwritten).
    encoding : mapping of str to mapping
        Per group path, the encoding of its variables (as for ``DataTree.to_netcdf``).
    """
    root = xr.backends.NetCDF4DataStore.open(path, mode="w", format="NETCDF4")
    writes = _DeferredWrites()
    try:
        for group, ds in groups.items():
            store = root if group == "/" else root.get_child_store(group)
            ds.dump_to_store(store, writer=writes, encoding=encoding.get(group))
        writes.write()
    finally:
        root.close()


def _metric_table(comparison: ComparisonResult, *, everything: bool = False
                  ) -> list[dict[str, Any]]:
    """Rows: metric; columns: model, baseline median, baseline worst, threshold, status.

    The main scores and every score with a threshold; with ``everything`` all scores.
    """
    checks = {c.metric: c for c in comparison.checks}
    if everything:
        names = list(comparison.scores)
    else:
        names = [m for m in _PREFERRED if m in comparison.scores]
        names += [m for m in checks if m not in names]
    rows = []
    for metric in names:
        row: dict[str, Any] = {"metric": metric, "model": comparison.scores.get(metric)}
        for which, scores in comparison.baseline.items():
            row[f"baseline {which}"] = scores.get(metric)
        check = checks.get(metric)
        row["threshold"] = check.threshold if check else ""
        row["status"] = ("pass" if check.passed else "fail") if check else ""
        rows.append(row)
    return rows


def _summary_rows(result: ValidationResult) -> list[dict[str, Any]]:
    """One row per comparison, the status first: narrow enough for a 1024 px window.

    Why a comparison failed is listed above the table (:func:`failure_reasons`).
    """
    return [{
        "comparison": c.name, "status": "pass" if c.passed else "fail",
        "V&V 20": "detected" if c.scores.get("vv20.curve.detected") else "not detected",
        "E": c.scores.get("vv20.curve.error"), "u_val": c.scores.get("vv20.curve.u_val"),
        "unit": c.units, "ISO rating": c.scores.get("iso18571_periodic.rating"),
        "grade": c.scores.get("iso18571_periodic.grade"),
        "NRMSE": c.scores.get("nrmse"), "r": c.scores.get("pearson_r"),
        "revolutions": int(c.cycles.shape[0]),
    } for c in result.comparisons]


def _revolutions_text(result: ValidationResult) -> str:
    """Return the revolutions recorded, and those each comparison used where fewer were valid."""
    used = sorted({int(c.cycles.shape[0]) for c in result.comparisons})
    if used in ([], [result.n_cycles]):
        return f"{result.n_cycles}"
    span = f"{used[0]}" if len(used) == 1 else f"{used[0]}-{used[-1]}"
    return (f"{result.n_cycles} of the main shaft; {span} by comparison (column 'revolutions': "
            "revolutions with a gap in a stream are left out of its comparisons)")


def _drives_text(result: ValidationResult) -> str:
    """How the model's drives were excited, with the law's speed for analytic drives."""
    if result.scene.model.drives == "measured":
        law = result.drive_law_angles
        names = ", ".join(
            f"{d.name} <- {d.encoder} (angle at the reference pulse {d.angle_at_reference:.5g} "
            f"rad; the drive law gives {law.get(d.name, float('nan')):.5g} rad)"
            for d in result.scene.model.drivers.values())
        return f"measured: {names}, averaged over {result.n_cycles} revolutions per angle"
    period = float(result.tree["/model"].attrs.get("cycle_period_s", float("nan")))
    return f"analytic: the mechanism file's laws, {1.0 / period:.4g} rev/s"


def _alignment_rows(result: ValidationResult) -> list[dict[str, Any]]:
    """Return the clock model of each stream (the first of the two alignment tables)."""
    return [{"stream": name, "device": a.device, "offset [s]": f"{a.offset_s:.6f}",
             "offset ±95 % [µs]": a.offset_u95_s * 1e6, "drift [ppm]": a.drift_ppm,
             "drift ±95 % [ppm]": a.drift_u95_ppm, "residual rms [µs]": a.residual_rms_s * 1e6,
             "input delay [ms]": a.input_delay_s * 1e3}
            for name, a in result.alignment.items()]


def _pulse_rows(result: ValidationResult) -> list[dict[str, Any]]:
    """Return each stream's reference pulses and segments (the second alignment table)."""
    return [{"stream": name, "pulses matched": a.events_matched, "missing": a.events_missing,
             "spurious": a.events_spurious,
             "periods decided by": a.periods_decided_by or "reference",
             "segments": a.segments, "gaps": len(a.gaps),
             "samples dropped": sum(int(r["samples_dropped"]) for r in a.segment_table)}
            for name, a in result.alignment.items()]


def _dropped_rows(result: ValidationResult) -> list[dict[str, Any]]:
    """One row per segment whose samples could not be aligned, with the reason."""
    return [{"stream": name, "segment": r["segment"], "device time [s]":
             f"{r['device_time_s'][0]:.3f} - {r['device_time_s'][1]:.3f}",
             "samples dropped": r["samples_dropped"], "why": r["dropped_because"]}
            for name, a in result.alignment.items() for r in a.segment_table
            if r["samples_dropped"]]


def _peaks(predictions: xr.Dataset) -> list[dict[str, Any]]:
    rows = []
    force = predictions["support_force"]
    angle = np.degrees(predictions["angle"].values)
    for support in force["support"].values:
        for axis in ("x", "y"):
            values = force.sel(support=support, axis=axis).values
            i_max, i_min = int(np.argmax(values)), int(np.argmin(values))
            rows.append({"support": str(support), "axis": axis,
                         "max [N]": float(values[i_max]), "phi_F at max [deg]": float(angle[i_max]),
                         "min [N]": float(values[i_min]),
                         "phi_F at min [deg]": float(angle[i_min])})
    return rows


def _summary(page: Page, result: ValidationResult, status: str) -> None:
    scene = result.scene
    page.section("Summary")
    verdict = run_verdict(result)
    page.paragraph(f"ASME V&V 20: {verdict['statement']}",
                   css_class="bad" if verdict["detected"] else "ok")
    page.paragraph(f"Result: {status}", css_class="ok" if result.passed else "bad")
    failed = [c for c in result.comparisons if not c.passed]
    if failed:
        page.paragraph(f"{len(failed)} of {len(result.comparisons)} comparisons failed a "
                       "threshold:")
        page.items([f"{c.name}: {'; '.join(failure_reasons(c))}" for c in failed],
                   css_class="failures")
    if result.health:
        page.paragraph(f"Sensor health: {len(result.health)} finding"
                       f"{'s' if len(result.health) > 1 else ''} (docs/processing.md):")
        page.items([f.line() for f in result.health],
                   css_class="failures" if any(not f.trusted for f in result.health) else None)
    page.facts({
        "scene": scene.path, "scene sha256": scene.sha256, "mechanism": scene.mechanism,
        "drives": _drives_text(result),
        "angle grid": f"{scene.angle.points_per_revolution} points per revolution, "
                      f"{scene.angle.interpolation} interpolation",
        "revolutions compared": _revolutions_text(result),
        "mean main-shaft speed [rev/s]": result.speed_rev_s,
    })
    note = _note_block(scene.note, result.note)
    if note is not None:
        page.paragraph(note[0])
        page.preformatted(note[1])
    page.table(_summary_rows(result), caption="comparisons")


def _note_block(path: Path | None, text: str | None) -> tuple[str, str] | None:
    """Return the operator's note as (caption naming its file, text), or None without one."""
    if path is None or text is None:
        return None
    return f"Operator's note, from {path}:", text


def _comparisons(page: Page, result: ValidationResult, figures: _Figures) -> None:
    page.section("Comparisons")
    page.paragraph("Measured against the model over the main shaft angle phi_F. Light lines: each "
                   "revolution; band: 5th to 95th percentile over revolutions; the baseline rows "
                   "score each measured revolution against the measured mean (median and worst "
                   "revolution): the agreement no model can beat.")
    for comparison, figure in zip(result.comparisons, figures["comparisons"], strict=True):
        page.section(f"{comparison.name}: {comparison.spec.measured_text} against "
                     f"{comparison.spec.model}", level=3)
        scale, scale_units = comparison.spec.scale, comparison.spec.scale_units
        # a scale of 1 is the default: the summary table's column shows it once for all
        page.facts({**({} if (scale, scale_units) == (1.0, "1") else {
                        "scale": f"{scale:g}" + ("" if scale_units == "1" else f" {scale_units}")}),
                    "low-pass [Hz]": comparison.spec.lowpass_hz,
                    "model offset added": f"{comparison.offset:.4g} {comparison.units}"
                    if comparison.spec.remove_offset else "none"})
        page.figure(figure,
                    caption=f"{comparison.name}: overlay, residual and harmonic orders")
        page.table(_metric_table(comparison), caption=f"{comparison.name}: metrics")
        page.table(_metric_table(comparison, everything=True),
                   collapsed=f"all {len(comparison.scores)} scores of {comparison.name}")


def _alignment(page: Page, result: ValidationResult, figures: _Figures) -> None:
    page.section("Alignment")
    page.table(_alignment_rows(result),
               caption="clock model per stream: t_ref = offset + (1 + drift) t_device per "
                       "gap-free segment, fitted on the reference pulses")
    page.table(_pulse_rows(result), caption="reference pulses and segments per stream")
    dropped = _dropped_rows(result)
    if dropped:
        page.table(dropped, caption="samples that could not be aligned (marked invalid, left "
                                    "out of every comparison)")
    page.figure(figures["pulse_edges"][0],
                caption="one reference pulse as each stream recorded it (raw signal, reference "
                        "timeline after alignment) with the detected edges dashed")
    page.figure(figures["clock_residuals"][0],
                caption="clock-fit residuals at the matched reference events")
    page.figure(figures["stream_coverage"][0],
                caption="streams on the reference timeline; gaps in red")
    gap_rows = [{"stream": name, **g} for name, a in result.alignment.items() for g in a.gaps]
    if gap_rows:
        page.table(gap_rows, caption="gaps (stream clock)")


def _predictions(page: Page, result: ValidationResult, figures: _Figures) -> None:
    page.section("Predictions")
    page.paragraph("What the model says about quantities that were not measured, for the drive "
                   "motion of this run (the paper's figs. 15 to 17).")
    points = shown_points(result.predictions)
    page.figure(figures["sketch"][0],
                caption="the mechanism at t = 0 of its file's drive laws: bodies (letters), "
                        "joints (open circles), ground pins (hatched: the supports), drives "
                        f"(red arrows); red: {', '.join(points) or 'no point'}")
    for point, figure in zip(points, figures["points"], strict=True):
        page.figure(figure, caption=f"{point}: vertical position, absolute speed and acceleration")
    if "support_force" in result.predictions:
        page.figure(figures["support_forces"][0],
                    caption="support forces on the frame (minus the ground pins' joint forces)")
        page.table(_peaks(result.predictions), caption="support force extremes")


#: The groups as the drawers take them besides the comparisons (two shares of those first),
#: each part with only its own data (:func:`_data`), so that a part of one page equal to one
#: of another page of the command is drawn once
#: (:class:`~rigval.validation.report.drawing.Drawers`): ``rigval identify``'s identified run
#: has the nominal run's alignment and kinematics.
FIGURE_PARTS = (("pulse_edges", "clock_residuals", "stream_coverage"), ("sketch",),
                ("points",), ("support_forces",))


def _data(result: ValidationResult) -> dict[str, tuple[Any, int]]:
    """Return each figure group's data (small: it travels to a drawer) and figure count."""
    return {"comparisons": (tuple(ComparisonCurves.of(c) for c in result.comparisons),
                            len(result.comparisons)),
            **_model_data(ModelledRun(result.alignment, result.mechanism, result.configuration,
                                      result.predictions))}


def _model_data(run: ModelledRun) -> dict[str, tuple[Any, int]]:
    """:func:`_data` of the groups of :data:`FIGURE_PARTS`: the alignment's and the model's.

    Plain arrays (:mod:`~rigval.validation.report.figure_inputs`): a drawer draws them with
    numpy and matplotlib alone.
    """
    predictions, points = run.predictions, shown_points(run.predictions)
    support = SupportCurves.of(predictions) if "support_force" in predictions else None
    streams = {name: StreamCurves.of(a) for name, a in run.alignment.items()}
    return {**dict.fromkeys(("pulse_edges", "clock_residuals", "stream_coverage"),
                            (streams, 1)),
            "sketch": _sketch_data(Assembly(run.mechanism, run.configuration, points)),
            "points": (PointCurves.of(predictions, points), len(points)),
            "support_forces": (support, int(support is not None))}


def _sketch_data(assembly: Assembly) -> tuple[Any, int]:
    """:func:`_data` of the sketch: the mechanism assembled, the points drawn red."""
    return (MechanismSketch.of(assembly.mechanism, assembly.configuration),
            assembly.shown_points), 1


def _start_part(drawing: Drawing, data: Mapping[str, tuple[Any, int]],
                names: tuple[str, ...]) -> None:
    """Start the groups ``names`` with their data, as one call.

    Equal data give an equal call, so that a part handed early is recognised when it is handed
    again (:class:`~rigval.validation.report.drawing.Drawers` shares its drawing).
    """
    drawing.start(draw_figure_groups, tuple(data[name][0] for name in names), names,
                  sum(data[name][1] for name in names))


def _start_parts(drawing: Drawing, data: Mapping[str, tuple[Any, int]]) -> None:
    for names in FIGURE_PARTS:
        _start_part(drawing, data, names)


def start_sketch(assembly: Assembly, drawers: Drawers) -> None:
    """Hand the mechanism's sketch to ``drawers`` now, before the run's data are read.

    Given as the pipeline's ``after_assembly`` (:func:`rigval.validation.pipeline.run_scene`),
    the drawers draw it while the data are read and aligned; :func:`start_figures` of the run
    then hands the same part with equal inputs and gets this drawing back.

    Parameters
    ----------
    assembly : Assembly
        The scene's mechanism assembled at t = 0.
    drawers : rigval.validation.report.drawing.Drawers
        From :func:`rigval.validation.report.drawing.standby_drawers`.
    """
    _start_part(Drawing(drawers), {"sketch": _sketch_data(assembly)}, ("sketch",))


def start_model_figures(run: ModelledRun, drawers: Drawers) -> None:
    """Hand the figures of the alignment and the model to ``drawers`` now.

    A run's model is solved before its comparisons are made: given as the pipeline's
    ``after_model`` (:func:`rigval.validation.pipeline.run_scene`), the drawers draw these
    figures while the pipeline goes on (they would otherwise wait for the comparisons).
    :func:`start_figures` of the run then hands the same parts with equal inputs, and
    ``drawers`` give it these drawings instead of drawing them again
    (:meth:`~rigval.validation.report.drawing.Drawers.submit`).

    Parameters
    ----------
    run : ModelledRun
        The run after its model stage.
    drawers : rigval.validation.report.drawing.Drawers
        From :func:`rigval.validation.report.drawing.standby_drawers`.
    """
    _start_parts(Drawing(drawers), _model_data(run))


def start_figures(result: ValidationResult, drawers: Drawers | None = None) -> Drawing:
    """Start drawing the page's figures as SVG text, by the ``drawers`` where given.

    No figure but the "Why" section's shows the diagnosis, so the drawing may start before
    :func:`rigval.validation.diagnosis.explain.attach_diagnosis` and the drawers draw beside
    it (:func:`rigval.validation.run.validate.validate_scene`); :func:`write_report` collects
    the figures. Parts handed before by :func:`start_model_figures` are not drawn again.

    Parameters
    ----------
    result : ValidationResult
        The validation, with or without its diagnosis.
    drawers : rigval.validation.report.drawing.Drawers, optional
        From :func:`rigval.validation.report.drawing.standby_drawers`; none: the figures are
        drawn here when the page asks for them.

    Returns
    -------
    rigval.validation.report.drawing.Drawing
        Hand it to :func:`write_report` of the same run.
    """
    drawing = Drawing(drawers)
    data = _data(result)
    curves = data["comparisons"][0]
    half = (len(curves) + 1) // 2  # the comparisons, a third of the drawing, in two shares
    for share in (curves[:half], curves[half:]):
        drawing.start(draw_figure_groups, (share,), ("comparisons",), len(share))
    _start_parts(drawing, data)
    return drawing


def _numerics(page: Page, result: ValidationResult) -> None:
    page.section("Numerics")
    numerics = result.numerics
    stage_rows = [{"stage": k, "time [s]": v} for k, v in numerics.stage_seconds.items()]
    stage_rows.append({"stage": "total", "time [s]": sum(numerics.stage_seconds.values())})
    page.table(stage_rows, caption="time per stage")
    page.table([{"check": k, "value": v} for k, v in numerics.model_residuals.items()],
               caption=f"model numerics (this run: {numerics.model_points} angle points; power "
                       "balance on the mechanism file's drive law)")
    page.table([{"comparison": k, "max error / range": v} for k, v in numerics.grid_error.items()],
               caption=f"angle grid: model on {result.scene.angle.points_per_revolution} points "
                       "against a grid four times finer")


def _reproduction(page: Page, result: ValidationResult) -> None:
    scene = result.scene
    page.section("Reproduction")
    page.facts({"rigval version": rigval_version(),
                "angle grid": f"{scene.angle.points_per_revolution} points per revolution of "
                              f"phi_F, {scene.angle.interpolation} interpolation, anti-alias "
                              "low-pass at 0.4 times the grid rate before resampling",
                "reference signal of the metrics": "the measured mean over the revolutions",
                "ISO/TS 18571 parameters": ", ".join(
                    f"{k} {v}" for k, v in dataclasses.asdict(IsoParameters()).items())})
    page.table([{"file": str(p), "sha256": digest} for p, digest in result.input_digests],
               caption="input files")
    page.preformatted(scene.text)


def _build_page(result: ValidationResult, drawing: Drawing) -> Page:
    status = "PASSED" if result.passed else "FAILED"
    # SVG figures: text as text (see page.figure_svg), about a third less drawing time than PNG
    page = Page(f"rigval validation: {result.scene.title}",
                subtitle=f"{status} · {len(result.comparisons)} comparisons · "
                         f"{result.n_cycles} revolutions at {result.speed_rev_s:.3f} rev/s",
                figure_format="svg")
    figures = {name: drawing.texts(name) for name in RUN_GROUPS}
    _summary(page, result, status)
    why_section(page, result, drawing)
    for drawn_section in (_comparisons, _alignment, _predictions):
        drawn_section(page, result, figures)
    _numerics(page, result)
    _reproduction(page, result)
    return page


def write_report(result: ValidationResult, out_dir: str | Path,
                 figures: Drawing | None = None,
                 rigidity: Mapping[str, RigidityEvidence] | None = None) -> list[Path]:
    """Write the report folder of a validation and return the files written.

    Parameters
    ----------
    result : ValidationResult
        The validation (see :func:`rigval.validation.pipeline.run_scene`).
    out_dir : str or pathlib.Path
        The folder; created if needed, files in it are overwritten.
    figures : Drawing, optional
        The page's figures, started by :func:`start_figures` on this run (also before its
        diagnosis); default: drawn here as the page needs them.
    rigidity : mapping of str to RigidityEvidence, optional
        The run's rigidity evidence for ``rigidity.json``, analysed before
        (:func:`write_rigidity`); default: its diagnosis's, else analysed here.

    Returns
    -------
    list of pathlib.Path
        ``report.html``, ``metrics.csv``, ``metrics.json``, ``alignment.json``,
        ``rigidity.json`` and the netCDF file
        (:func:`rigval.validation.run.validate.validate_scene` returns them in the result's
        ``outputs``).
    """
    out = Path(out_dir)
    drawing = start_figures(result) if figures is None else figures
    start_why_figures(drawing, result)
    # all files in a hidden folder first, moved in at the end: no half-written report folder,
    # whatever fails; the data files first, while the drawers draw the page's figures
    with staged_folder(out) as stage:
        staged = write_metrics(result, stage)
        staged.append(write_alignment(result, stage))
        staged.append(write_rigidity(result, stage, rigidity))
        staged.append(write_netcdf(result, stage / f"{result.scene.path.stem}.nc"))
        staged.insert(0, _build_page(result, drawing).write(stage / "report.html"))
    written = [out / path.name for path in staged]
    logger.info("report written to %s", out)
    return written

