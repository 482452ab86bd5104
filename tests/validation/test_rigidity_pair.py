"""Two validations of one measurement analysed together give each one's own rigidity evidence.

``rigval identify`` writes ``rigidity.json`` for the nominal and the identified run, one
measurement against two mechanisms (:func:`rigval.validation.diagnosis.rigidity.
run_rigidity_pair`): a residual equal in both is analysed once, the others share the work
that depends on the measurement alone. The expectation is each run analysed on its own
(:func:`run_rigidity`), to the bit: the JSON records are compared as text.
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from rigval.model import load_mechanism
from rigval.model.mechanism_text import apply_parameters, mechanism_toml
from rigval.sample_data import shipped_runs
from rigval.validation.diagnosis import rigidity
from rigval.validation.diagnosis.residual import residual_series
from rigval.validation.diagnosis.spectra import residual_spectra, shared_residual_spectra
from rigval.validation.pipeline import run_scene_kept


@pytest.fixture(scope="module")
def pair(tmp_path_factory: pytest.TempPathFactory):
    """The shipped run and the same measurement against an arm 8 % heavier."""
    nominal, measurement = run_scene_kept(shipped_runs()[0])
    mechanism = load_mechanism(nominal.scene.mechanism)
    mass = next(b.mass for b in mechanism.bodies if b.name == "A")
    path = tmp_path_factory.mktemp("mechanism") / "heavier.toml"
    path.write_text(mechanism_toml(apply_parameters(mechanism, {"A.mass": 1.08 * mass})),
                    encoding="utf-8")
    return nominal, measurement.against(path)


def _text(evidence: dict[str, rigidity.RigidityEvidence]) -> dict[str, str]:
    return {name: json.dumps(rigidity.evidence_record(e)) for name, e in evidence.items()}


def _assert_same_bits(a: object, b: object) -> None:
    """Equal dataclasses, every array and float to the bit."""
    if dataclasses.is_dataclass(a):
        for field in dataclasses.fields(a):
            _assert_same_bits(getattr(a, field.name), getattr(b, field.name))
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
    else:
        assert np.asarray(a).tobytes() == np.asarray(b).tobytes(), (a, b)


def test_pair_equals_each_run_analysed_alone(pair) -> None:
    nominal, heavier = pair
    first, second = rigidity.run_rigidity_pair(nominal, heavier)
    assert _text(first) == _text(rigidity.run_rigidity(nominal))
    assert _text(second) == _text(rigidity.run_rigidity(heavier))
    # both ways were taken: accelerations do not depend on the arm's mass, torques do
    assert first["acc1"] is second["acc1"]
    assert first["torque_F"] is not second["torque_F"]
    assert _text(first)["torque_F"] != _text(second)["torque_F"]


@pytest.mark.parametrize("held", [rigidity.SHARED_SAMPLES, 7000, 1])
def test_run_rigidity_equals_each_comparison_analysed_alone(pair, held: int,
                                                            monkeypatch: pytest.MonkeyPatch
                                                            ) -> None:
    """The comparisons at the same samples (one stream's) are analysed together, as many as
    ``held`` samples allow (7000: two of the run's series of about 3100 samples; 1: one)."""
    nominal, _ = pair
    alone = {c.name: rigidity.rigidity_evidence(residual_series(nominal, c.name))
             for c in nominal.comparisons}
    monkeypatch.setattr(rigidity, "SHARED_SAMPLES", held)
    found = rigidity.run_rigidity(nominal)
    assert list(found) == list(alone)  # the comparisons' order: rigidity.json's keys
    assert _text(found) == _text(alone)
    groups = rigidity._same_samples({name: [residual_series(nominal, name)] for name in alone})
    assert ["tor1", "tor2", "torque_F"] in groups and ["acc1", "acc2"] in groups


def test_shared_spectra_equal_each_alone_and_need_the_same_samples(pair) -> None:
    nominal, heavier = pair
    series = [residual_series(result, name) for name in ("tor1", "tor2", "torque_F")
              for result in (nominal, heavier)]
    assert series[0].same_measurement(series[1]) and not series[0].same(series[1])
    assert series[0].same_samples(series[2]) and not series[0].same_measurement(series[2])
    shared = shared_residual_spectra(series)
    for one, alone in zip(shared, (residual_spectra(s) for s in series), strict=True):
        _assert_same_bits(one, alone)
    assert shared[0].measured is shared[1].measured  # one measured signal's spectrum, once
    other = dataclasses.replace(series[1], phi=series[1].phi + 1e-9)
    with pytest.raises(ValueError, match="the same samples"):
        shared_residual_spectra([series[0], other])
