"""The predict report as a browser shows it (headless Chromium): every figure decodes, the
mechanism sketch is on the page, no two figures overlap, and the 110-row sweep table is folded
until opened."""

from __future__ import annotations

import itertools
import subprocess
import sys
from pathlib import Path

import pytest

PROBE = """<script>window.addEventListener('load',()=>{
const imgs=[...document.images].map(i=>{const r=i.getBoundingClientRect();
  return {alt:i.alt,w:i.complete&&i.naturalWidth,top:r.top,bottom:r.bottom,left:r.left,
          right:r.right};});
const details=[...document.querySelectorAll('details')].map(d=>({open:d.open,
  summary:d.querySelector('summary').textContent,
  rowsShown:[...d.querySelectorAll('tbody tr')].filter(t=>t.checkVisibility()).length,
  rows:d.querySelectorAll('tbody tr').length}));
const p=document.createElement('pre');p.id='probe';
p.textContent=JSON.stringify({imgs,details,width:document.documentElement.scrollWidth,
  viewport:window.innerWidth});document.body.appendChild(p);});</script>"""


@pytest.mark.browser
def test_predict_page_in_chromium(tmp_path: Path, chromium_probe) -> None:
    out = tmp_path / "report"
    subprocess.run([sys.executable, "-m", "rigval.validation.cli", "predict", "builtin:pendulum",
                    "--out", str(out), "--points", "72", "--sweep-points", "24",
                    "--sweep", "theta_H.phase=0:324:10deg", "--sweep", "frequency=0.5:1.5:11",
                    "--summary", "torque_peak", "-q"], check=True, timeout=600)
    seen = chromium_probe(out / "report.html", PROBE, tmp_path, "--window-size=1280,900")
    images = seen["imgs"]
    assert images and all(isinstance(i["w"], int) and i["w"] > 0 for i in images), images
    assert any(i["alt"].startswith("the mechanism at t = 0") for i in images)
    for a, b in itertools.pairwise(images):  # stacked, never drawn over each other
        assert b["top"] >= a["bottom"] - 0.5, (a["alt"], b["alt"])
    assert all(i["right"] <= seen["viewport"] + 0.5 for i in images)  # no figure runs off
    sweep = [d for d in seen["details"] if d["summary"].startswith("sweep summaries")]
    assert len(sweep) == 1 and sweep[0]["rows"] == 110
    assert not sweep[0]["open"] and sweep[0]["rowsShown"] == 0  # folded until opened
