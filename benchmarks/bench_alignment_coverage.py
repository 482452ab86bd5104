"""Coverage of the clock fit's 95 % intervals over simulated pulse runs.

Two tables:

1. pulse-time sequences (``tests/validation/test_alignment_coverage.py``: exactly periodic or
   wandering drive, digital or analog edges, 6 to 400 pulses): how often the true offset and
   drift lie within the reported 95 % intervals, and the median ratio of the half-width to the
   true error;
2. sampled pulse signals of every edge class (:mod:`rigval.sample_data.edge_runs`: digital,
   band-limited, first-order rises of 0.05-2 sample periods; 1.6-5 kHz; drive periods near and
   far from a whole number of samples; 6-400 pulses; noise), timed by
   :func:`~rigval.processing.pulses.time_edges`: coverage per edge class, and the half-widths
   over the quantisation limit (:func:`~rigval.processing.clock_fit.quantisation_limit`).

Usage: ``python benchmarks/bench_alignment_coverage.py [RUNS] [SEED...]`` (default 1000 runs,
seeds 1 2 3); ``--signals RUNS [SEED...]`` prints only the second table for RUNS signal runs.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np

from rigval.processing.clock_fit import estimate_clock, quantisation_limit
from rigval.processing.pulses import detect_edges, time_edges
from rigval.sample_data.edge_runs import STAMP_WINDOW_S, EdgeRun, edge_runs

_TEST = Path(__file__).resolve().parents[1] / "tests" / "validation" / "test_alignment_coverage.py"


def _simulator():
    spec = importlib.util.spec_from_file_location("alignment_coverage", _TEST)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up
    assert spec.loader is not None
    spec.loader.exec_module(module)
    return module


def sequences(runs: int, seeds: list[int]) -> None:
    """Print the coverage table of the pulse-time sequences."""
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


def signal_clock(run: EdgeRun) -> tuple[float, float, float, float, float, float, str]:
    """Fit one signal run's clock; return the errors, half-widths, limits and edge shape.

    Returns ``(offset error, offset u95, offset limit, drift error, drift u95, drift limit,
    shape)`` in s and 1.
    """
    crossings = detect_edges(run.x_dev, run.t_dev, refine="sinc", holdoff_s=0.01)
    timing = time_edges(run.x_dev, run.t_dev, crossings, fs=run.fs)
    clock = estimate_clock(run.ref, timing.times, coarse_offset_s=run.coarse_offset_s,
                           max_offset_error_s=STAMP_WINDOW_S, timing_bound_s=timing.bounds_s,
                           min_events=3)
    limit_offset, limit_drift = quantisation_limit(timing.times, run.fs)
    return (clock.offsets_s[0] - run.offset_s, clock.offsets_u95_s[0], limit_offset,
            clock.drift - run.drift, clock.drift_u95, limit_drift, timing.shape)


def signals(runs: int, seeds: list[int]) -> None:
    """Print the coverage table per edge class of the sampled signal runs."""
    print(f"{'seed':>4} {'edge class':<22} {'runs':>5} {'offset cov':>10} {'drift cov':>9} "
          f"{'u95/limit offset (med, max)':>27} {'u95/limit drift (med, max)':>26}  shapes found")
    for seed in seeds:
        table: dict[str, list[tuple[float, ...]]] = {}
        shapes: dict[str, dict[str, int]] = {}
        for run in edge_runs(runs, seed):
            e_off, u_off, q_off, e_drift, u_drift, q_drift, shape = signal_clock(run)
            for kind in (run.edge, f"{run.edge} {'near' if ' near' in run.label else 'far'}"):
                table.setdefault(kind, []).append(
                    (abs(e_off) <= u_off, abs(e_drift) <= u_drift, u_off / q_off,
                     u_drift / q_drift))
            found = shapes.setdefault(run.edge, {})
            found[shape] = found.get(shape, 0) + 1
        rows = [*sorted(table.items()), ("all", [r for k, v in table.items() if " " not in k
                                                 for r in v])]
        for kind, cases in rows:
            data = np.array(cases)
            seen = ", ".join(f"{k} {v}" for k, v in shapes.get(kind, {}).items())
            print(f"{seed:>4} {kind:<22} {len(cases):>5} {data[:, 0].mean():>10.3f} "
                  f"{data[:, 1].mean():>9.3f} {np.median(data[:, 2]):>16.2f} "
                  f"{data[:, 2].max():>10.2f} {np.median(data[:, 3]):>15.2f} "
                  f"{data[:, 3].max():>10.2f}  {seen}")


def main(argv: list[str]) -> None:
    if argv and argv[0] == "--signals":
        signals(int(argv[1]) if len(argv) > 1 else 240, [int(s) for s in argv[2:]] or [1])
        return
    runs = int(argv[0]) if argv else 1000
    seeds = [int(s) for s in argv[1:]] or [1, 2, 3]
    sequences(runs, seeds)
    signals(max(runs // 4, 240), seeds)


if __name__ == "__main__":
    main(sys.argv[1:])
