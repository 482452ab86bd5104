"""A kept measurement validated against another mechanism equals a second whole run.

``rigval identify`` validates the identified mechanism with the nominal run's measurement
(:class:`rigval.validation.pipeline.Measurement`) instead of reading and aligning the files
again. The second method is the plain one: :func:`run_scene` of the scene with that mechanism.
The measured side does not depend on the mechanism, so everything must agree exactly.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import xarray as xr

from rigval.model import load_mechanism
from rigval.model.mechanism_text import apply_parameters, mechanism_toml
from rigval.sample_data import shipped_runs
from rigval.validation.pipeline import run_scene, run_scene_kept


@pytest.fixture(scope="module")
def kept():
    return run_scene_kept(shipped_runs()[0])


def test_the_kept_run_is_the_plain_run(kept):
    result, _ = kept
    plain = run_scene(shipped_runs()[0])
    for a, b in zip(result.comparisons, plain.comparisons, strict=True):
        assert a.scores == b.scores
        np.testing.assert_array_equal(a.cycles, b.cycles)


def test_another_mechanism_on_the_kept_measurement_equals_a_second_run(kept, tmp_path):
    result, measurement = kept
    document = apply_parameters(load_mechanism(result.scene.mechanism),
                                {"A.mass": 1.08 * _nominal(result, "A", "mass")})
    path = tmp_path / "heavier.toml"
    path.write_text(mechanism_toml(document), encoding="utf-8")
    again = measurement.against(path)
    plain = run_scene(dataclasses.replace(result.scene, mechanism=path))
    assert set(again.numerics.stage_seconds) == {"model", "numerics", "compare"}
    for a, b, nominal in zip(again.comparisons, plain.comparisons, result.comparisons,
                             strict=True):
        assert a.name == b.name
        assert a.scores == b.scores
        assert a.baseline == b.baseline  # taken from the kept run's: the same revolutions
        np.testing.assert_array_equal(a.model, b.model)
        np.testing.assert_array_equal(a.cycles, nominal.cycles)
    xr.testing.assert_identical(again.tree["/model"].to_dataset(),
                                plain.tree["/model"].to_dataset())
    # the heavier arm moved the drive torque's model: the new mechanism was used
    torque = next(c for c in again.comparisons if c.name == "torque_F")
    before = next(c for c in result.comparisons if c.name == "torque_F")
    assert not np.allclose(torque.model, before.model, rtol=1e-3)
    assert again.mechanism.bodies != result.mechanism.bodies


def _nominal(result, body: str, key: str) -> float:
    mechanism = load_mechanism(result.scene.mechanism)
    return float(getattr(next(b for b in mechanism.bodies if b.name == body), key))
