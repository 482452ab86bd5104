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


def test_shared_spectra_equal_each_alone_and_need_one_measurement(pair) -> None:
    nominal, heavier = pair
    a, b = residual_series(nominal, "tor1"), residual_series(heavier, "tor1")
    assert a.same_measurement(b) and not a.same(b)
    for shared, alone in zip(shared_residual_spectra([a, b]),
                             (residual_spectra(a), residual_spectra(b)), strict=True):
        _assert_same_bits(shared, alone)
    other = dataclasses.replace(b, measured=b.measured * 1.01)
    with pytest.raises(ValueError, match="one measurement"):
        shared_residual_spectra([a, other])
    # a series of another measurement is analysed on its own
    alone = rigidity._evidence_pair(a, other, rigidity.UPPER_HZ)
    assert ([json.dumps(rigidity.evidence_record(e)) for e in alone]
            == [json.dumps(rigidity.evidence_record(rigidity.rigidity_evidence(s)))
                for s in (a, other)])
