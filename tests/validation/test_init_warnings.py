"""``rigval init`` warns about files that can never validate: a record shorter than
``min_cycles`` revolutions, an encoder that never moves; and without ``--mechanism`` the model
item's hint says where the names come from instead of "one of: the joint"."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

from rigval.validation.cli import EXIT_OK, main
from rigval.validation.scene_init import MIN_CYCLES

#: The warnings are shown (the test configuration turns rigval's warnings into errors).
SHOWN = pytest.mark.filterwarnings("default::rigval.acquisition.errors.DataWarning")


@SHOWN
def test_short_record_is_warned_about(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from rigval.sample_data import RigSettings, simulate_rig

    # 3 s at 0.8 rev/s: 2.4 revolutions, at most 3 reference pulses, 2 complete revolutions
    files = simulate_rig(tmp_path / "rig", RigSettings(speed=0.8, duration=3.0, seed=2))
    scene = tmp_path / "scene.toml"
    assert main(["init", str(files.path("cdaq.tdms")), "--out", str(scene)]) == EXIT_OK
    err = capsys.readouterr().err
    assert f"fewer than [angle] min_cycles = {MIN_CYCLES}" in err
    found = re.match(r"rigval: warning: DataWarning: run_0p8_cdaq\.opt1: (\d) complete "
                     r"revolution\(s\) between the reference pulses in 3 s", err)
    assert found and 1 <= int(found.group(1)) <= 2, err  # 2.4 turns: 2 or 3 pulses
    assert f"# WARNING: run_0p8_cdaq.opt1: {found.group(1)} complete" in scene.read_text()
    # a record long enough for min_cycles revolutions gets no warning
    files = simulate_rig(tmp_path / "rig8", RigSettings(speed=0.8, duration=6.0, seed=2))
    assert main(["init", str(files.path("cdaq.tdms")), "--out",
                 str(tmp_path / "long.toml")]) == EXIT_OK
    assert "warning" not in capsys.readouterr().err
    assert "WARNING" not in (tmp_path / "long.toml").read_text()


@SHOWN
def test_an_encoder_that_never_moves_is_warned_about(tmp_path: Path,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    csv = tmp_path / "run.csv"
    k = np.arange(4000)
    moving = np.floor(k * 1.7).astype(int)  # counts of a turning shaft
    rows = ["Time;enc1;enc2"] + [f"{i / 1000:.3f};{m};1234" for i, m in zip(k, moving,
                                                                            strict=True)]
    csv.write_text("\n".join(rows) + "\n")
    scene = tmp_path / "scene.toml"
    assert main(["init", str(csv), "--out", str(scene)]) == EXIT_OK
    warned = [line for line in capsys.readouterr().err.splitlines() if "warning" in line]
    assert warned == ["rigval: warning: DataWarning: run.enc2: the counts never change in this "
                      "file: the encoder did not turn or is not connected, so no revolution can "
                      "be compared"]
    assert "# WARNING: run.enc2: the counts never change" in scene.read_text()


def test_item_hint_without_mechanism(tmp_path: Path) -> None:
    from rigval.sample_data import runs_dir

    scene = tmp_path / "scene.toml"
    assert main(["init", str(runs_dir() / "run_0p8_wls1.tdms"), "--out", str(scene),
                 "-q"]) == EXIT_OK
    text = scene.read_text()
    assert "one of: the" not in text
    items = [line for line in text.splitlines() if line.startswith("model.item")]
    assert items and all("rigval init --mechanism lists them" in line for line in items)
    assert tomllib.loads(text)["mechanism"] == "TODO"
