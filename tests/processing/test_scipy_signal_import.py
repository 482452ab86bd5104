"""scipy.signal imported without scipy.stats behaves as scipy.signal imported plainly.

Each case runs in a new interpreter (an import is once per process): what rigval's import left
in ``sys.modules``, and ``scipy.signal``'s one use of ``scipy.stats`` (``find_peaks_cwt``'s
noise floor, ``scoreatpercentile``) against the same call in an interpreter that imported
scipy.signal the ordinary way.
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
import scipy.stats

from rigval.processing.clock_fit import student_t_975

PEAKS = """
import json, sys
import numpy as np
{first}
import scipy.signal
stats_before = "scipy.stats" in sys.modules
x = np.arange(1000.0)
y = sum(np.exp(-0.5 * ((x - c) / 12.0) ** 2) for c in (150.0, 420.0, 700.0))
y += 0.02 * np.random.default_rng(1).standard_normal(x.size)
peaks = scipy.signal.find_peaks_cwt(y, np.arange(5, 30))
import scipy.stats
print(json.dumps({{"stats_before": stats_before, "peaks": [int(p) for p in peaks],
                  "real": hasattr(scipy.stats, "norm") and "scipy.stats" in sys.modules,
                  "score": float(scipy.signal._peak_finding.scoreatpercentile(y, 10.0)),
                  "expected": float(scipy.stats.scoreatpercentile(y, 10.0))}}))
"""


def _run(first: str) -> dict:
    code = PEAKS.format(first=first)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_rigvals_import_leaves_no_stats_and_the_same_peaks():
    plain = _run("")
    ours = _run("import rigval.processing.scipy_signal")
    assert plain["stats_before"] is True   # scipy.signal alone loads scipy.stats ...
    assert ours["stats_before"] is False   # ... rigval's import of it does not
    assert ours["real"]                    # a later import gives the real module
    assert ours["peaks"] == plain["peaks"] and len(plain["peaks"]) > 2
    assert ours["score"] == ours["expected"] == plain["score"]


def test_nothing_is_stood_in_when_scipy_stats_is_already_there():
    code = ("import sys, scipy.stats, rigval.processing.scipy_signal, scipy.signal\n"
            "print(scipy.signal._peak_finding.scoreatpercentile is "
            "scipy.stats.scoreatpercentile)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, check=True)
    assert done.stdout.strip() == "True"


@pytest.mark.parametrize("dof", [1, 2, 3, 4.5, 14, 29, 100, 1e4, np.inf])
def test_the_clock_fits_t_quantile_is_scipy_stats(dof):
    assert student_t_975(dof) == float(scipy.stats.t.ppf(0.975, dof))
