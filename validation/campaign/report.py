"""The campaign summary: a metrics table over runs, a plot against running speed, an HTML page.

:func:`write_campaign_report` writes three files into the campaign folder, beside the per-run
report folders:

``index.html``
    Self-contained page, the summary of ``rigval campaign`` and ``rigval demo`` alike: the
    V&V 20 verdict and the result, counts, one row per run (status, speed, time, why it did not
    pass, warnings, link to its report), the data each run could not use
    (:func:`data_not_used`: gaps, samples dropped and why, pulses missed), the metrics of every
    comparison over the runs, the metrics plotted against running speed, every warning, and
    every error with its class, message, location, hint and traceback.
``campaign_metrics.csv``
    The metrics of every run in long form (one row per run, comparison and metric).
``campaign.json``
    Every :class:`~rigval.validation.campaign.runs.RunOutcome` as data (what :func:`open_campaign`
    and scripts read back), each with its ``data_not_used`` rows.

:func:`open_campaign` reads the runs' netCDF files back as one dataset with a ``run`` dimension.
"""

from __future__ import annotations

import importlib.util
import json
import logging
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd
import xarray as xr

from rigval.acquisition.errors import DataFileError
from rigval.acquisition.outputs import atomic_output, write_text_atomic
from rigval.validation.campaign.engine import RunOutcome, dask_available
from rigval.validation.campaign.figure_groups import SPEED_GROUP, draw_speed_figure
from rigval.validation.campaign.runs import run_reason
from rigval.validation.campaign.speed_panels import speed_panels
from rigval.validation.diagnosis.campbell import (
    MIN_SPEEDS,
    Campbell,
    RunSpectrum,
    campbell,
    plot_campbell,
)
from rigval.validation.diagnosis.rigidity import resonances_from_record
from rigval.validation.report.drawing import Drawers, Drawing
from rigval.validation.report.page import Link, Page

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "SUMMARY_PAGE",
    "CampaignFiles",
    "data_not_used",
    "metrics_table",
    "open_campaign",
    "plot_metrics_against_speed",
    "write_campaign_report",
]

logger = logging.getLogger(__name__)

#: The summary page's file name in the campaign folder (also the demo's).
SUMMARY_PAGE = "index.html"
_METRIC_COLUMNS = ["run", "status", "speed_rev_s", "comparison", "row", "metric", "value",
                   "text", "threshold", "passed"]


@dataclass(frozen=True)
class CampaignFiles:
    """Paths of the campaign summary files.

    Parameters
    ----------
    html : Path
        ``index.html``, the summary page.
    metrics_csv : Path
        ``campaign_metrics.csv``.
    outcomes_json : Path
        ``campaign.json``.
    """

    html: Path
    metrics_csv: Path
    outcomes_json: Path


def metrics_table(outcomes: Sequence[RunOutcome]) -> pd.DataFrame:
    """Return every run's metrics in long form.

    Parameters
    ----------
    outcomes : sequence of RunOutcome
        The campaign's runs; runs with an error contribute no rows.

    Returns
    -------
    pandas.DataFrame
        Columns ``run``, ``status``, ``speed_rev_s`` (rev/s), ``comparison``, ``row``
        (``"model"`` for the model against the measured mean, ``"baseline ..."`` for the
        measured cycles against their mean), ``metric``, ``value`` (the metric's own unit; NaN
        for a metric given as text), ``text`` (a metric given as text, such as an ISO 18571
        grade, else None), ``threshold`` (text or None) and ``passed`` (bool or None), in run
        order.
    """
    rows = []
    for outcome in outcomes:
        for row in outcome.metrics:
            value = row.get("value")
            is_text = isinstance(value, str)
            rows.append({"run": outcome.name, "status": outcome.status,
                         "speed_rev_s": outcome.speed_rev_s, "comparison": row.get("comparison"),
                         "row": row.get("row", "model"), "metric": row.get("metric"),
                         "value": np.nan if is_text or value is None else float(value),
                         "text": value if is_text else None, "threshold": row.get("threshold"),
                         "passed": row.get("passed")})
    table = pd.DataFrame(rows, columns=_METRIC_COLUMNS)
    table["value"] = table["value"].astype(float)
    table["speed_rev_s"] = pd.to_numeric(table["speed_rev_s"], errors="coerce").astype(float)
    return table


