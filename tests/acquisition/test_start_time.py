"""Start times as shown by ``rigval info`` and ``rigval init``: a CSV's local time without a zone
is shown as local time, zone unknown (not with a "Z", which made its device look an hour away
from the others), or in the zone its reader was given."""

from __future__ import annotations

from pathlib import Path

import pytest

from rigval.acquisition.start_time import start_time_text
from rigval.acquisition.time_fallbacks import LOCAL_TIME_AS_UTC, TimeFallback, taken_as_utc
from rigval.sample_data import runs_dir
from rigval.validation.cli import main


def test_start_time_text() -> None:
    utc = "2026-03-11T08:07:23.506000000Z"
    assert start_time_text(utc) == utc  # a UTC time stays as it is
    assert (start_time_text("2026-03-11T09:07:23.506000000Z", zone_unknown=True)
            == "2026-03-11 09:07:23.506 local time, zone unknown")
    assert (start_time_text("2026-03-11T09:07:23.000000000Z", zone_unknown=True)
            == "2026-03-11 09:07:23 local time, zone unknown")
    # Berlin: UTC+1 in March (CET), UTC+2 in July (CEST)
    assert (start_time_text(utc, timezone="Europe/Berlin")
            == "2026-03-11T09:07:23.506000+01:00 (Europe/Berlin)")
    assert (start_time_text("2026-07-01T10:00:00.000000000Z", timezone="Europe/Berlin")
            == "2026-07-01T12:00:00+02:00 (Europe/Berlin)")
    assert taken_as_utc([TimeFallback("no wf_start_offset", "taken as 0 s"),
                         TimeFallback("local date-times without a zone", LOCAL_TIME_AS_UTC)])
    assert not taken_as_utc([TimeFallback("no start time in the file",
                                          "start_time unknown (1904-01-01)")])
    assert not taken_as_utc(())


def _first_local_time(csv: Path) -> str:
    """The start time as the CSV file's header writes it (day first, comma decimals)."""
    for line in csv.read_text(encoding="utf-8").splitlines():
        if line.startswith("Start time;"):
            return line.split(";")[1]
    raise AssertionError("no start time in the header")


def test_info_shows_a_csv_start_as_local_time(capsys: pytest.CaptureFixture[str]) -> None:
    csv = runs_dir() / "run_0p8_wls2.csv"
    day, clock = _first_local_time(csv).split(" ")  # e.g. 11.03.2026 09:07:23,506
    d, m, y = day.split(".")
    local = f"{y}-{m}-{d} {clock.replace(',', '.')}"
    assert main(["info", str(csv)]) == 0
    out = capsys.readouterr().out
    assert f"start {local} local time, zone unknown" in out
    assert main(["info", str(csv), "--timezone", "Europe/Berlin"]) == 0
    out = capsys.readouterr().out
    assert f"start {y}-{m}-{d}T{clock.replace(',', '.')}000+01:00 (Europe/Berlin)" in out
    assert main(["info", str(runs_dir() / "run_0p8_cdaq.tdms")]) == 0
    assert "Z\n" in capsys.readouterr().out  # TDMS start times are UTC


def test_init_comments_the_csv_start_as_local_time(tmp_path: Path) -> None:
    scene = tmp_path / "scene.toml"
    assert main(["init", str(runs_dir() / "run_0p8_wls2.csv"), "--out", str(scene), "-q"]) == 0
    line = next(s for s in scene.read_text().splitlines() if s.startswith("file = "))
    assert line.endswith("local time, zone unknown") and "Z" not in line.split("start")[1]
