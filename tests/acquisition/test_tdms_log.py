"""nptdms's log messages during rigval's reads: captured locally, nptdms's loggers untouched."""

from __future__ import annotations

import logging
import threading
from pathlib import Path

import numpy as np
import pytest
from nptdms import ChannelObject, TdmsWriter

from rigval.acquisition import read_stream
from rigval.acquisition.tdms_log import captured_nptdms_messages
from rigval.acquisition.warn import DataWarning


def _odd_scale_file(path: Path) -> Path:
    """One channel whose scale type nptdms does not know (nptdms logs a warning on reading)."""
    props = {"wf_start_time": np.datetime64("2026-01-01T00:00:00"), "wf_increment": 0.001,
             "wf_start_offset": 0.0, "NI_Number_Of_Scales": 1,
             "NI_Scale[0]_Scale_Type": "Made Up"}
    with TdmsWriter(path) as writer:
        writer.write_segment([ChannelObject("g", "c", np.arange(10.0), properties=props)])
    return path


def _levels_and_filters() -> dict[str, tuple[int, int]]:
    manager = logging.Logger.manager
    return {name: (logging.getLogger(name).level, len(logging.getLogger(name).filters))
            for name in list(manager.loggerDict) if name.startswith("nptdms")}


def test_nptdms_warning_is_captured_at_debug_and_loggers_are_unchanged(
        tmp_path: Path, caplog: pytest.LogCaptureFixture,
        capfd: pytest.CaptureFixture[str]) -> None:
    path = _odd_scale_file(tmp_path / "odd.tdms")
    import nptdms.scaling  # noqa: F401  (creates the logger that warns)

    before = _levels_and_filters()
    with caplog.at_level(logging.DEBUG, logger="rigval.acquisition.tdms_log"), \
            pytest.warns(DataWarning, match="scale type 'Made Up' is not applied"):
        ds = read_stream(path)
    np.testing.assert_array_equal(ds["c"].values, np.arange(10.0))  # raw values, as warned
    assert "nptdms WARNING: Unsupported scale type: Made Up" in caplog.messages
    assert "[nptdms.scaling WARNING]" not in capfd.readouterr().err  # nptdms's handler: silent
    assert _levels_and_filters() == before


def test_capture_leaves_other_threads_and_later_calls_alone() -> None:
    seen: list[str] = []

    class Keep(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            seen.append(record.getMessage())

    target = logging.getLogger("nptdms.scaling")
    handler = Keep(logging.WARNING)
    target.addHandler(handler)
    try:
        with captured_nptdms_messages():
            target.warning("mine")  # this thread: captured
            other = threading.Thread(target=target.warning, args=("other thread",))
            other.start()
            other.join()
        target.warning("after")
    finally:
        target.removeHandler(handler)
    assert seen == ["other thread", "after"]