def plot_metrics_against_speed(table: pd.DataFrame, *, metrics: Sequence[str] | None = None,
                               ax_width: float = 3.6) -> Figure:
    """Plot metrics against running speed, one panel per metric and one line per comparison.

    Parameters
    ----------
    table : pandas.DataFrame
        Long-form metrics as returned by :func:`metrics_table`; only the ``"model"`` rows are
        plotted.
    metrics : sequence of str, optional
        Metrics to show; default those with a threshold in some run, then the others, at most
        six.
    ax_width : float
        Width of one panel in inches.

    Returns
    -------
    matplotlib.figure.Figure
        :func:`~rigval.validation.campaign.speed_plot.plot_speed_panels` of the table's
        :func:`~rigval.validation.campaign.speed_panels.speed_panels`.
    """
    from rigval.validation.campaign.speed_plot import plot_speed_panels

    return plot_speed_panels(speed_panels(table, metrics), ax_width=ax_width)


def write_campaign_report(outcomes: Sequence[RunOutcome], out_dir: str | Path, *,
                          title: str = "rigval campaign",
                          details: dict[str, Any] | None = None,
                          drawers: Drawers | None = None) -> CampaignFiles:
    """Write the campaign summary (HTML page, metrics CSV, outcomes JSON) into ``out_dir``.

    Parameters
    ----------
    outcomes : sequence of RunOutcome
        The runs, in the order to list them.
    out_dir : path
        The campaign folder (the per-run folders are inside it).
    title : str
        Page title.
    details : dict, optional
        Further facts shown on the page and stored in the JSON (scheduler, workers, wall time).
    drawers : rigval.validation.report.drawing.Drawers, optional
        Who draws the figure of the metrics against speed; default this process. The Campbell
        diagrams, drawn only where a run shows a resonance, are drawn here.

    Returns
    -------
    CampaignFiles
        The paths written.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    details = dict(details or {})
    table = metrics_table(outcomes)
    drawing = Drawing(drawers)
    if not table.empty:  # drawn while the files are written
        drawing.start(draw_speed_figure, speed_panels(table), (SPEED_GROUP,))
    files = CampaignFiles(html=out_dir / SUMMARY_PAGE,
                          metrics_csv=out_dir / "campaign_metrics.csv",
                          outcomes_json=out_dir / "campaign.json")
    with atomic_output(files.metrics_csv) as partial:
        table.to_csv(partial, index=False)
    counts = {status: sum(o.status == status for o in outcomes)
              for status in ("passed", "failed", "error")}
    unused = {outcome.name: data_not_used(outcome) for outcome in outcomes}
    document = {"written": datetime.now(UTC).isoformat(timespec="seconds"), "counts": counts,
                **details, "runs": [{**outcome.to_dict(), "data_not_used": unused[outcome.name]}
                                    for outcome in outcomes]}
    write_text_atomic(files.outcomes_json, json.dumps(document, indent=1, allow_nan=False))
    _summary_page(outcomes, table, out_dir, title, counts, details, unused,
                  drawing).write(files.html)
    logger.info("campaign summary written to %s", files.html)
    return files


def data_not_used(outcome: RunOutcome) -> list[dict[str, Any]]:
    """Return what a run's streams could not use, one row per stream, from its alignment.json.

    Parameters
    ----------
    outcome : RunOutcome
        The run; a run without an ``alignment.json`` output (an error, a custom validation)
        gives no rows.

    Returns
    -------
    list of dict
        ``stream``, ``gaps`` (count), ``samples missing in gaps`` (never recorded: the device
        dropped them), ``samples dropped`` (recorded, but in segments that could not be
        aligned), ``why dropped`` (the reasons, or None), ``pulses missing`` and ``pulses
        spurious`` (expected reference events not seen; events that matched nothing),
        ``invalid samples`` and ``why invalid`` (samples marked invalid by reason: empty
        cells, unaligned segments, ...; None when the file does not record them). One row
        with only a ``note`` when the file cannot be read.
    """
    path = outcome.output("alignment.json")
    if path is None:
        return []
    try:
        streams = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as error:
        return [{"stream": None, "note": f"{path.name} cannot be read: {error}"}]
    rows = []
    for name, info in (streams.items() if isinstance(streams, Mapping) else ()):
        if not isinstance(info, Mapping):
            continue
        gaps = [g for g in info.get("gaps") or () if isinstance(g, Mapping)]
        table = info.get("segment_table")
        reasons = sorted({str(row["dropped_because"]) for row in table
                          if isinstance(row, Mapping) and row.get("dropped_because")}
                         ) if isinstance(table, list) else []
        rows.append({"stream": str(name), "gaps": len(gaps),
                     "samples missing in gaps": sum(int(g.get("missing_samples", 0))
                                                    for g in gaps),
                     "samples dropped": int(info.get("samples_dropped", 0)),
                     "why dropped": "; ".join(reasons) or None,
                     "pulses missing": info.get("events_missing"),
                     "pulses spurious": info.get("events_spurious"),
                     **_invalid(info.get("invalid_samples"))})
    return rows


def _invalid(counts: Any) -> dict[str, Any]:
    """Return the ``invalid samples``/``why invalid`` cells of a reason -> count mapping."""
    if not isinstance(counts, Mapping):
        return {"invalid samples": None, "why invalid": None}
    return {"invalid samples": sum(int(n) for n in counts.values()),
            "why invalid": "; ".join(f"{reason}: {int(n)}" for reason, n in counts.items())
            or None}


def _vv20_detected(outcome: RunOutcome) -> list[str]:
    """Comparisons of a run whose V&V 20 curve verdict is "model error detected"."""
    return [row["comparison"] for row in outcome.metrics
            if row.get("row") == "model" and row.get("metric") == "vv20.curve.detected"
            and row.get("value") is True]


#: The scores shown first in the per-comparison tables; the others are folded.
_KEY_METRICS = ("iso18571_periodic.rating", "iso18571_periodic.grade", "nrmse", "pearson_r",
                "vv20.curve.error", "vv20.curve.u_val", "vv20.curve.detected")


def campbell_diagrams(outcomes: Sequence[RunOutcome]) -> list[Campbell]:
    """Return the Campbell diagram of each comparison from the runs' ``rigidity.json``.

    Empty when fewer than :data:`~rigval.validation.diagnosis.campbell.MIN_SPEEDS` runs at
    distinct speeds have one (docs/diagnosis.md).
    """
    records: dict[str, list[tuple[str, dict[str, Any]]]] = {}
    for outcome in outcomes:
        path = outcome.output("rigidity.json")
        if path is None or not path.is_file():
            continue
        for name, record in json.loads(path.read_text(encoding="utf-8")).items():
            records.setdefault(name, []).append((outcome.name, record))
    diagrams = []
    for name, runs in records.items():
        spectra = [RunSpectrum(run, r["speed_rev_s"],
                               np.asarray(r["spectrum"]["frequency_hz"], dtype=float),
                               np.asarray(r["spectrum"]["residual_psd"], dtype=float),
                               resonances_from_record(r)) for run, r in runs]
        if len({round(s.speed_rev_s, 2) for s in spectra}) >= MIN_SPEEDS:
            diagrams.append(campbell(name, runs[0][1]["units"], spectra))
    return diagrams


def _campbell_section(page: Page, outcomes: Sequence[RunOutcome]) -> None:
    """Add the Campbell diagrams (residual spectra against speed) to the campaign page."""
    diagrams = campbell_diagrams(outcomes)
    if not diagrams:
        return
    page.section("Campbell diagram: residual spectra against speed")
    page.paragraph("A peak of the residual that keeps its frequency across speeds is a "
                   "structural mode; content on an order line (k x speed) is the rigid-body "
                   "motion's (docs/diagnosis.md).")
    page.table([{"comparison": d.name, "finding": d.sentence} for d in diagrams])
    for diagram in diagrams:
        if any(run.resonances for run in diagram.runs):
            page.figure(plot_campbell(diagram), caption=diagram.sentence, fmt="svg")


def _report_link(outcome: RunOutcome, out_dir: Path) -> Link | str:
    """Return the run's name, linking its report page when it has one."""
    report = outcome.output(".html")
    if report is None:
        return outcome.name
    return Link(outcome.name, Path(os.path.relpath(report, out_dir)).as_posix())


