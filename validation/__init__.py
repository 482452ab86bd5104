"""Validation: compare measurement and model, metrics, pass/fail, reports and the command line.

Entry points (docs/scene.md): :func:`load_scene` reads and checks a scene file,
:func:`validate_scene` runs it (read, convert, align, model, compare) and writes the run folder,
:func:`run_scene` does the same in memory. Subpackages, one job each: ``metrics`` (ISO 18571,
waveform metrics, V&V 20, thresholds), ``report`` (pages and plots), ``campaign`` (many runs),
``bench`` (benchmarks) and ``commands`` (the ``rigval`` subcommands).
"""

from rigval.acquisition.lazy import lazy_exports

#: Public names and their modules, imported on first use so that ``rigval --help`` stays light.
_LAZY = {"Scene": "scene_types", "load_scene": "scene", "SceneError": "errors",
         "read_streams": "read_plan", "run_scene": "pipeline", "validate_scene": "run.validate",
         "ValidationResult": "results"}

__all__ = ["Scene", "SceneError", "ValidationResult", "load_scene", "read_streams", "run_scene",
           "validate_scene"]

__getattr__, __dir__ = lazy_exports(__name__, _LAZY, globals())
