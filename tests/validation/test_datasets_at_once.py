"""The run's data tree and the ``/why`` group, each Dataset built in one constructor call.

:func:`rigval.validation.run_tree.run_tree` and
:meth:`rigval.validation.diagnosis.explain.Diagnosis.dataset` build every group at once (adding
variables one at a time merged and aligned the Dataset again each time, 195 times per run).
The expectation here is the plain construction, one variable after the other as the file
format describes it (docs/scene.md, the netCDF file): the same variables in the same order,
dtypes, attributes in their order and encodings.
"""

from __future__ import annotations

import datetime
import shutil
from typing import Any

import numpy as np
import pytest
import xarray as xr

from rigval.sample_data import shipped_runs
from rigval.validation import pipeline
from rigval.validation.diagnosis.explain import Diagnosis, _typed, _unit, diagnose
from tests.validation.diagnosis_cases import PAIR

#: Two pairs of each kind, so that both pair dimensions are written: the rig's pair of main
#: drive shafts, then two more.
PAIRS = PAIR + """
[[symmetry]]
name = "side shafts"
comparisons = ["tor3", "tor4"]
u_measurement_rel = 0.01

[[symmetry]]
name = "side faces"
comparisons = ["tor3", "tor4"]
kind = "faces"
u_measurement_rel = 0.02
"""


@pytest.fixture(scope="module")
def captured(tmp_path_factory: pytest.TempPathFactory) -> tuple[tuple[Any, ...], Any]:
    """The shipped run with raw and aligned streams kept and symmetry pairs: the arguments
    the pipeline gave :func:`run_tree`, and the run's result."""
    folder = tmp_path_factory.mktemp("run")
    scene = shipped_runs()[0]
    for path in scene.parent.glob(scene.name.removesuffix("_scene.toml") + "_*"):
        shutil.copy(path, folder / path.name)
    copy = folder / scene.name
    copy.write_text(copy.read_text(encoding="utf-8") + PAIRS
                    + "\n[output]\nraw = true\naligned = true\n", encoding="utf-8")
    calls = []
    with pytest.MonkeyPatch.context() as patch:
        built = pipeline.run_tree
        patch.setattr(pipeline, "run_tree",
                      lambda *args: calls.append(args) or built(*args))
        result = pipeline.run_scene(copy)
    return calls[0], result


def _float32(ds: xr.Dataset) -> xr.Dataset:
    out = ds.copy()
    for name, var in ds.data_vars.items():
        if var.dtype.kind == "f":
            out[name] = var.astype(np.float32)
    return out


def _tree_variable_by_variable(scene, raw, aligned, angle, grid_times, measured, results, model,
                               steps, history, corners) -> xr.DataTree:
    """The run's tree with every variable added on its own (the expectation)."""
    angle_ds = xr.Dataset(coords={
        "angle": ("angle", angle, {"units": "rad", "long_name": "main shaft angle phi_F"}),
        "cycle": ("cycle", np.arange(grid_times.shape[0]),
                  {"long_name": "whole revolution index", "units": "1"})})
    angle_ds["time_at_angle"] = (("cycle", "angle"), grid_times, {
        "units": "s", "long_name": "reference time at each grid angle"})
    for r in results:
        attrs = {"units": r.units, "long_name": r.long_name, "source": r.spec.measured_text}
        angle_ds[r.name] = (("cycle", "angle"), measured[r.name].astype(np.float32), attrs)
        if corners.get(r.name) is not None:
            angle_ds[r.name].attrs["lowpass_hz"] = float(corners[r.name])
        stats = {"mean": r.mean, "std": r.cycles.std(axis=0, ddof=1), "p5": r.band[0],
                 "p95": r.band[1], "min": r.cycles.min(axis=0), "max": r.cycles.max(axis=0)}
        for stat, values in stats.items():
            angle_ds[f"{r.name}_{stat}"] = ("angle", values,
                                            {**attrs, "cell_methods": f"cycle: {stat}"})
        angle_ds[f"{r.name}_n"] = ((), r.cycles.shape[0], {"units": "1"})
    model_ds = model.copy()
    for r in results:
        model_ds[f"compared_{r.name}"] = ("angle", r.model, {
            "units": r.units, "long_name": f"{r.spec.model} x {r.spec.scale:g} + {r.offset:g}"})
    scores = sorted({k for r in results for k, v in r.scores.items()
                     if isinstance(v, int | float) and not isinstance(v, bool)}
                    | {k for r in results for k in r.spec.thresholds})
    validation = xr.Dataset(coords={"comparison": [r.name for r in results], "score": scores})
    for row, sources in (("model", [r.scores for r in results]),
                         ("baseline_median", [r.baseline["median"] for r in results]),
                         ("baseline_worst", [r.baseline["worst"] for r in results])):
        validation[f"metrics_{row}"] = (("comparison", "score"), np.array(
            [[float(s.get(k, np.nan)) for k in scores] for s in sources]), {"units": "1"})
    validation["passed"] = ("comparison", np.array([r.passed for r in results], dtype=np.int8),
                            {"long_name": "all thresholds met", "units": "1"})
    validation["threshold"] = (("comparison", "score"), np.array(
        [[str(r.spec.thresholds.get(s, "")) for s in scores] for r in results], dtype=object),
        {"long_name": "pass/fail rule on the score, OP LIMIT (empty: none)"})
    nodes = {f"/raw/{name}": _float32(ds) for name, ds in raw.items()}
    nodes.update({f"/aligned/{name}": _float32(ds) for name, ds in aligned.items()})
    nodes.update({"/angle": angle_ds, "/model": model_ds, "/validation": validation})
    tree = xr.DataTree.from_dict(nodes)
    tree.attrs["title"] = scene.title
    tree.attrs["history"] = "\n".join(
        [*history, *(f"{datetime.datetime.now(datetime.UTC):%Y-%m-%dT%H:%M:%SZ} rigval {step}"
                     for step in steps)])
    return tree


