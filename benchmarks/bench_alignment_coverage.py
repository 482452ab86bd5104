"""Coverage of the clock fit's 95 % intervals over simulated pulse-time sequences.

Prints, per kind of run (exactly periodic or wandering drive, digital or analog edges, 6 to 400
pulses), how often the true offset and drift lie within the reported 95 % intervals, and the
median ratio of the interval's half-width to the true error. The runs are those of
``tests/validation/test_alignment_coverage.py`` (which asserts >= 93 % on 200 of them).

Usage: ``python benchmarks/bench_alignment_coverage.py [RUNS] [SEED...]`` (default 1000 runs,
seeds 1 2 3).
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np

from rigval.processing.clock_fit import estimate_clock

_TEST = Path(__file__).resolve().parents[1] / "tests" / "validation" / "test_alignment_coverage.py"


def _simulator():
    spec = importlib.util.spec_from_file_location("alignment_coverage", _TEST)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up
    assert spec.loader is not None
    spec.loader.exec_module(module)
    return module


def main(argv: list[str]) -> None:
    runs = int(argv[0]) if argv else 1000
    seeds = [int(s) for s in argv[1:]] or [1, 2, 3]
    sim = _simulator()
    print(f"{'seed':>4} {'kind':<18} {'runs':>5} {'offset cov':>10} {'drift cov':>9} "
          f"{'u95/err offset':>14} {'u95/err drift':>13}")
    for seed in seeds:
        table: dict[str, list[tuple[bool, bool, float, float]]] = {}
        for run in sim.pulse_runs(runs, seed=seed):
            clock = estimate_clock(run.ref, run.dev, coarse_offset_s=run.coarse_s,
                                   max_offset_error_s=sim.STAMP_WINDOW_S,
                                   timing_bound_s=run.bound_s)
            e_off = abs(clock.offsets_s[0] - run.offset_s)
            e_drift = abs(clock.drift - run.drift)
            kind = " ".join(run.label.split()[:2])
            table.setdefault(kind, []).append(
                (e_off <= clock.offsets_u95_s[0], e_drift <= clock.drift_u95,
                 clock.offsets_u95_s[0] / max(e_off, 1e-15), clock.drift_u95 / max(e_drift, 1e-18)))
        rows = [*table.items(), ("all", [r for rows in table.values() for r in rows])]
        for kind, cases in rows:
            data = np.array(cases)
            print(f"{seed:>4} {kind:<18} {len(cases):>5} {data[:, 0].mean():>10.3f} "
                  f"{data[:, 1].mean():>9.3f} {np.median(data[:, 2]):>14.1f} "
                  f"{np.median(data[:, 3]):>13.1f}")


if __name__ == "__main__":
    main(sys.argv[1:])
