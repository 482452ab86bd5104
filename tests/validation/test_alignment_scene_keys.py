"""Scene keys of a stream's alignment: start_time_uncertainty_s, coarse_offset_s, method."""

from __future__ import annotations

import pytest

from rigval.sample_data import runs_dir
from rigval.validation.errors import SceneError
from rigval.validation.scene import parse_scene

SHIPPED = runs_dir() / "run_0p8_scene.toml"
WLS1 = 'wls1 = { channel = "opt2", per_revolution = 1 }'


def _scene(entry: str):
    text = SHIPPED.read_text()
    assert WLS1 in text
    return parse_scene(text.replace(WLS1, f"wls1 = {{ {entry} }}"), SHIPPED)


def test_defaults_and_values() -> None:
    pulses = _scene('channel = "opt2"').alignment.pulses
    assert pulses["wls1"].method == "pulses"
    assert pulses["wls1"].coarse_offset_s is None
    assert pulses["wls1"].start_time_uncertainty_s is None
    # the shipped scene states WLS #2's laptop-clock bound
    assert pulses["wls2"].start_time_uncertainty_s == pytest.approx(1.116)
    spec = _scene('channel = "opt2", coarse_offset_s = -1.25, '
                  "start_time_uncertainty_s = 0.2").alignment.pulses["wls1"]
    assert (spec.coarse_offset_s, spec.start_time_uncertainty_s) == (-1.25, 0.2)
    stamps = _scene('method = "stamps"').alignment.pulses["wls1"]
    assert stamps.method == "stamps" and stamps.channel is None


@pytest.mark.parametrize(("entry", "key", "text"), [
    ('channel = "opt2", start_time_uncertainty_s = -0.1', "start_time_uncertainty_s",
     "positive"),
    ('channel = "opt2", start_time_uncertainty_s = 0', "start_time_uncertainty_s", "positive"),
    ('channel = "opt2", coarse_offset_s = "1 s"', "coarse_offset_s", "expected"),
    ('channel = "opt2", method = "ptp"', "method", "expected one of"),
    ('method = "pulses"', "channel", "missing required key"),
    ('channel = "opt2", coarse_offset = 1.0', "coarse_offset", "unknown"),
])
def test_bad_values_name_the_key(entry: str, key: str, text: str) -> None:
    with pytest.raises(SceneError, match=text) as info:
        _scene(entry)
    assert f"alignment.pulses.wls1.{key}" in str(info.value)

