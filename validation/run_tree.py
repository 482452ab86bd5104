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
    """Return a stream with its floating-point variables as float32 (``/raw``, ``/aligned``).

    One new Dataset with the same coordinates, attributes and encodings; the data variables
    keep their order.
    """
    return ds.copy(data={name: var.data.astype(np.float32) if var.dtype.kind == "f" else var.data
                         for name, var in ds.data_vars.items()})


def _angle_dataset(angle: np.ndarray, grid_times: np.ndarray,
                   measured: Mapping[str, np.ndarray], results: tuple[ComparisonResult, ...],
                   corners: Mapping[str, float | None]) -> xr.Dataset:
    """Return the group ``/angle``: the measured revolutions and their statistics, at once.

    Per comparison ``<name>`` (cycles x angle, float32; ``lowpass_hz`` in Hz when low-passed),
    ``<name>_<stat>`` over the revolutions (mean, std, p5, p95, min, max; signal units) and
    ``<name>_n`` (revolutions); ``time_at_angle`` the reference time of each grid angle (s).
    """
    variables: dict[str, Any] = {"time_at_angle": (("cycle", "angle"), grid_times, {
        "units": "s", "long_name": "reference time at each grid angle"})}
    for result in results:
        name = result.name
        attrs = {"units": result.units, "long_name": result.long_name,
                 "source": result.spec.measured_text}
        corner = corners.get(name)  # absent: not low-passed
        variables[name] = (("cycle", "angle"), measured[name].astype(np.float32),
                           attrs if corner is None else {**attrs, "lowpass_hz": float(corner)})
        low, high = result.band
        stats = {"mean": result.mean, "std": result.cycles.std(axis=0, ddof=1), "p5": low,
                 "p95": high, "min": result.cycles.min(axis=0), "max": result.cycles.max(axis=0)}
        for stat, values in stats.items():
            variables[f"{name}_{stat}"] = ("angle", values,
                                           {**attrs, "cell_methods": f"cycle: {stat}"})
        variables[f"{name}_n"] = ((), result.cycles.shape[0], {"units": "1"})
    return xr.Dataset(variables, coords={
        "angle": ("angle", angle, {"units": "rad", "long_name": "main shaft angle phi_F"}),
        "cycle": ("cycle", np.arange(grid_times.shape[0]),
                  {"long_name": "whole revolution index", "units": "1"})})


def _model_dataset(model: xr.Dataset, results: tuple[ComparisonResult, ...]) -> xr.Dataset:
    """Return the group ``/model``: the model's outputs and each comparison's compared curve."""
    return model.assign({f"compared_{r.name}": ("angle", r.model, {
        "units": r.units, "long_name": f"{r.spec.model} x {r.spec.scale:g} + {r.offset:g}"})
        for r in results})


def _validation_dataset(results: tuple[ComparisonResult, ...]) -> xr.Dataset:
    """Return the group ``/validation``: scores, baseline rows, verdicts and thresholds."""
    scores = sorted({k for r in results for k, v in r.scores.items()
                     if isinstance(v, int | float) and not isinstance(v, bool)}
                    | {k for r in results for k in r.spec.thresholds})
    table = {row: np.array([[float(source.get(s, np.nan)) for s in scores]
                            for source in sources]) for row, sources in (
        ("model", [r.scores for r in results]),
        ("baseline_median", [r.baseline["median"] for r in results]),
        ("baseline_worst", [r.baseline["worst"] for r in results]))}
    variables: dict[str, Any] = {f"metrics_{row}": (("comparison", "score"), values, {"units": "1"})
                                 for row, values in table.items()}
    variables["passed"] = ("comparison", np.array([r.passed for r in results], dtype=np.int8),
                           {"long_name": "all thresholds met", "units": "1"})
    variables["threshold"] = (("comparison", "score"), np.array(
        [[str(r.spec.thresholds.get(s, "")) for s in scores] for r in results], dtype=object),
        {"long_name": "pass/fail rule on the score, OP LIMIT (empty: none)"})
    return xr.Dataset(variables, coords={"comparison": [r.name for r in results],
                                         "score": scores})


def run_tree(scene: Scene, raw: Mapping[str, xr.Dataset], aligned: Mapping[str, xr.Dataset],
             angle: np.ndarray, grid_times: np.ndarray, measured: Mapping[str, np.ndarray],
             results: tuple[ComparisonResult, ...], model: xr.Dataset, steps: list[str],
             history: list[str], corners: Mapping[str, float | None]) -> xr.DataTree:
    """Build the run's DataTree; history: the streams' processing lines, then ``steps``.

    ``/raw`` and ``/aligned`` hold the streams given in ``raw`` and ``aligned`` (empty mappings
    when the scene's ``[output]`` does not ask for them); ``corners`` are the low-pass corners
    applied per comparison in Hz (None: not low-passed), kept as ``lowpass_hz``. Each group's
    Dataset is built in one constructor call and the tree in one more (adding variables one at
    a time merged and aligned the Dataset again each time).
    """
    lines = list(history)
    lines += [f"{datetime.datetime.now(datetime.UTC):%Y-%m-%dT%H:%M:%SZ} rigval {step}"
              for step in steps]
    nodes: dict[str, xr.Dataset] = {
        "/": xr.Dataset(attrs={"title": scene.title, "history": "\n".join(lines)})}
    for name, ds in raw.items():
        nodes[f"/raw/{name}"] = _measured_float32(ds)
    for name, ds in aligned.items():
        nodes[f"/aligned/{name}"] = _measured_float32(ds)
    nodes["/angle"] = _angle_dataset(angle, grid_times, measured, results, corners)
    nodes["/model"] = _model_dataset(model, results)
    nodes["/validation"] = _validation_dataset(results)
    return xr.DataTree.from_dict(nodes)


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
