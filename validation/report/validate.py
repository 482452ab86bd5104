"""One validation with its report folder: :func:`validate_scene`.

:func:`rigval.validation.pipeline.run_scene` validates in memory; this module adds the writing of
the run folder (:func:`rigval.validation.report.run_report.write_report`), so that the pipeline
never imports the report package (docs/architecture.md).
"""

from __future__ import annotations

from pathlib import Path

from rigval.validation.pipeline import run_scene
from rigval.validation.report.run_report import write_report
from rigval.validation.results import ValidationResult

__all__ = ["validate_scene"]


def validate_scene(scene_path: str | Path, out_dir: str | Path) -> ValidationResult:
    """Validate a scene and write its report folder.

    Parameters
    ----------
    scene_path : str or pathlib.Path
        The scene file.
    out_dir : str or pathlib.Path
        The report folder (created; files in it are overwritten).

    Returns
    -------
    ValidationResult
        With ``passed``, ``metric_rows()``, ``outputs`` (files written), ``inputs`` (files read)
        and ``speed_rev_s``.
    """
    result = run_scene(scene_path)
    write_report(result, out_dir)
    return result
