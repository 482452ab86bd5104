"""A failing run report as a browser shows it (headless Chromium), at 1024 and 1400 px wide.

The verdict and the reason for every failed threshold must be readable without scrolling
sideways (no table hides them behind its scroll bar), no table of the Summary or the Alignment
section scrolls, and the facts under the verdict break lines between words, not inside them.
"""

from __future__ import annotations

import html
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from rigval.sample_data import runs_dir

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
  pageWidth:document.documentElement.scrollWidth,viewport:window.innerWidth});
document.body.appendChild(p);});</script>"""

#: Thresholds no torque comparison of the shipped run meets (its NRMSE is 1e-4 to 2e-2).
TIGHT = '"nrmse" = "<= 0.0001", "iso18571_periodic.rating" = ">= 0.8"'


@pytest.fixture(scope="module")
def failing_report(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The report of the shipped 0.8 rev/s run with thresholds its torque comparisons fail."""
    folder = tmp_path_factory.mktemp("failing")
    for path in runs_dir().glob("run_0p8_*"):
        shutil.copy(path, folder)
    scene = folder / "run_0p8_scene.toml"
    text = scene.read_text(encoding="utf-8")
    loose = '"iso18571_periodic.rating" = ">= 0.8", "vv20.curve.normalised_error" = "<= 2"'
    assert text.count(loose) == 6  # tor1-tor4, torque_F, torque_H
    scene.write_text(text.replace(loose, TIGHT), encoding="utf-8")
    done = subprocess.run([sys.executable, "-m", "rigval.validation.cli", "validate", str(scene),
                           "--out", str(folder / "report"), "-q"], timeout=600)
    assert done.returncode == 1  # failed its thresholds
    return folder / "report" / "report.html"


@pytest.mark.browser
@pytest.mark.parametrize("width", [1024, 1400])
def test_failed_report_shows_why_without_scrolling(failing_report: Path, tmp_path: Path,
                                                   chromium_probe, width: int) -> None:
    seen = chromium_probe(failing_report, PROBE, tmp_path, f"--window-size={width},900")
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
    summary_and_alignment = [s for s in seen["scrolls"] if s["caption"] in (
        "comparisons", "reference pulses and segments per stream")
        or s["caption"].startswith("clock model per stream")]
    assert len(summary_and_alignment) == 3
    assert all(s["overflow"] <= 0 for s in summary_and_alignment), summary_and_alignment
    assert not seen["broken"], f"words broken inside: {seen['broken']}"
