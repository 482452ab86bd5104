"""Processing: raw channels to physical, aligned and angle-domain signals.

Modules, one job each (numpy functions with explicit SI parameters, plus Dataset-level functions
that keep the channel metadata and append a ``history`` line):

- :mod:`~rigval.processing.bridge`, :mod:`~rigval.processing.torsion`,
  :mod:`~rigval.processing.stress`, :mod:`~rigval.processing.accelerometer`: NI's bridge
  equations, rosette torque, stress, the charge chain, and their exact forward models;
- :mod:`~rigval.processing.transducers`: linear scales, IEPE accelerometers, load cells;
- :mod:`~rigval.processing.encoder`: counts to angle, quadrature decoding, revolution checks;
- :mod:`~rigval.processing.conversions`: the Dataset-level sensor conversions;
  :mod:`~rigval.processing.sensors`: a stream's channel map applied with them;
- :mod:`~rigval.processing.pulses`: reference edges, missing and spurious pulses;
- :mod:`~rigval.processing.clock_fit`: the clock fit of one device (its clock model) and its
  aligned stream;
  :mod:`~rigval.processing.event_match`: device events paired with reference events, strays;
- :mod:`~rigval.processing.stamps`: start stamps to a coarse offset and its window, clock groups;
- :mod:`~rigval.processing.stream_alignment`: the orchestration, every stream of a set on the
  reference timeline, from plain settings; :mod:`~rigval.processing.alignment_summary`: its
  per-stream diagnostics;
- :mod:`~rigval.processing.timeline`: all aligned streams on one uniform time grid;
- :mod:`~rigval.processing.selection`: which channels of aligned streams the timeline and the
  angle domain use;
- :mod:`~rigval.processing.arrays`: the array types of the numpy functions;
- :mod:`~rigval.processing.angle`: phi_F, cycles, angle-domain resampling;
- :mod:`~rigval.processing.cycles`: cycle statistics and outlier cycles;
- :mod:`~rigval.processing.excitation`: drive angles and their derivatives with an error estimate;
- :mod:`~rigval.processing.filters`: zero-phase filtering by gap-free run, in chunks;
- :mod:`~rigval.processing.dtw`: dynamic time warping of many equally long signal pairs at once;
- :mod:`~rigval.processing.scipy_signal`: the scipy.signal functions rigval uses, imported
  without scipy.stats (every module takes them from there).

``docs/processing.md`` lists the pipeline calls in order and the accuracy measured.
"""

from rigval.acquisition.lazy import lazy_exports

#: The public modules, each imported on first use (``rigval.processing.clock_fit``).
_LAZY = {name: name for name in (
    "accelerometer", "angle", "bridge", "clock_fit", "conversions", "cycles", "dtw", "encoder",
    "errors", "excitation", "filters", "pulses", "sensors", "stamps", "stream_alignment",
    "stress", "timeline", "torsion", "transducers")}

__all__ = ["accelerometer", "angle", "bridge", "clock_fit", "conversions", "cycles", "dtw",
           "encoder", "errors", "excitation", "filters", "pulses", "sensors", "stamps",
           "stream_alignment", "stress", "timeline", "torsion", "transducers"]

__getattr__, __dir__ = lazy_exports(__name__, _LAZY, globals())
