"""Files of ``rigval bench``: the rows as CSV and Markdown, and plots of time against error.

Plots are made on :class:`matplotlib.figure.Figure` objects (no pyplot state), one PNG per stage:
one panel per metric and case (alignment: one per metric, the numbers of events joined as a
line), CPU time per item (sample, step, event) on the x axis, the error on the y axis, both
logarithmic; the baseline in black; where the input sets a limit (quantisation, timing noise) it
is drawn dotted with open markers; the bound ``rigval bench`` checks is a dashed red line, and
exact results (error 0, which a log axis cannot show) are drawn as downward triangles on the
bottom edge, labelled "exact 0".
Reading has no error to speak of (every reader returns the exact values), so its panel shows peak
memory against time instead.
"""

from __future__ import annotations

import csv
import logging
import math
from collections.abc import Sequence
from dataclasses import fields
from pathlib import Path

from matplotlib.axis import Axis
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, LogLocator, MaxNLocator, NullFormatter

from rigval.acquisition.errors import DataFileError
from rigval.acquisition.outputs import atomic_output, write_text_atomic
from rigval.validation.bench.rows import STAGES, BenchRow

__all__ = ["closing_line", "compare_text", "markdown_table", "plot_stage", "read_csv",
           "write_csv", "write_outputs"]

logger = logging.getLogger(__name__)

#: Smallest error drawn on a log axis (exact results are drawn there).
_FLOOR = 1e-17
#: Stages whose cases are steps of one swept parameter (their points are joined across cases);
#: the other stages get one panel per metric and case.
_SWEPT_CASES = frozenset({"alignment"})


