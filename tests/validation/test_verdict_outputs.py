"""The V&V 20 verdict heads the report, metrics.json, the console summary and the campaign page."""

import io
import json
import re

import pytest

from rigval.sample_data import runs_dir
from rigval.validation.campaign import engine as campaign
from rigval.validation.campaign.report import write_campaign_report
from rigval.validation.commands.validate import print_summary
from rigval.validation.pipeline import run_scene
from rigval.validation.report.run_report import write_report
from rigval.validation.verdict import run_verdict


@pytest.fixture(scope="module")
def sample():
    return run_scene(runs_dir() / "run_0p8_scene.toml")


def test_verdict_first_everywhere(sample, tmp_path):
    verdict = run_verdict(sample)
    assert not verdict["detected"]
    rows = {row["comparison"]: row for row in verdict["comparisons"]}
    for name, row in rows.items():
        # the parts are the RMS of independent pointwise parts: u_val^2 = sum of squares
        assert row["u_val"] == pytest.approx(sum(v**2 for v in row["parts"].values()) ** 0.5,
                                             rel=1e-12), name
        # the larger of the curve's and (torque_F, torque_H) the common gain's |E|/(k u_val)
        gain = row["common_gain"]
        assert (gain is not None) == (name in ("torque_F", "torque_H")), name
        curve = row["E"] / (2.0 * row["u_val"])
        assert row["ratio"] == pytest.approx(max(curve, gain["ratio"] if gain else 0.0),
                                             rel=1e-12)
    assert verdict["worst"] == max(rows, key=lambda n: rows[n]["ratio"])

    write_report(sample, tmp_path)
    document = json.loads((tmp_path / "metrics.json").read_text())
    assert next(iter(document)) == "verdict"
    assert document["verdict"]["statement"] == verdict["statement"]
    html = (tmp_path / "report.html").read_text(encoding="utf-8")
    summary = html[html.index(">Summary<"):]
    first = re.sub(r"<[^>]+>", "", summary[summary.index("<p"):summary.index("</p>")])
    assert first.startswith("ASME V&amp;V 20: Model error not detected (|E| &lt;= k u_val)")

    text = io.StringIO()
    print_summary(sample, tmp_path, text)
    assert text.getvalue().splitlines()[0] == verdict["statement"]

    outcome = campaign.RunOutcome(name="run_0p8", scene=sample.scene.path, run_dir=tmp_path,
                                  status="passed", metrics=tuple(sample.metric_rows()),
                                  speed_rev_s=sample.speed_rev_s)
    files = write_campaign_report([outcome], tmp_path / "campaign")
    page = files.html.read_text(encoding="utf-8")
    assert "model error detected (|E| &gt; k u_val) in 0 of 1 validated runs" in page


def test_figures_started_before_the_diagnosis_equal_those_drawn_after_it(sample):
    """validate_scene starts the page's figures before the diagnosis (a child draws beside it):
    no figure may show the diagnosis, so both orders give the same SVG texts."""
    from rigval.validation.diagnosis.explain import attach_diagnosis
    from rigval.validation.report.figure_groups import RUN_GROUPS
    from rigval.validation.report.run_report import start_figures

    early = start_figures(sample)
    diagnosed = attach_diagnosis(sample)
    assert diagnosed.diagnosis is not None
    late = start_figures(diagnosed)
    before, after = ([drawn.texts(name) for name in RUN_GROUPS] for drawn in (early, late))
    assert sum(len(group) for group in after) >= 10
    assert before == after