def _summary_page(outcomes: Sequence[RunOutcome], table: pd.DataFrame, out_dir: Path,
                  title: str, counts: dict[str, int], details: dict[str, Any],
                  unused: Mapping[str, list[dict[str, Any]]], drawing: Drawing) -> Page:
    """Build the campaign page; ``unused``: :func:`data_not_used` per run name.

    ``drawing``: where the figure of the metrics against speed was started.
    """
    verdict = ("errors" if counts["error"] else "failed" if counts["failed"] else "passed")
    page = Page(title, subtitle=f"{len(outcomes)} runs: {counts['passed']} passed, "
                                f"{counts['failed']} failed, {counts['error']} errors")
    page.section("Summary")
    detected = {o.name: _vv20_detected(o) for o in outcomes if o.metrics}
    page.paragraph("ASME V&V 20: model error detected (|E| > k u_val) in "
                   f"{sum(bool(d) for d in detected.values())} of {len(detected)} validated runs"
                   + "".join(f"; {name}: {', '.join(names)}"
                             for name, names in detected.items() if names),
                   css_class="bad" if any(detected.values()) else "ok")
    page.paragraph(f"Result: {verdict.upper()}", css_class="ok" if verdict == "passed" else "bad")
    page.facts({**counts, "reused (up to date)": sum(o.reused for o in outcomes), **details})

    page.section("Runs")
    page.table([{"run": _report_link(o, out_dir), "status": o.status,
                 "V&V 20": (None if not o.metrics else "detected: " + ", ".join(
                     _vv20_detected(o)) if _vv20_detected(o) else "not detected"),
                 "speed [rev/s]": o.speed_rev_s,
                 "time [s]": o.elapsed_s, "CPU [s]": o.cpu_s, "reused": o.reused,
                 "warnings": len(o.warnings),
                 "reason": run_reason(o) or None} for o in outcomes], digits=3)
    page.paragraph("Each run's name links its report.")

    page.section("Data not used")
    rows = [{"run": name, **row} for name, part in unused.items() for row in part]
    if rows:
        page.paragraph("Per run and stream, from its alignment.json: samples the device never "
                       "recorded (gaps), samples recorded but dropped (segments that could not "
                       "be aligned) and why, reference pulses missing or spurious.")
        page.table(rows, digits=3)
    else:
        page.paragraph("No run reported its alignment (runs with errors have none).")

    if not table.empty:
        page.section("Metrics against running speed")
        page.figure(drawing.texts(SPEED_GROUP)[0], caption="Each marker is a run; a red ring "
                    "marks a missed threshold; a dashed line is the threshold where all "
                    "comparisons share one.")
        page.section("Metrics per comparison")
        model_rows = table[table["row"] == "model"]
        for comparison, part in model_rows.groupby("comparison", sort=False):
            rows = []
            for (run, speed), metrics in part.groupby(["run", "speed_rev_s"], sort=False,
                                                      dropna=False):
                cells = {m: (t if isinstance(t, str) else v) for m, v, t in
                         zip(metrics["metric"], metrics["value"], metrics["text"], strict=True)}
                rows.append({"run": run, "speed [rev/s]": speed, **cells})
            page.wide_table(rows, key=["run", "speed [rev/s]", *_KEY_METRICS],
                            caption=str(comparison), digits=3)

    _campbell_section(page, outcomes)

    warned = [{"run": o.name, "warning": str(w)} for o in outcomes for w in o.warnings]
    if warned:
        page.section("Warnings")
        page.table(warned)

    errors = [o for o in outcomes if o.error is not None]
    if errors:
        page.section("Errors")
        page.table([{"run": o.name, "error": o.error.kind, "message": o.error.message,
                     "where": ", ".join(f"{k}: {v}" for k, v in o.error.where.items()),
                     "how to fix": o.error.hint} for o in errors if o.error is not None])
        for outcome in errors:
            if outcome.error is not None:
                page.section(f"Traceback of {outcome.name}", level=3)
                page.preformatted(outcome.error.traceback)
    return page