def write_csv(rows: Sequence[BenchRow], path: Path) -> Path:
    """Write the rows to a CSV file, one column per :class:`BenchRow` field.

    Parameters
    ----------
    rows : sequence of BenchRow
        The rows.
    path : pathlib.Path
        Output file.

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    names = [f.name for f in fields(BenchRow)]
    with atomic_output(path) as partial, open(partial, "w", newline="",
                                              encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=names)
        writer.writeheader()
        for row in rows:
            writer.writerow({k: _csv_value(v) for k, v in row.as_dict().items()})
    return path


def read_csv(path: Path) -> list[BenchRow]:
    """Read rows written by :func:`write_csv`.

    Parameters
    ----------
    path : pathlib.Path
        A ``bench.csv`` file.

    Returns
    -------
    list of BenchRow
        Its rows.

    Raises
    ------
    DataFileError
        If the file cannot be read or is not a ``rigval bench`` CSV.
    """
    kinds = {f.name: str(f.type) for f in fields(BenchRow)}
    converters = {"int": int, "float": float, "str": str}
    try:
        with open(path, newline="", encoding="utf-8") as handle:
            reader = csv.DictReader(handle)
            if reader.fieldnames != list(kinds):
                raise ValueError(f"columns {reader.fieldnames}, expected {list(kinds)}")
            return [BenchRow(**{k: converters[kinds[k]](v) for k, v in row.items()})
                    for row in reader]
    except (OSError, ValueError, UnicodeDecodeError) as error:
        raise DataFileError(f"cannot read a rigval bench table: {error}",
                            where={"file": str(path)},
                            hint="pass the bench.csv that `rigval bench --out DIR` wrote") \
            from error


def compare_text(rows: Sequence[BenchRow], reference: Sequence[BenchRow]) -> str:
    """Return a Markdown table of each row's error and CPU time against an earlier run.

    Rows are matched by stage, case, choice and metric; rows without a partner are listed as
    such. Errors of the synthetic cases are deterministic (fixed seeds), so their ratio should
    be 1 up to rounding; CPU times vary with the machine's load.

    Parameters
    ----------
    rows : sequence of BenchRow
        This run.
    reference : sequence of BenchRow
        The earlier run (e.g. the one behind ``docs/performance.md``).

    Returns
    -------
    str
        Markdown text.
    """
    earlier = {(r.stage, r.case, r.choice, r.metric): r for r in reference}
    lines = ["| stage | choice | metric | error | earlier | ratio | CPU s | earlier | ratio |",
             "|" + "---|" * 9]
    for r in rows:
        old = earlier.get((r.stage, r.case, r.choice, r.metric))
        if old is None:
            lines.append(f"| {r.stage} | {_cell(r.choice)} | {_cell(r.metric)} | "
                         f"{_number(r.error)} | (no earlier row) | | | | |")
            continue
        error_ratio = r.error / old.error if old.error else (1.0 if r.error == 0 else math.inf)
        time_ratio = r.cpu_s / old.cpu_s if old.cpu_s else math.nan
        lines.append(f"| {r.stage} | {_cell(r.choice)} | {_cell(r.metric)} | "
                     f"{_number(r.error)} | {_number(old.error)} | {_number(error_ratio)} | "
                     f"{_number(r.cpu_s)} | {_number(old.cpu_s)} | {_number(time_ratio)} |")
    return "\n".join(lines)


def _csv_value(value: object) -> object:
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else str(value)
    return value


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def _number(value: float, digits: int = 3) -> str:
    if not math.isfinite(value):
        return "-" if math.isnan(value) else "inf"
    if value == 0:
        return "0"
    return f"{value:.{digits}g}"


def markdown_table(rows: Sequence[BenchRow], note: str = "") -> str:
    """Return the rows as Markdown: one section per stage, one table per case.

    Parameters
    ----------
    rows : sequence of BenchRow
        The rows.
    note : str, optional
        A line printed under the title (machine, date, load).

    Returns
    -------
    str
        Markdown text.
    """
    lines = ["# rigval bench: speed against error", ""]
    if note:
        lines += [note, ""]
    lines += ["Time: best of the repeats, wall clock and CPU of the process; `baseline time` is "
              "the baseline's wall time scaled to the row's work. `bound`: the stated upper "
              "bound of the error (checked); `limit`: the error the input itself sets, where "
              "known.", ""]
    for stage in dict.fromkeys((*STAGES, *(r.stage for r in rows))):  # then other stages (long)
        stage_rows = [r for r in rows if r.stage == stage]
        if not stage_rows:
            continue
        lines += [f"## {stage}", ""]
        for case in dict.fromkeys(r.case for r in stage_rows):
            lines += [f"**{case}**", ""]
            memory = stage in ("reading", "long")
            head = ["choice", "metric", "error", "unit", "bound", "limit", "wall s", "CPU s",
                    "n"] + (["peak MiB"] if memory else []) + \
                   ["baseline", "baseline error", "baseline wall s"]
            lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
            for r in (r for r in stage_rows if r.case == case):
                cells = [_cell(r.choice), _cell(r.metric), _number(r.error), r.unit,
                         _number(r.bound),
                         _number(r.limit), _number(r.time_s), _number(r.cpu_s), str(r.n)]
                cells += [_number(r.peak_mib, 4)] if memory else []
                cells += ["(this row)" if r.is_baseline else _cell(r.baseline),
                          _number(r.baseline_error), _number(r.baseline_time_s)]
                lines.append("| " + " | ".join(cells) + " |")
            lines.append("")
    return "\n".join(lines)


def plot_stage(rows: Sequence[BenchRow], stage: str) -> Figure:
    """Plot one stage's rows: time per item against error, one panel per metric.

    Parameters
    ----------
    rows : sequence of BenchRow
        Rows (other stages are ignored).
    stage : str
        The stage to plot.

    Returns
    -------
    matplotlib.figure.Figure
        The figure (not attached to pyplot).
    """
    stage_rows = [r for r in rows if r.stage == stage]
    if stage == "reading":
        panels = [("", "")]
    elif stage in _SWEPT_CASES:
        panels = [(m, "") for m in dict.fromkeys(r.metric for r in stage_rows)]
    else:
        panels = list(dict.fromkeys((r.metric, r.case) for r in stage_rows))
    metrics = [p[0] for p in panels]
    ncols = min(2, len(metrics))
    nrows = math.ceil(len(metrics) / ncols)
    fig = Figure(figsize=(6.5 * ncols, 4.4 * nrows), layout="constrained")
    grid = fig.subplots(nrows, ncols, squeeze=False).ravel()
    for ax in grid[len(metrics):]:
        ax.set_visible(False)
    for ax, (metric, case) in zip(grid, panels, strict=False):
        chosen = [r for r in stage_rows if stage == "reading"
                  or (r.metric == metric and (not case or r.case == case))]
        xs: list[float] = []
        ys: list[float] = []
        for choice in dict.fromkeys(r.choice for r in chosen):
            series = sorted((r for r in chosen if r.choice == choice), key=lambda r: r.cpu_s)
            baseline = series[0].is_baseline
            style = {"color": "black", "marker": "s"} if baseline else {"marker": "o"}
            if stage == "reading":
                x = [r.cpu_s for r in series]
                y = [r.peak_mib for r in series]
            else:
                x = [r.cpu_s / r.n * 1e6 for r in series]
                y = [r.error if r.error > 0 else math.nan for r in series]
            if all(v <= 0 for v in x):  # untimed baseline (e.g. start times): a level
                ax.axhline(y[0], color="black", linestyle=":", label=choice)
                ys.append(y[0])
                continue
            xs += x
            ys += y
            lines = ax.plot(x, y, linestyle="-" if len(series) > 1 else "", label=choice,
                            **style)
            exact = [v for v, r in zip(x, series, strict=True) if r.error == 0.0]
            if stage != "reading" and exact:  # a log axis has no 0: a mark on the bottom edge
                ax.plot(exact, [0.0] * len(exact), "v", color=lines[0].get_color(), ms=8,
                        clip_on=False, transform=ax.get_xaxis_transform(),
                        label=f"{choice}: exact 0")
            limits = [r.limit for r in series]
            if stage != "reading" and all(math.isfinite(v) for v in limits):
                ax.plot(x, limits, linestyle=":", marker=style["marker"], fillstyle="none",
                        color=lines[0].get_color())
        bounded = [r for r in chosen if math.isfinite(r.bound)] if stage != "reading" else []
        if len({r.bound for r in bounded}) == 1:  # one bound for the panel: a line
            ax.axhline(bounded[0].bound, color="#c8322b", linestyle="--", lw=1.0,
                       label=f"bound {bounded[0].bound:.3g} (rigval bench checks)")
        elif bounded:  # each point its own bound: a red bar above (or below) the point
            ax.plot([r.cpu_s / r.n * 1e6 for r in bounded], [r.bound for r in bounded], "_",
                    color="#c8322b", ms=14, mew=2, label="each point's bound (rigval bench "
                                                          "checks)")
        ys += [r.bound for r in bounded]
        ax.set_xscale("log")
        ax.set_yscale("log")
        if stage == "reading":
            ax.set_xlabel("CPU time of the read, s")
            ax.set_ylabel("memory growth during the read, MiB")
            ax.set_title(chosen[0].case, fontsize=9)
        else:
            unit = {"us": "µs"}.get(chosen[0].unit, chosen[0].unit)  # the CSV keeps ASCII
            ax.set_xlabel("CPU time per item, µs")
            ax.set_ylabel(f"error ({unit})" if unit != "1" else "error (relative)")
            limited = any(math.isfinite(r.limit) for r in chosen)
            title = f"{case}\n{metric}" if case else metric
            ax.set_title(title + ("\n(open markers, dotted: the input's limit)" if limited
                                  else ""), fontsize=8)
        _log_ticks(ax.xaxis, xs or [r.cpu_s for r in chosen])
        _log_ticks(ax.yaxis, ys or [r.peak_mib for r in chosen])
        ax.grid(True, which="major", alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(f"rigval bench: {stage}")
    return fig


def closing_line(rows: Sequence[BenchRow]) -> str:
    """Return the verdict of a bench run in one line.

    Parameters
    ----------
    rows : sequence of BenchRow
        The rows.

    Returns
    -------
    str
        ``"rigval bench: all N rows within their bounds"``, or how many rows exceed their bounds
        and which (stage / case / choice / metric).
    """
    over = [r for r in rows if not r.within_bound]
    if not over:
        return f"rigval bench: all {len(rows)} rows within their bounds"
    names = "; ".join(f"{r.stage} / {r.case} / {r.choice} / {r.metric}" for r in over)
    return f"rigval bench: {len(over)} of {len(rows)} rows exceed their bounds: {names}"


def _tick_label(value: float, plain: bool) -> str:
    """Return a log-axis tick label: plain digits, or a power of ten (``plain`` False)."""
    if value <= 0 or not math.isfinite(value):
        return ""
    if plain:
        return f"{value:.3g}"
    exponent = math.floor(math.log10(value) + 1e-9)
    mantissa = value / 10.0 ** exponent
    if math.isclose(mantissa, 1.0, rel_tol=1e-6):
        return f"$10^{{{exponent}}}$"
    return f"${mantissa:.2g}\\times10^{{{exponent}}}$"


def _log_ticks(axis: Axis, values: Sequence[float]) -> None:
    """Label a log axis with a few readable ticks, also when its data span under a decade.

    Over several decades: the powers of ten (with 2 and 5 between them over less than 2.5
    decades); within less than one decade, where a log locator finds one tick or none: at most
    five evenly spaced round values. Labels are plain digits when the whole axis lies between
    0.001 and 9999, else powers of ten (:func:`_tick_label`), so neighbours never run into each
    other as ``6.6x10^0 6.8x10^0`` did.
    """
    finite = [v for v in values if math.isfinite(v) and v > 0]
    decades = math.log10(max(finite) / min(finite)) if finite else 0.0
    if decades < 1:
        axis.set_major_locator(MaxNLocator(nbins=4, steps=[1, 2, 2.5, 5, 10]))
    else:
        subs = (1.0, 2.0, 5.0) if decades < 2.5 else (1.0,)
        axis.set_major_locator(LogLocator(base=10.0, subs=subs, numticks=8))

    def label(value: float, _position: float | None) -> str:
        low, high = sorted(axis.get_view_interval())
        return _tick_label(value, plain=low >= 1e-3 and high < 1e4)

    axis.set_major_formatter(FuncFormatter(label))
    axis.set_minor_formatter(NullFormatter())


def write_outputs(rows: Sequence[BenchRow], out: Path, note: str = "") -> list[Path]:
    """Write ``bench.csv``, ``bench.md`` and ``bench_<stage>.png`` into a folder.

    Parameters
    ----------
    rows : sequence of BenchRow
        The rows.
    out : pathlib.Path
        Output folder (created if missing).
    note : str, optional
        Machine and load line for the Markdown file.

    Returns
    -------
    list of pathlib.Path
        The files written.
    """
    out.mkdir(parents=True, exist_ok=True)
    paths = [write_csv(rows, out / "bench.csv")]
    markdown = out / "bench.md"
    write_text_atomic(markdown, markdown_table(rows, note) + "\n")
    paths.append(markdown)
    for stage in dict.fromkeys(r.stage for r in rows):
        figure = plot_stage(rows, stage)
        path = out / f"bench_{stage}.png"
        with atomic_output(path) as partial:
            figure.savefig(partial, dpi=110, format="png")
        paths.append(path)
    logger.info("bench: wrote %d files to %s", len(paths), out)
    return paths
