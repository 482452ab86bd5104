"""docs/architecture.md matches the code: the run's path names files that exist, in the order of
the pipeline's stages, and no module of the packages is over 800 lines (issue 29)."""

from __future__ import annotations

import inspect
import re
from pathlib import Path

from rigval.validation import pipeline
from rigval.validation.pipeline import STAGES

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("acquisition", "processing", "model", "sample_data", "validation")
MAX_LINES = 800


def _run_path_rows() -> list[tuple[str, list[str]]]:
    text = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    section = text.split("## The run's path", 1)[1].split("\n## ", 1)[0]
    rows = []
    for line in section.splitlines():
        cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
        if len(cells) == 3 and cells[0] not in ("step", "---"):
            rows.append((cells[0], re.findall(r"`([\w/]+\.py)`", cells[2])))
    return rows


def test_every_file_of_the_run_path_exists() -> None:
    rows = _run_path_rows()
    assert len(rows) >= len(STAGES) + 4
    for step, files in rows:
        assert files, f"{step}: no file named"
        missing = [name for name in files if not (ROOT / name).is_file()]
        assert not missing, f"{step}: {missing} do not exist"


def test_the_run_path_lists_the_pipeline_stages_in_order() -> None:
    listed = [step.removeprefix("stage ") for step, _ in _run_path_rows()
              if step.startswith("stage ")]
    assert listed == list(STAGES)
    # run_scene and run_scene_kept both run the stages of pipeline._run
    timed = re.findall(r'watch\.stage\("(\w+)"\)', inspect.getsource(pipeline._run))
    assert list(dict.fromkeys(timed)) == list(STAGES)


def test_no_module_of_the_packages_is_over_800_lines() -> None:
    long = {str(path.relative_to(ROOT)): n for package in PACKAGES
            for path in (ROOT / package).rglob("*.py")
            if (n := len(path.read_text(encoding="utf-8").splitlines())) > MAX_LINES}
    assert not long, f"modules over {MAX_LINES} lines: {long}"
