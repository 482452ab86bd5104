"""The scene's mechanism is assembled before any data are read, and handed to the caller.

The assembly a caller gets before the read (``after_assembly``: the report's sketch is drawn
while the data are read) is the mechanism and configuration the run's result holds.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np

from rigval.sample_data import runs_dir
from rigval.validation import pipeline


def _copy(folder: Path) -> Path:
    for path in runs_dir().glob("run_0p8_*"):
        shutil.copy(path, folder)
    return folder / "run_0p8_scene.toml"


def test_the_assembly_handed_before_the_read_is_the_modelled_mechanism(tmp_path, monkeypatch):
    scene = _copy(tmp_path)
    order, handed = [], []
    read_streams = pipeline.read_streams

    def reading(*args, **kwargs):
        order.append("read")
        return read_streams(*args, **kwargs)

    def assembled(assembly):
        order.append("assembly")
        handed.append(assembly)

    monkeypatch.setattr(pipeline, "read_streams", reading)
    result = pipeline.run_scene(scene, after_assembly=assembled)
    assert order == ["assembly", "read"]
    (assembly,) = handed
    assert assembly.mechanism == result.mechanism
    assert assembly.configuration is result.configuration
    assert assembly.shown_points == tuple(str(p) for p in result.predictions["point"].values)
    # the configuration is the mechanism assembled at t = 0: its tip P1 where the model puts it
    tip = assembly.configuration["point_position"].sel(point="P1").isel(time=0).values
    assert np.all(np.isfinite(tip))
