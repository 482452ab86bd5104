"""The campaign summary says what each run could not use and what it warned about.

Each run's alignment.json (in the layout the validation writes) lists per stream its gaps, the
samples dropped in segments that could not be aligned with the reason, and the reference pulses
missed; the summary page and campaign.json carry those counts per run, and every warning a run
raised, so that nothing a campaign lost is silent.
"""

from __future__ import annotations

import json
from pathlib import Path

from rigval.acquisition.errors import DataWarning
from rigval.validation.campaign.engine import RunOutcome, RunWarning
from rigval.validation.campaign.report import data_not_used, write_campaign_report

ALIGNMENT = {
    "cdaq": {"reference": True, "gaps": [], "samples_dropped": 0, "segment_table": [],
             "events_missing": 1, "events_spurious": 0},
    "wls1": {"reference": False,
             "gaps": [{"after_s": 5.0, "duration_s": 0.2, "missing_samples": 322},
                      {"after_s": 9.0, "duration_s": 0.1, "missing_samples": 161}],
             "samples_dropped": 2805,
             "segment_table": [
                 {"segment": 0, "samples_dropped": 0, "dropped_because": ""},
                 {"segment": 1, "samples_dropped": 2805,
                  "dropped_because": "2 edges in 1.7 s: fewer than 3 pulses to fit"},
                 {"segment": 2, "samples_dropped": 0, "dropped_because": ""}],
             "events_missing": 0, "events_spurious": 3,
             "invalid_samples": {"empty cells": 12, "unaligned segment": 2805}},
}


def _run(tmp_path: Path, name: str, *, alignment: bool, warned: tuple[RunWarning, ...] = ()
         ) -> RunOutcome:
    run_dir = tmp_path / name
    run_dir.mkdir()
    outputs = ["report.html"]
    (run_dir / "report.html").write_text("<html></html>")
    if alignment:
        (run_dir / "alignment.json").write_text(json.dumps(ALIGNMENT))
        outputs.append("alignment.json")
    return RunOutcome(name=name, scene=tmp_path / f"{name}.toml", run_dir=run_dir,
                      status="passed", outputs=tuple(outputs), speed_rev_s=1.0,
                      warnings=warned)


def test_rows_count_gaps_dropped_samples_and_pulses(tmp_path: Path) -> None:
    rows = data_not_used(_run(tmp_path, "a", alignment=True))
    assert [r["stream"] for r in rows] == ["cdaq", "wls1"]
    wls1 = rows[1]
    assert wls1["gaps"] == 2 and wls1["samples missing in gaps"] == 322 + 161
    assert wls1["samples dropped"] == 2805
    assert wls1["why dropped"] == "2 edges in 1.7 s: fewer than 3 pulses to fit"
    assert (wls1["pulses missing"], wls1["pulses spurious"]) == (0, 3)
    assert wls1["invalid samples"] == 12 + 2805
    assert wls1["why invalid"] == "empty cells: 12; unaligned segment: 2805"
    assert rows[0]["samples dropped"] == 0 and rows[0]["why dropped"] is None
    assert rows[0]["invalid samples"] is None  # a file that does not record them
    assert data_not_used(_run(tmp_path, "b", alignment=False)) == []


def test_unreadable_alignment_is_a_note_not_a_crash(tmp_path: Path) -> None:
    outcome = _run(tmp_path, "c", alignment=True)
    (outcome.run_dir / "alignment.json").write_text("{ not json")
    (row,) = data_not_used(outcome)
    assert row["stream"] is None and "alignment.json cannot be read" in row["note"]


def test_summary_page_and_json_carry_the_losses_and_warnings(tmp_path: Path) -> None:
    warned = (RunWarning(DataWarning, "stream wls1: 12 empty cells (channel: tor1)"),)
    outcomes = [_run(tmp_path, "lossy", alignment=True, warned=warned),
                _run(tmp_path, "other", alignment=False)]
    files = write_campaign_report(outcomes, tmp_path)
    document = json.loads(files.outcomes_json.read_text())
    lossy = document["runs"][0]
    assert lossy["data_not_used"][1]["samples dropped"] == 2805
    assert lossy["warnings"] == ["DataWarning: stream wls1: 12 empty cells (channel: tor1)"]
    assert document["runs"][1]["data_not_used"] == []
    page = files.html.read_text()
    assert "Data not used" in page and "fewer than 3 pulses to fit" in page
    assert ">2805<" in page.replace(",", "") and ">483<" in page.replace(",", "")
    assert "DataWarning: stream wls1: 12 empty cells (channel: tor1)" in page
