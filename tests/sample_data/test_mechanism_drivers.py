"""The virtual rig reads its drive laws through the mechanism parser (sample_data.simulate)."""

from __future__ import annotations

from pathlib import Path

import pytest

import rigval.model as rm
from rigval.acquisition.errors import ConfigError
from rigval.model.laws import Harmonic
from rigval.sample_data.simulate import default_mechanism, mechanism_drivers

LIFT_HARMONIC = "harmonics = [{ amplitude = 0.1, omega = 6.283185307179586, phase = 0.0 }]"


def test_pendulum_laws_are_the_file_laws() -> None:
    drivers = mechanism_drivers(default_mechanism())
    mech = rm.load_mechanism(default_mechanism())
    assert drivers["theta_F"] == (mech.drivers[0].theta0, (Harmonic(0.05, 1, 0.0),))
    assert drivers["theta_H"] == (mech.drivers[1].theta0, (Harmonic(0.1, 1, 0.0),))


@pytest.mark.parametrize(("replacement", "match", "key"), [
    (LIFT_HARMONIC.replace("6.283185307179586", "9.42477796076938"), "not a whole number",
     "drivers.theta_H.harmonics[0]"),
    (LIFT_HARMONIC.replace("6.283185307179586", "-6.283185307179586"), "not a whole number",
     "drivers.theta_H.harmonics[0]"),
])
def test_a_harmonic_that_is_not_a_whole_positive_multiple_is_refused(
        tmp_path: Path, replacement: str, match: str, key: str) -> None:
    text = default_mechanism().read_text()
    assert LIFT_HARMONIC in text
    path = tmp_path / "m.toml"
    path.write_text(text.replace(LIFT_HARMONIC, replacement))
    with pytest.raises(ConfigError, match=match) as info:
        mechanism_drivers(path)
    assert info.value.where["key"] == key


def test_a_file_that_is_no_mechanism_is_a_config_error(tmp_path: Path) -> None:
    path = tmp_path / "m.toml"
    path.write_text("schema = 'something else'\n")
    with pytest.raises(ConfigError, match="missing key 'bodies'"):
        mechanism_drivers(path)
