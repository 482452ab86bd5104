"""Other streams read beside the reference stream give the run the reading here gives.

The read stage reads small files of the other streams in a child forked beside this process,
and finds their clock pulses there (:func:`rigval.validation.read_stage.read_streams`). The
reference is the same run read one stream after the other in this process (``BESIDE_BYTES``
below every file): equal results, the same health findings in the same order, and the same
first error for a scene with a broken stream. Each check runs in a new interpreter, where no
other thread stops the fork.
"""

from __future__ import annotations

import dataclasses
import logging
import shutil
import tempfile
from pathlib import Path

import numpy as np
import xarray as xr

from rigval.validation import pipeline, read_stage
from tests.validation.fresh_process import no_fork_here, run_in_a_fresh_process


def _shipped_copy() -> Path:
    """A copy of the first shipped run's files; returns its scene."""
    from rigval.sample_data import runs_dir

    folder = Path(tempfile.mkdtemp())
    for path in runs_dir().glob("run_0p8_*"):
        shutil.copy(path, folder)
    return folder / "run_0p8_scene.toml"


def _both_ways(scene: Path, records: list[logging.LogRecord]):
    """Run ``scene`` beside and here; return each outcome (result or error) and the log."""
    outcomes = []
    for limit in (read_stage.BESIDE_BYTES, -1):  # beside, then one stream after the other here
        read_stage.BESIDE_BYTES = limit
        records.clear()
        try:
            outcomes.append(pipeline.run_scene(scene))
        except Exception as error:  # compared below
            outcomes.append(error)
        outcomes.append([r.getMessage() for r in records])
    return outcomes


class _Keep(logging.Handler):
    def __init__(self, records: list[logging.LogRecord]) -> None:
        super().__init__()
        self.records = records

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append(record)


def _logged() -> list[logging.LogRecord]:
    records: list[logging.LogRecord] = []
    logging.getLogger("rigval.validation.read_stage").addHandler(_Keep(records))
    logging.getLogger("rigval.validation.read_stage").setLevel(logging.INFO)
    return records


def _same_run_either_way() -> None:
    if no_fork_here():
        return
    beside, beside_log, here, here_log = _both_ways(_shipped_copy(), _logged())
    assert any("read beside the reference stream cdaq" in m for m in beside_log)
    assert not any("read beside" in m for m in here_log)
    assert beside.metric_rows() == here.metric_rows()
    assert beside.health == here.health  # the same findings in the same order
    assert beside.alignment.keys() == here.alignment.keys()
    for name in beside.alignment:
        for field in dataclasses.fields(beside.alignment[name]):
            mine, theirs = (getattr(s.alignment[name], field.name) for s in (beside, here))
            if isinstance(mine, np.ndarray):
                np.testing.assert_array_equal(mine, theirs, err_msg=f"{name}.{field.name}")
            else:
                assert repr(mine) == repr(theirs), f"{name}.{field.name}"
    for tree in (beside.tree, here.tree):  # the history's lines carry the time they were made
        tree.attrs.pop("history")
    xr.testing.assert_identical(beside.tree, here.tree)


def test_other_streams_read_beside_give_the_same_run():
    run_in_a_fresh_process("test_read_beside", "_same_run_either_way", timeout_s=300)


def _same_error_either_way() -> None:
    if no_fork_here():
        return
    records = _logged()
    # a wireless stream's file cut short: the read reports it, beside or here
    scene = _shipped_copy()
    csv = scene.with_name("run_0p8_wls2.csv")
    csv.write_bytes(csv.read_bytes()[:300])
    beside, _, here, _ = _both_ways(scene, records)
    assert isinstance(beside, Exception) and type(beside) is type(here)
    assert str(beside) == str(here)
    # a pulse threshold no edge reaches: the align stage reports it after phi_F, as always
    scene = _shipped_copy()
    text = scene.read_text(encoding="utf-8").replace(
        '[streams.wls1.channels.opt2]\n', '[streams.wls1.channels.opt2]\nthreshold = 1e9\n')
    scene.write_text(text, encoding="utf-8")
    beside, _, here, _ = _both_ways(scene, records)
    assert isinstance(beside, Exception) and type(beside) is type(here)
    assert str(beside) == str(here)


def test_a_broken_other_stream_gives_the_same_error_beside():
    run_in_a_fresh_process("test_read_beside", "_same_error_either_way", timeout_s=300)


def test_large_files_are_read_here(tmp_path, monkeypatch):
    """Beyond BESIDE_BYTES (a long record) the streams are read one after the other here."""
    monkeypatch.setattr(read_stage, "BESIDE_BYTES", 0)
    scene = pipeline.load_scene(_shipped_copy())
    assert not read_stage.reads_beside(scene, pipeline.alignment_settings(scene))


def _small_files_read_beside() -> None:
    if no_fork_here():
        return
    scene = pipeline.load_scene(_shipped_copy())
    assert read_stage.reads_beside(scene, pipeline.alignment_settings(scene))


def test_small_files_are_read_beside():
    run_in_a_fresh_process("test_read_beside", "_small_files_read_beside", timeout_s=120)
