"""A long record's other streams are read after phi_F, and the run is the same.

Where the other streams are not read beside the reference stream (large files, or no fork),
:func:`rigval.validation.read_stage.read_streams` reads the reference stream alone and
:func:`rigval.validation.read_stage.read_later` reads the others in the align stage, once phi_F
and the encoders are let go (memory). Independent expectations: each file's SHA-256 from
:mod:`hashlib`, the scene's stream order for the health findings, and the run of the same
scene read beside (tests/validation/test_read_beside.py compares the whole result).
"""

from __future__ import annotations

import hashlib

import pytest

from rigval.processing.health import Finding
from rigval.sample_data import runs_dir
from rigval.validation import pipeline, read_stage
from rigval.validation.health import HealthLog
from rigval.validation.read_plan import read_plan
from rigval.validation.scene import load_scene
from rigval.validation.stage_settings import alignment_settings
from rigval.validation.stopwatch import Stopwatch


def _sha256(path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_the_reference_stream_is_read_first_and_the_others_later(monkeypatch):
    monkeypatch.setattr(read_stage, "BESIDE_BYTES", -1)
    scene = load_scene(runs_dir() / "run_0p8_scene.toml")
    settings = alignment_settings(scene)
    plan = read_plan(scene, settings)
    read = read_stage.read_streams(scene, plan, settings, Stopwatch(quiet=True))
    others = tuple(name for name in scene.streams if name != settings.reference)
    assert set(read.converted) == {settings.reference} and read.later == others
    unread = {scene.streams[name].file for name in others}
    assert {path for path, _ in read.inputs.digests} == set(scene.input_files) - unread
    inputs, streams = read_stage.read_later(scene, plan, read.later, read.inputs,
                                            Stopwatch(quiet=True))
    assert set(streams) == set(others)
    assert [path for path, _ in inputs.digests] == list(scene.input_files)
    for path, digest in inputs.digests:
        assert digest == _sha256(path), path


def test_phi_f_is_made_before_the_other_streams_are_read(monkeypatch):
    monkeypatch.setattr(read_stage, "BESIDE_BYTES", -1)
    calls: list[str] = []

    def spy(name: str):
        real = getattr(pipeline, name)

        def called(*args, **kwargs):
            calls.append(name)
            return real(*args, **kwargs)
        return called

    for name in ("_phi_f", "_drives", "read_later", "_align"):
        monkeypatch.setattr(pipeline, name, spy(name))
    pipeline.run_scene(runs_dir() / "run_0p8_scene.toml")
    assert calls == ["_phi_f", "_drives", "read_later", "_align"]


def _finding(channel: str) -> Finding:
    return Finding(channel, "spikes", channel, 1, 0, 0, 0.0, 0.0, 1.0, (0,), (0,))


@pytest.mark.parametrize("found", [["wls2.tor3", "cdaq.acc1", "wls1.opt2", "wls2.opt3",
                                    "cdaq.enc1"],
                                   ["cdaq.enc1"], []])
def test_findings_come_in_the_scene_stream_order(found):
    scene = load_scene(runs_dir() / "run_0p8_scene.toml")
    log = HealthLog(scene)
    log.findings = [_finding(channel) for channel in found]
    log.in_stream_order()
    rank = {name: k for k, name in enumerate(scene.streams)}
    expected = sorted(found, key=lambda channel: rank[channel.split(".")[0]])  # stable
    assert [finding.channel for finding in log.findings] == expected
