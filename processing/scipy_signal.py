"""The functions of :mod:`scipy.signal` that rigval uses, imported without :mod:`scipy.stats`.

:mod:`scipy.signal` imports :mod:`scipy.stats` as it loads, for the one function
``scoreatpercentile`` (used by ``find_peaks_cwt``, which rigval does not call); loading
:mod:`scipy.stats` and its distributions costs about 0.25 s of every cold command's start, more
than any other import of a run (docs/performance.md), and nothing of rigval's run needs it
(its quantiles come from :mod:`scipy.special`). So this module imports :mod:`scipy.signal`
with a stand-in for :mod:`scipy.stats` in ``sys.modules``: the stand-in hands over a
``scoreatpercentile`` that imports :mod:`scipy.stats` when called, and gives any other name by
importing the real module at once (a later SciPy that needs more of it at import then loses
the saving, never its behaviour). The stand-in is removed right after, so that a later
``import scipy.stats`` anywhere in the process imports the real module; where
:mod:`scipy.signal` or :mod:`scipy.stats` is already imported, nothing is stood in.

rigval's modules import :mod:`scipy.signal`'s functions from here, never :mod:`scipy.signal`
itself, so that whichever of them is imported first imports it this way.
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
import types
from importlib.machinery import ModuleSpec
from typing import Any

__all__ = ["butter", "correlate", "decimate", "lfilter", "lsim", "resample", "savgol_filter",
           "sosfiltfilt", "sosfreqz", "welch"]

_STATS = "scipy.stats"


def _score_at_percentile(*args: Any, **kwargs: Any) -> Any:
    """``scipy.stats.scoreatpercentile``, importing :mod:`scipy.stats` when first called."""
    from scipy.stats import scoreatpercentile

    return scoreatpercentile(*args, **kwargs)


class _StatsStandIn(types.ModuleType):
    """Stands for :mod:`scipy.stats` while :mod:`scipy.signal` is imported (see the module).

    It carries the real package's spec and search path, so that the import system takes it
    for that package (``from scipy.stats import name`` asks whether it is one).
    """

    def __init__(self, spec: ModuleSpec) -> None:
        super().__init__(spec.name)
        self.__spec__ = spec
        self.__path__ = list(spec.submodule_search_locations or ())

    def __getattr__(self, name: str) -> Any:
        if name == "scoreatpercentile":
            return _score_at_percentile
        if sys.modules.get(_STATS) is self:  # anything else: the real module, from now on
            del sys.modules[_STATS]
        return getattr(importlib.import_module(_STATS), name)


def _import_signal() -> types.ModuleType:
    """Import :mod:`scipy.signal` with :mod:`scipy.stats` stood in for (see the module)."""
    if "scipy.signal" in sys.modules or _STATS in sys.modules:
        return importlib.import_module("scipy.signal")
    spec = importlib.util.find_spec(_STATS)
    if spec is None:  # a SciPy without it: scipy.signal's import says what is missing
        return importlib.import_module("scipy.signal")
    stand_in = _StatsStandIn(spec)
    sys.modules[_STATS] = stand_in
    try:
        return importlib.import_module("scipy.signal")
    finally:
        if sys.modules.get(_STATS) is stand_in:
            del sys.modules[_STATS]


_signal = _import_signal()
butter = _signal.butter
correlate = _signal.correlate
decimate = _signal.decimate
lfilter = _signal.lfilter
lsim = _signal.lsim
resample = _signal.resample
savgol_filter = _signal.savgol_filter
sosfiltfilt = _signal.sosfiltfilt
sosfreqz = _signal.sosfreqz
welch = _signal.welch
