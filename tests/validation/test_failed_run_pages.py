"""The pages of a failing run: its report as a browser shows it, and the demo's summary page.

``rigval demo`` validates the shipped 0.8 rev/s run with thresholds its torque comparisons miss.
The run's report in headless Chromium at 1024 and 1400 px wide: the verdict and the reason for
every failed threshold are readable without scrolling sideways (no table hides them behind its
scroll bar), no table of the Summary or the Alignment section scrolls, and the facts under the
verdict break lines between words, not inside them. The demo writes the campaign's summary page
(one page, one name: ``index.html``): the V&V 20 verdict and the result as banners, each run
linking its report, why the run failed.
"""

from __future__ import annotations

import html
import re
import shutil
from pathlib import Path

import pytest

from rigval.sample_data import runs_dir
from rigval.validation.campaign.report import SUMMARY_PAGE
from rigval.validation.cli import EXIT_FAILED, main

PROBE = """<script>window.addEventListener('load',()=>{
const box=e=>{const r=e.getBoundingClientRect();return {left:r.left,right:r.right,
  top:r.top,bottom:r.bottom,text:e.textContent};};
const clipped=e=>{for(let p=e.parentElement;p;p=p.parentElement){const s=getComputedStyle(p);
  if(s.overflowX!=='visible'){const r=p.getBoundingClientRect(),b=e.getBoundingClientRect();
    if(b.right>r.right+0.5||b.left<r.left-0.5)return true;}}return false;};
const result=[...document.querySelectorAll('p')].find(p=>p.textContent.startsWith('Result:'));
const failures=[...document.querySelectorAll('ul.failures li')].map(li=>
  ({...box(li),clipped:clipped(li)}));
const scrolls=[...document.querySelectorAll('div.scroll')].map(d=>({
  caption:(d.querySelector('caption')||{}).textContent||'',
  overflow:d.scrollWidth-d.clientWidth}));
const broken=[];
for(const dd of document.querySelectorAll('dd')){
  const node=dd.firstChild; if(!node||node.nodeType!==3)continue;
  const re=/\\S+/g; let m;
  while((m=re.exec(node.data))){
    if(m[0].length>30)continue;  // a hash or a path longer than the column may break
    const range=document.createRange(); range.setStart(node,m.index);
    range.setEnd(node,m.index+m[0].length);
    const tops=new Set([...range.getClientRects()].map(r=>Math.round(r.top)));
    if(tops.size>1)broken.push(m[0]);}}
const p=document.createElement('pre');p.id='probe';
p.textContent=JSON.stringify({result:box(result),failures,scrolls,broken,
  pageWidth:document.documentElement.scrollWidth,viewport:window.innerWidth,
  height:window.innerHeight});
document.body.appendChild(p);});</script>"""

#: Thresholds no torque comparison of the shipped run meets (its NRMSE is 1e-4 to 2e-2).
TIGHT = '"nrmse" = "<= 0.0001", "iso18571_periodic.rating" = ">= 0.8"'


@pytest.fixture(scope="module")
def failing_demo(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``rigval demo``'s folder, the shipped 0.8 rev/s run with thresholds its torques fail."""
    folder = tmp_path_factory.mktemp("failing")
    for path in runs_dir().glob("run_0p8_*"):
        shutil.copy(path, folder)
    scene = folder / "run_0p8_scene.toml"
    text = scene.read_text(encoding="utf-8")
    loose = '"iso18571_periodic.rating" = ">= 0.8", "vv20.curve.normalised_error" = "<= 2"'
    assert text.count(loose) == 6  # tor1-tor4, torque_F, torque_H
    scene.write_text(text.replace(loose, TIGHT), encoding="utf-8")
    out = folder / "demo"
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr("rigval.sample_data.shipped_runs", lambda: [scene])
        assert main(["demo", "--out", str(out), "--workers", "1", "-q"]) == EXIT_FAILED
    return out


def test_demo_summary_is_the_campaign_page(failing_demo: Path) -> None:
    assert SUMMARY_PAGE == "index.html"
    page = (failing_demo / "index.html").read_text(encoding="utf-8")
    assert '<p class="ok">ASME V&amp;V 20: model error detected' in page  # not detected: ok
    assert '<p class="bad">Result: FAILED</p>' in page
    assert '<a href="run_0p8/report.html">run_0p8</a>' in page
    # why, in the run's row: the first three misses (tor1's NRMSE is about 0.015), then a count
    assert re.search(r"missed tor1 nrmse 0\.0\d+ \(needs &lt;= 0\.0001\);.*; and \d+ more",
                     page)
    assert (failing_demo / "campaign.json").is_file()
    assert (failing_demo / "campaign_metrics.csv").is_file()


@pytest.mark.browser
@pytest.mark.parametrize("width", [1024, 1400])
def test_failed_report_shows_why_without_scrolling(failing_demo: Path, tmp_path: Path,
                                                   chromium_probe, width: int) -> None:
    report = failing_demo / "run_0p8" / "report.html"
    seen = chromium_probe(report, PROBE, tmp_path, f"--window-size={width},900")
    viewport = seen["viewport"]
    assert seen["result"]["text"] == "Result: FAILED"
    assert seen["result"]["left"] >= 0 and seen["result"]["right"] <= viewport + 0.5
    failures = seen["failures"]
    assert [f["text"].split(":")[0] for f in failures] == ["tor1", "tor2", "tor3", "tor4",
                                                          "torque_F", "torque_H"]
    for failure in failures:  # the DOM dump keeps "<" escaped
        assert "nrmse" in failure["text"] and "(needs <= 0.0001)" in html.unescape(
            failure["text"])
        assert failure["right"] <= viewport + 0.5 and not failure["clipped"], failure
    assert seen["pageWidth"] <= viewport  # the page itself never scrolls sideways
    # the verdict and the first reason are on the first screen, without scrolling down either
    assert seen["result"]["bottom"] <= seen["height"] and failures[0]["bottom"] <= seen["height"]
    summary_and_alignment = [s for s in seen["scrolls"] if s["caption"] in (
        "comparisons", "reference pulses and segments per stream")
        or s["caption"].startswith("clock model per stream")]
    assert len(summary_and_alignment) == 3
    assert all(s["overflow"] <= 0 for s in summary_and_alignment), summary_and_alignment
    assert not seen["broken"], f"words broken inside: {seen['broken']}"
