"""The run's entry point: validate a scene and write its report folder (:func:`validate_scene`).

:func:`rigval.validation.pipeline.run_scene` validates in memory and returns a result that holds
everything the report needs; :func:`validate_scene` adds why the model disagrees
(:func:`rigval.validation.diagnosis.explain.attach_diagnosis`: the diagnosis package reads the
pipeline's results, so the pipeline does not call it) and writes the folder from that result alone
(:func:`rigval.validation.report.run_report.write_report`) and returns the result with the files
written. Two drawers are forked first (:func:`rigval.validation.report.drawing.standby_drawers`;
``rigval validate`` forks them before it imports this module): the first imports matplotlib
while this process imports and runs the pipeline and forks the second from itself; they draw
the mechanism's sketch as soon as it is assembled, before the data are read
(:func:`~rigval.validation.report.run_report.start_sketch`), the figures of the alignment and
the model as soon as the model is solved
(:func:`~rigval.validation.report.run_report.start_model_figures`), while the pipeline makes the
comparisons, then the comparisons' figures while this process diagnoses and writes the data
files, so this process never imports matplotlib. As they keep the other core busy, this process
runs one BLAS thread throughout: a second would only wait for them (its idle spinning cost about
0.5 s of CPU beside them). The pipeline itself never imports the report package
(docs/architecture.md).
"""

from __future__ import annotations

import contextlib
import dataclasses
from pathlib import Path

from rigval.acquisition.heap import release_free_heap
from rigval.acquisition.threads import single_blas_thread
from rigval.validation.diagnosis.explain import attach_diagnosis
from rigval.validation.pipeline import run_scene
from rigval.validation.report.drawing import Drawers, standby_drawers
from rigval.validation.report.run_report import (
    start_figures,
    start_model_figures,
    start_sketch,
    write_report,
)
from rigval.validation.results import ValidationResult

__all__ = ["validate_scene"]


def validate_scene(scene_path: str | Path, out_dir: str | Path,
                   drawers: Drawers | None = None) -> ValidationResult:
    """Validate a scene and write its report folder.

    Parameters
    ----------
    scene_path : str or pathlib.Path
        The scene file.
    out_dir : str or pathlib.Path
        The report folder (created; files in it are overwritten).
    drawers : rigval.validation.report.drawing.Drawers, optional
        Drawers forked earlier (``rigval validate`` forks them before it imports this
        module); default: forked now, and ended on return.

    Returns
    -------
    ValidationResult
        With ``passed``, ``metric_rows()``, ``outputs`` (files written), ``inputs`` (files read),
        ``speed_rev_s`` and ``diagnosis``.
    """
    forked = standby_drawers() if drawers is None else contextlib.nullcontext(drawers)
    with forked as drawers, single_blas_thread():
        result = run_scene(scene_path,
                           after_assembly=lambda assembly: start_sketch(assembly, drawers),
                           after_model=lambda run: start_model_figures(run, drawers))
        release_free_heap()  # the pipeline's freed memory, before the diagnosis's large arrays
        figures = start_figures(result, drawers)  # no figure but the Why's shows the diagnosis
        result = attach_diagnosis(result)
        outputs = write_report(result, out_dir, figures)
    return dataclasses.replace(result, outputs=tuple(outputs))
