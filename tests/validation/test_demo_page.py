"""``rigval demo`` writes the campaign's summary page (one page, one name: ``index.html``): the
V&V 20 verdict and the result as banners, each run linking its report, the failed run's reason."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

from rigval.sample_data import runs_dir
from rigval.validation.campaign.report import SUMMARY_PAGE
from rigval.validation.cli import EXIT_FAILED, main


def test_demo_summary_is_the_campaign_page(tmp_path: Path,
                                           monkeypatch: pytest.MonkeyPatch) -> None:
    folder = tmp_path / "runs"
    folder.mkdir()
    for path in runs_dir().glob("run_0p8_*"):
        shutil.copy(path, folder)
    scene = folder / "run_0p8_scene.toml"
    text = scene.read_text(encoding="utf-8")
    # tor1 (one shaft, unequal split) has an NRMSE of about 0.015: a threshold of 0.001 fails
    text, count = re.subn(r'(name = "tor1"\n(?:.*\n)*?thresholds = \{)',
                          r'\1 "nrmse" = "<= 0.001",', text, count=1)
    assert count == 1
    scene.write_text(text, encoding="utf-8")
    monkeypatch.setattr("rigval.sample_data.shipped_runs", lambda: [scene])
    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out), "--workers", "1"]) == EXIT_FAILED
    assert SUMMARY_PAGE == "index.html"
    page = (out / "index.html").read_text(encoding="utf-8")
    assert '<p class="ok">ASME V&amp;V 20: model error detected' in page  # not detected: ok
    assert '<p class="bad">Result: FAILED</p>' in page
    assert '<a href="run_0p8/report.html">run_0p8</a>' in page
    assert re.search(r"missed tor1 nrmse 0\.0\d+ \(needs &lt;= 0\.001\)", page)  # why
    assert (out / "campaign.json").is_file() and (out / "campaign_metrics.csv").is_file()