def _damaged_output(paths: list[Path], group: str, engine: str,
                    error: BaseException) -> DataFileError:
    """Return the error naming the first run file that cannot be opened (each tried alone)."""
    for path in paths:
        try:
            xr.open_dataset(path, group=group, engine=engine).close()
        except (OSError, ValueError, RuntimeError, KeyError) as failure:
            return DataFileError(
                f"cannot read group {group!r} of a run's netCDF file {path.name}: {failure}",
                where={"file": path, "group": group},
                hint="the file is missing or damaged (a run stopped while writing it?): rerun "
                     "the campaign with --force for that run, or delete its folder and rerun")
    return DataFileError(f"cannot open the campaign's netCDF files together: {error}",
                         where={"file": paths[0].parent.parent, "group": group},
                         hint="check that every run wrote the same groups and dimensions")


def open_campaign(directory: str | Path, group: str = "validation", *,
                  parallel: bool | None = None, **kwargs: Any) -> xr.Dataset:
    """Open one group of every validated run's netCDF file as one dataset with a ``run`` dim.

    Parameters
    ----------
    directory : path
        A campaign folder written by ``rigval campaign`` (it holds ``campaign.json``).
    group : str
        netCDF group to read (``"validation"``, ``"angle"``, ``"model"``, ...).
    parallel : bool, optional
        Open the files in parallel with Dask; default True when Dask is installed.
    **kwargs
        Passed on to :func:`xarray.open_mfdataset` (e.g. ``join="exact"``, ``chunks``).

    Returns
    -------
    xarray.Dataset
        The group's variables stacked along ``run`` (coordinate: run names), with the
        coordinates ``speed_rev_s`` (rev/s) and ``status`` along ``run``. Runs that errored
        have no file and are left out. Lazy (dask arrays) when Dask is installed.

    Raises
    ------
    DataFileError
        If the folder has no ``campaign.json`` or no run has a netCDF file.
    """
    directory = Path(directory)
    index = directory / "campaign.json"
    try:
        runs = json.loads(index.read_text(encoding="utf-8"))["runs"]
    except (OSError, ValueError, KeyError) as error:
        raise DataFileError(f"cannot read the campaign index: {error}", where={"file": index},
                            hint="give a folder written by `rigval campaign`") from error
    found = [(run, directory / run["name"] / name) for run in runs for name in run["outputs"]
             if name.endswith(".nc")]
    if not found:
        raise DataFileError("no run of the campaign has a netCDF file", where={"file": index},
                            hint=f"check the errors in {SUMMARY_PAGE}; rerun the failed runs")
    has_dask = dask_available()
    # h5netcdf (the parallel extra) reads from threads safely; the netCDF4 library of a plain
    # install does not (xarray issues 7079, 8120, 11088), so it opens the files one by one.
    engine = "h5netcdf" if importlib.util.find_spec("h5netcdf") is not None else "netcdf4"
    threads = has_dask and engine == "h5netcdf"
    options: dict[str, Any] = {
        "engine": engine, "combine": "nested", "concat_dim": "run", "data_vars": "all",
        "coords": "minimal", "compat": "override", "join": "outer",
        "parallel": threads if parallel is None else parallel and threads,
        "chunks": {} if has_dask else None, "combine_attrs": "drop_conflicts",
    }
    options.update(kwargs)
    try:
        dataset = xr.open_mfdataset([str(path) for _, path in found], group=group, **options)
    except (OSError, ValueError, RuntimeError, KeyError) as error:
        raise _damaged_output([path for _, path in found], group, options["engine"],
                              error) from error
    return dataset.assign_coords(
        run=[run["name"] for run, _ in found],
        speed_rev_s=("run", [np.nan if run["speed_rev_s"] is None else run["speed_rev_s"]
                             for run, _ in found], {"units": "s-1",
                                                    "long_name": "mean running speed in rev/s"}),
        status=("run", [run["status"] for run, _ in found]),
    )
