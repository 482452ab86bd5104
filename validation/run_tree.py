"""The run's data tree: what the netCDF file of a validation holds.

:func:`run_tree` builds the ``xarray.DataTree`` of one run (docs/formats.md, the validate
netCDF): ``/angle`` (the measured revolutions on the phi_F grid and their statistics),
``/model``, ``/validation`` (scores, thresholds, verdicts), and ``/raw/<stream>`` and
``/aligned/<stream>`` where the scene's ``[output]`` asks; :func:`history_lines` the steps that
end its ``history``.
"""

from __future__ import annotations

import datetime
from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr

from rigval.validation.results import ComparisonResult
from rigval.validation.scene_types import Scene

__all__ = ["history_lines", "run_tree"]


def _measured_float32(ds: xr.Dataset) -> xr.Dataset:
    out = ds.copy()
    for name, var in ds.data_vars.items():
        if var.dtype.kind == "f":
            out[name] = var.astype(np.float32)
    return out


def run_tree(scene: Scene, raw: Mapping[str, xr.Dataset], aligned: Mapping[str, xr.Dataset],
             angle: np.ndarray, grid_times: np.ndarray, measured: Mapping[str, np.ndarray],
             results: tuple[ComparisonResult, ...], model: xr.Dataset, steps: list[str],
             history: list[str], corners: Mapping[str, float | None]) -> xr.DataTree:
    """Build the run's DataTree; history: the streams' processing lines, then ``steps``.

    ``/raw`` and ``/aligned`` hold the streams given in ``raw`` and ``aligned`` (empty mappings
    when the scene's ``[output]`` does not ask for them); ``corners`` are the low-pass corners
    applied per comparison in Hz (None: not low-passed), kept as ``lowpass_hz``.
    """
    cycle = np.arange(grid_times.shape[0])
    angle_ds = xr.Dataset(coords={
        "angle": ("angle", angle, {"units": "rad", "long_name": "main shaft angle phi_F"}),
        "cycle": ("cycle", cycle, {"long_name": "whole revolution index", "units": "1"})})
    angle_ds["time_at_angle"] = (("cycle", "angle"), grid_times, {
        "units": "s", "long_name": "reference time at each grid angle"})
    for result in results:
        name = result.name
        attrs = {"units": result.units, "long_name": result.long_name,
                 "source": result.spec.measured_text}
        angle_ds[name] = (("cycle", "angle"), measured[name].astype(np.float32), attrs)
        corner = corners.get(name)
        if corner is not None:  # absent: not low-passed
            angle_ds[name].attrs["lowpass_hz"] = float(corner)
        low, high = result.band
        stats = {"mean": result.mean, "std": result.cycles.std(axis=0, ddof=1), "p5": low,
                 "p95": high, "min": result.cycles.min(axis=0), "max": result.cycles.max(axis=0)}
        for stat, values in stats.items():
            angle_ds[f"{name}_{stat}"] = ("angle", values,
                                          {**attrs, "cell_methods": f"cycle: {stat}"})
        angle_ds[f"{name}_n"] = ((), result.cycles.shape[0], {"units": "1"})
    model_ds = model.copy()
    for result in results:
        model_ds[f"compared_{result.name}"] = ("angle", result.model, {
            "units": result.units, "long_name": f"{result.spec.model} x {result.spec.scale:g}"
                                                f" + {result.offset:g}"})
    scores = sorted({k for r in results for k, v in r.scores.items()
                     if isinstance(v, int | float) and not isinstance(v, bool)}
                    | {k for r in results for k in r.spec.thresholds})
    table = {row: np.array([[float(source.get(s, np.nan)) for s in scores]
                            for source in sources]) for row, sources in (
        ("model", [r.scores for r in results]),
        ("baseline_median", [r.baseline["median"] for r in results]),
        ("baseline_worst", [r.baseline["worst"] for r in results]))}
    validation = xr.Dataset(
        {f"metrics_{row}": (("comparison", "score"), values, {"units": "1"})
         for row, values in table.items()},
        coords={"comparison": [r.name for r in results], "score": scores})
    validation["passed"] = ("comparison", np.array([r.passed for r in results], dtype=np.int8),
                            {"long_name": "all thresholds met", "units": "1"})
    validation["threshold"] = (("comparison", "score"), np.array(
        [[str(r.spec.thresholds.get(s, "")) for s in scores] for r in results], dtype=object),
        {"long_name": "pass/fail rule on the score, OP LIMIT (empty: none)"})
    nodes: dict[str, xr.Dataset] = {}
    for name, ds in raw.items():
        nodes[f"/raw/{name}"] = _measured_float32(ds)
    for name, ds in aligned.items():
        nodes[f"/aligned/{name}"] = _measured_float32(ds)
    nodes["/angle"] = angle_ds
    nodes["/model"] = model_ds
    nodes["/validation"] = validation
    tree = xr.DataTree.from_dict(nodes)
    tree.attrs["title"] = scene.title
    lines = list(history)
    lines += [f"{datetime.datetime.now(datetime.UTC):%Y-%m-%dT%H:%M:%SZ} rigval {step}"
              for step in steps]
    tree.attrs["history"] = "\n".join(lines)
    return tree


def history_lines(scene: Scene, n_cycles: int, corners: Mapping[str, float | None],
                  request: Mapping[str, Any], passed: bool) -> list[str]:
    """Return the run's steps for the netCDF ``history``, one line per stage."""
    files = ", ".join(spec.file.name for spec in scene.streams.values())
    return [
        f"validation.pipeline read+convert {files}",
        f"validation.pipeline angle: {n_cycles} revolutions, "
        f"{scene.angle.points_per_revolution} points per revolution, "
        f"{scene.angle.interpolation} interpolation, "
        f"low-pass {({c.name: corners[c.name] for c in scene.comparisons})}",
        f"validation.pipeline model {scene.mechanism.name}: drives {scene.model.drives}, "
        f"outputs {dict(request)}",
        f"validation.pipeline compare {', '.join(c.name for c in scene.comparisons)}: "
        f"{'passed' if passed else 'failed'}"]
