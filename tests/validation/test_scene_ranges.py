"""Every numeric scene key is finite and in range; the error names the scene key (item 9).

Before: ``alignment.pulses.X.angle = nan`` crashed with a traceback in the alignment,
``angle_at_reference = nan`` stopped the model naming an internal drive array,
``counts_per_rev = 1`` named the internal ``cutoff_hz``, and ``highpass_hz``/``lowpass_hz``
above fs/2 were accepted.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from rigval.sample_data import runs_dir
from rigval.validation.cli import main
from rigval.validation.errors import SceneError
from rigval.validation.read_plan import read_streams
from rigval.validation.scene import load_scene
from rigval.validation.stage_settings import check_sample_rates

SHIPPED = runs_dir() / "run_0p8_scene.toml"


def _scene(tmp_path: Path, old: str, new: str) -> Path:
    """The shipped 0.8 rev/s scene with one edit, its data files named by absolute path."""
    text = SHIPPED.read_text()
    assert old in text
    text = text.replace(old, new, 1)
    text = re.sub(r'^(file|note) = "(run_0p8_[^"]+)"',
                  lambda m: f'{m[1]} = "{(runs_dir() / m[2]).as_posix()}"', text, flags=re.M)
    path = tmp_path / "scene.toml"
    path.write_text(text)
    return path


ENC1 = "counts_per_rev = 8192\n\n[streams.cdaq.channels.enc2]"
CASES = [
    ("angle = 0.008221215236712265", "angle = nan", "alignment.pulses.wls2.angle"),
    ("angle = 0.008221215236712265", "angle = inf", "alignment.pulses.wls2.angle"),
    ("angle_at_reference = 1.461333994409296", "angle_at_reference = nan",
     "model.drivers.theta_F.angle_at_reference"),
    (ENC1, ENC1.replace("8192", "1"), "streams.cdaq.channels.enc1.counts_per_rev"),
    (ENC1, ENC1.replace("8192", "15"), "streams.cdaq.channels.enc1.counts_per_rev"),
    ("per_revolution = 2", "per_revolution = 0", "alignment.pulses.wls2.per_revolution"),
    ("gauge_factor = 2.02", "gauge_factor = -inf", "streams.cdaq.channels.str1.gauge_factor"),
    ("highpass_hz = 0.1", "highpass_hz = nan", "streams.cdaq.channels.acc1.highpass_hz"),
    ("highpass_hz = 0.1", "highpass_hz = -1.0", "streams.cdaq.channels.acc1.highpass_hz"),
    ("lowpass_hz = 20.0", "lowpass_hz = nan", "comparisons[0].lowpass_hz"),
    ("scale = 1.0", "scale = nan", "comparisons[0].scale"),
]


@pytest.mark.parametrize(("old", "new", "key"), CASES)
def test_bad_number_is_a_scene_error_naming_the_key(tmp_path: Path, old: str, new: str,
                                                   key: str) -> None:
    with pytest.raises(SceneError) as info:
        load_scene(_scene(tmp_path, old, new))
    assert info.value.where["key"] == key
    assert key in str(info.value) and info.value.hint


def test_cli_exits_2_without_traceback(tmp_path: Path, capsys: pytest.CaptureFixture[str]
                                       ) -> None:
    scene = _scene(tmp_path, "angle = 0.008221215236712265", "angle = nan")
    assert main(["validate", str(scene), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "alignment.pulses.wls2.angle" in err and "Traceback" not in err
    assert not (tmp_path / "out").exists()


@pytest.fixture(scope="module")
def raw() -> dict:
    return read_streams(load_scene(SHIPPED))


@pytest.mark.parametrize(("old", "new", "key", "limit"), [
    ("highpass_hz = 0.1", "highpass_hz = 2500.0", "streams.cdaq.channels.acc1.highpass_hz",
     "2500"),
    ("lowpass_hz = 20.0", "lowpass_hz = 4000.0", "comparisons[0].lowpass_hz", "2250"),
    ("lowpass_hz = 20.0", "lowpass_hz = 2300.0", "comparisons[0].lowpass_hz", "2250"),
])
def test_corners_above_the_rate_name_the_key(tmp_path: Path, raw: dict, old: str, new: str,
                                             key: str, limit: str) -> None:
    scene = load_scene(_scene(tmp_path, old, new))      # the rate is unknown until read
    with pytest.raises(SceneError) as info:
        check_sample_rates(scene, raw)
    assert info.value.where["key"] == key and limit in str(info.value)


def test_shipped_scene_passes_the_rate_checks(raw: dict) -> None:
    check_sample_rates(load_scene(SHIPPED), raw)


def test_wrong_encoder_scale_names_counts_per_rev_not_cutoff_hz(tmp_path: Path,
                                                                capsys: pytest.CaptureFixture[str]
                                                                ) -> None:
    """counts_per_rev = 16 passes the static check but is 512 times too small for the data."""
    scene = _scene(tmp_path, ENC1, ENC1.replace("8192", "16"))
    assert main(["validate", str(scene), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "streams.cdaq.channels.enc1.counts_per_rev = 16" in err
    assert "(key: streams.cdaq.channels.enc1.counts_per_rev" in err and "Traceback" not in err


def test_corner_above_the_rate_stops_the_cli_with_exit_2(tmp_path: Path,
                                                          capsys: pytest.CaptureFixture[str]
                                                          ) -> None:
    scene = _scene(tmp_path, "lowpass_hz = 20.0", "lowpass_hz = 4000.0")
    assert main(["validate", str(scene), "--out", str(tmp_path / "out")]) == 2
    assert "comparisons[0].lowpass_hz" in capsys.readouterr().err
