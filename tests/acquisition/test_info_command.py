"""``rigval info`` describes all three formats from metadata and reports bad files with exit 3."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from rigval.validation.cli import main


def test_info_describes_real_files_of_each_format(realdata_dir: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    files = [realdata_dir / "nidaqmx-python/data_ai.tdms",
             realdata_dir / "npTDMS/Digital_Input.tdms", realdata_dir / "lvm_read/short.lvm"]
    assert main(["info", *map(str, files)]) == 0
    out = capsys.readouterr().out
    assert "stream '_unnamedTask<0>': 1000 Hz, 7000 samples, 7 s" in out
    assert "'Torque02': 7000 samples, units 'Volts', starts 1.09996e-05 s after the stream" in out
    assert "skipped group (decimated)" in out
    assert "time: no wf_start_offset: taken as 0 s" in out
    assert "'Response (Trigger)': 10 samples, units 'm/s^2'" in out


def test_info_json_and_csv_gaps(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    csv = tmp_path / "wls2.csv"
    csv.write_text("Time [s];tor3 [V/V]\n0,000;1\n0,001;2\n0,002;3\n0,010;4\n0,011;5\n")
    assert main(["info", "--json", str(csv)]) == 0
    (info,) = json.loads(capsys.readouterr().out)
    (stream,) = info["streams"]
    assert stream["samples"] == 5
    assert stream["gaps"][0]["missing_samples"] == 7
    assert stream["channels"][0]["units"] == "V/V"
    assert stream["time_fallbacks"] == [{"reason": "no start time in the file",
                                         "used": "start_time unknown (1904-01-01)",
                                         "channel": ""}]


def test_info_reports_unreadable_files_and_goes_on(tmp_path: Path, realdata_dir: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    pointer = tmp_path / "run.tdms"
    pointer.write_text("version https://git-lfs.github.com/spec/v1\n")
    good = realdata_dir / "npTDMS/raw1.tdms"
    assert main(["info", str(pointer), str(good)]) == 3
    captured = capsys.readouterr()
    assert "Git-LFS pointer" in captured.err
    assert "'Seventh Cha': 2000 samples" in captured.out
    assert "Traceback" not in captured.err
    # a missing file is a usage error (2) of every command, found before any file is read
    assert main(["info", str(good), str(tmp_path / "nope.tdms")]) == 2
    captured = capsys.readouterr()
    assert "nope.tdms does not exist: check the path" in captured.err
    assert captured.out == "" and "scene" not in captured.err


def test_info_reads_tdms_metadata_only_and_shows_restart_gaps(
        tmp_path: Path, realdata_dir: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    import numpy as np
    from nptdms import ChannelObject, GroupObject, TdmsWriter

    t0 = np.datetime64("2026-11-21T05:00:00")
    props = {"wf_increment": 1e-3, "wf_start_time": t0, "wf_start_offset": 0.0}
    path = tmp_path / "wls.tdms"
    with TdmsWriter(path) as writer:
        writer.write_segment([GroupObject("task"), ChannelObject("task", "x", np.ones(100), props)])
        writer.write_segment([ChannelObject("task", "x", np.ones(50),
                                            {"wf_start_time": t0 + np.timedelta64(2, "s")})])
    import rigval.acquisition.tdms as tdms_module

    def no_data_reads(*args: object, **kwargs: object) -> None:
        raise AssertionError("info must not read sample data")

    monkeypatch.setattr(tdms_module.TdmsFile, "open", no_data_reads)
    monkeypatch.setattr(tdms_module.TdmsFile, "read", no_data_reads)
    assert main(["info", "--json", str(path)]) == 0
    (info,) = json.loads(capsys.readouterr().out)
    (stream,) = info["streams"]
    assert stream["samples"] == 150
    assert stream["gaps"] == [{"after_s": 0.099, "duration_s": pytest.approx(1.9),
                               "missing_samples": 1900}]
    assert main(["info", "--all-groups", str(realdata_dir / "npTDMS/Digital_Input.tdms")]) == 0
    out = capsys.readouterr().out
    assert out.count("stream '") == 3