def _assert_same_datasets(a: xr.Dataset, b: xr.Dataset, where: str) -> None:
    """Identical, with the variables, attributes and encodings in the same order."""
    xr.testing.assert_identical(a, b)
    assert list(a.variables) == list(b.variables), where
    assert list(a.attrs) == list(b.attrs), where
    for name in a.variables:
        assert a[name].dtype == b[name].dtype, (where, name)
        assert list(a[name].attrs) == list(b[name].attrs), (where, name)
        assert a[name].encoding == b[name].encoding, (where, name)


def _without_stamps(tree: xr.DataTree) -> xr.DataTree:
    """The tree with the history's time stamps (minutes: they may differ) taken out."""
    tree = tree.copy()
    tree.attrs["history"] = "\n".join(line.split(" rigval ")[-1]
                                      for line in tree.attrs["history"].splitlines())
    return tree


def test_run_tree_equals_the_tree_built_variable_by_variable(captured) -> None:
    args, _ = captured
    expected = _without_stamps(_tree_variable_by_variable(*args))
    built = _without_stamps(pipeline.run_tree(*args))
    assert set(built["raw"].children) == {"cdaq", "wls1", "wls2"}  # the streams are written
    assert [n.path for n in built.subtree] == [n.path for n in expected.subtree]
    for mine, theirs in zip(built.subtree, expected.subtree, strict=True):
        _assert_same_datasets(mine.to_dataset(inherit=False), theirs.to_dataset(inherit=False),
                              mine.path)


def _why_variable_by_variable(diagnosis: Diagnosis) -> xr.Dataset:
    """The ``/why`` group with every variable added on its own (the expectation)."""
    names = list(diagnosis.causes)
    ds = xr.Dataset(coords={"comparison": names})
    records = [diagnosis.causes[n].record() for n in names]
    for field in [f for f in records[0] if f != "comparison"]:
        ds[f"cause_{field}"] = ("comparison", _typed([r[field] for r in records]), {
            "units": _unit(field), "long_name": f"attribution: {field}"})
    ds["cause_sentence"] = ("comparison", np.array(
        [diagnosis.causes[n].sentence for n in names], dtype=object), {"long_name": "verdict"})
    ds["explained"] = (("comparison", "angle"),
                       np.array([diagnosis.explained[n] for n in names]),
                       {"long_name": "residual the chosen causes explain (measured minus "
                                     "model), in each comparison's unit"})
    for kind, rows in (("shares", [p for p in diagnosis.pairs if p.shares is not None]),
                       ("faces", [p for p in diagnosis.pairs if p.bending is not None])):
        ds = ds.assign_coords({f"pair_{kind}": [p.spec.name for p in rows]})
        scores = [(p.shares or p.bending).as_dict() for p in rows]
        for score in scores[0]:
            ds[f"{kind}_{score}"] = (f"pair_{kind}", _typed([s[score] for s in scores]),
                                     {"units": "1", "long_name": f"symmetry pair: {score}"})
    return ds


def test_why_group_equals_the_group_built_variable_by_variable(captured) -> None:
    _, result = captured
    diagnosis = diagnose(result)
    assert [len([p for p in diagnosis.pairs if getattr(p, kind) is not None])
            for kind in ("shares", "bending")] == [2, 1]
    _assert_same_datasets(diagnosis.dataset(), _why_variable_by_variable(diagnosis), "/why")
