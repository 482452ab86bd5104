"""Sample data: a virtual test rig and the sample runs it writes.

The rig reproduces the set-up of docs/references.md ([paper] section 4.1): the model along a
true drive motion, sensor models, devices with their own clocks, and the files the devices write
(NI-DAQmx TDMS, a European LabVIEW CSV), with the truth and a scene that validates the run. See
``sample_data/README.md``.

Public API
----------
simulate_rig(out_dir, settings=None, *, truth=None) -> RunFiles
    Write one run folder.
RigSettings(speed, duration, seed, imperfections, mechanism, truth_fs, preroll, index_reset,
            faults)
    One run; ``Imperfections`` sets the imperfection levels (``Imperfections.none()``: ideal);
    ``faults`` a tuple of ``Fault`` (injected sensor faults, ``sample_data/faults.py``).
load_truth(path, *, signals=True) -> RunTruth
    The truth of a run, true signals as one Dataset per stream (``signals=False``: parameters,
    clocks and drive law only).
shipped_runs() -> list of Path
    Scenes of the runs shipped with rigval.
"""

from pathlib import Path

from rigval.acquisition.lazy import lazy_exports

#: The rig's names, imported on first use (numpy, xarray and the model), so that ``runs_dir``
#: stays light.
_LAZY = {"Fault": "faults", "Imperfections": "rig", "RigSettings": "rig", "run_stem": "rig",
         "RunFiles": "rig", "simulate_rig": "simulate", "RunTruth": "truthfile",
         "load_truth": "truthfile"}

__all__ = ["Fault", "Imperfections", "RigSettings", "RunFiles", "RunTruth", "load_truth",
           "run_stem", "runs_dir", "shipped_runs", "simulate_rig"]

__getattr__, __dir__ = lazy_exports(__name__, _LAZY, globals())


def runs_dir() -> Path:
    """Return the folder of the shipped sample runs (``sample_data/runs``)."""
    return Path(__file__).resolve().parent / "runs"


def shipped_runs() -> list[Path]:
    """Return the scene files of the shipped sample runs, sorted by name."""
    return sorted(runs_dir().glob("*_scene.toml"))
