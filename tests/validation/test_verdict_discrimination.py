"""The shipped scenes' verdict tells the right mechanism from one with a body 5 % off.

The virtual rig runs a mechanism file; its scene is validated against the nominal built-in
pendulum. The right mechanism must pass (every threshold, "model error not detected") at each
shipped speed and seed; an arm 5 % heavier must be detected on the whole drive torques that see
it (torque_F, torque_H, each more than 3 % of its RMS, docs/metrics.md) and not on the
accelerations, which do not depend on masses. An arm inertia 5 % larger changes torque_F by about
1.4 % in the shape of torque_F itself, like a calibration gain: the whole-curve statement cannot
see it at a 1 % torque calibration, but the common-gain statement does (the four shafts share
most of their calibration, so torque_F's gain disagreeing with torque_H's is a model error).
"""

import re
from pathlib import Path

import pytest

from rigval.model import builtin_mechanism
from rigval.sample_data import RigSettings, runs_dir, simulate_rig
from rigval.validation.pipeline import run_scene
from rigval.validation.verdict import run_verdict

# alignment warnings about a run's Wi-Fi dropouts are the rig's imperfections, not the subject
pytestmark = pytest.mark.filterwarnings("ignore::rigval.acquisition.errors.DataWarning")


def _scaled(folder: Path, body: str, key: str, factor: float) -> Path:
    text = Path(builtin_mechanism("pendulum")).read_text(encoding="utf-8")
    pattern = rf'(name = "{body}"\n(?:.*\n)*?){key} = ([0-9.]+)'
    text, count = re.subn(pattern, lambda m: f"{m[1]}{key} = {float(m[2]) * factor!r}", text,
                          count=1)
    assert count == 1
    path = folder / f"{body}_{key}.toml"
    path.write_text(text, encoding="utf-8")
    return path


def _validate_against_nominal(folder: Path, mechanism: Path, speed: float, seed: int,
                              duration: float = 8.0):
    files = simulate_rig(folder / f"run{seed}", RigSettings(
        speed=speed, duration=duration, seed=seed, mechanism=mechanism))
    scene = files.path("scene.toml")
    scene.write_text(re.sub(r"^mechanism = .*$", 'mechanism = "builtin:pendulum"',
                            scene.read_text(encoding="utf-8"), flags=re.M), encoding="utf-8")
    return run_scene(scene)


@pytest.mark.parametrize("scene", ["run_0p8_scene.toml", "run_1p2_scene.toml"])
def test_right_mechanism_passes_the_shipped_runs(scene):
    result = run_scene(runs_dir() / scene)
    verdict = run_verdict(result)
    assert result.passed
    assert not verdict["detected"], verdict["statement"]
    assert verdict["statement"].startswith("Model error not detected")


@pytest.mark.parametrize(("speed", "seed"), [(0.8, 1), (1.2, 2)])
def test_heavier_arm_is_detected_where_it_shows(tmp_path, speed, seed):
    result = _validate_against_nominal(tmp_path, _scaled(tmp_path, "A", "mass", 1.05), speed,
                                       seed)
    verdict = run_verdict(result)
    assert {"torque_F", "torque_H"} <= set(verdict["detected_on"]), verdict["statement"]
    assert not {"acc1", "acc2"} & set(verdict["detected_on"])
    assert not result.passed
    assert verdict["statement"].startswith("Model error detected (|E| > k u_val)")


@pytest.mark.parametrize(("speed", "seed"),
                         [(0.8, 3), pytest.param(1.2, 4, marks=pytest.mark.slow)])
def test_larger_arm_inertia_is_detected_by_the_common_gain(tmp_path, speed, seed):
    result = _validate_against_nominal(tmp_path, _scaled(tmp_path, "A", "inertia", 1.05), speed,
                                       seed)
    scores = {c.name: c.scores for c in result.comparisons}
    # the whole-curve statement alone cannot see it: a 1 % calibration covers a 1.4 % gain
    assert not scores["torque_F"]["vv20.curve.detected"]
    # the model's torque_F is about 1.3 % low (a gain), torque_H's is not
    assert -0.02 < scores["torque_F"]["vv20.curve.gain"] < -0.008
    assert abs(scores["torque_H"]["vv20.curve.gain"]) < 0.005
    verdict = run_verdict(result)
    assert {"torque_F", "torque_H"} == set(verdict["detected_on"]), verdict["statement"]
    assert "against the common" in verdict["statement"]
    failed = {(c.name, check.metric) for c in result.comparisons for check in c.checks
              if not check.passed}
    assert failed == {("torque_F", "vv20.common_gain.normalised_error"),
                      ("torque_H", "vv20.common_gain.normalised_error")}


@pytest.mark.slow
@pytest.mark.parametrize("speed", [0.8, 1.2])
@pytest.mark.parametrize("seed", [11, 12, 13])
def test_right_and_wrong_mechanism_over_seeds(tmp_path, speed, seed):
    nominal = Path(builtin_mechanism("pendulum"))
    right = _validate_against_nominal(tmp_path, nominal, speed, seed, 12.0)
    assert right.passed and not run_verdict(right)["detected"], run_verdict(right)["statement"]
    for key in ("mass", "inertia"):
        wrong = _validate_against_nominal(tmp_path / key, _scaled(tmp_path, "A", key, 1.05),
                                          speed, seed + 100, 12.0)
        assert {"torque_F", "torque_H"} <= set(run_verdict(wrong)["detected_on"]), key
