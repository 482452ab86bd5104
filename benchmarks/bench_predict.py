"""Sweep speed: time per sweep point against one full model solve per point.

Sweeps the reference pendulum over main-drive frequency x lifting-drive phase (10 x 10 = 100
points by default) and compares with solving the full model (every output) once per point, and
with predict() per point. Also prints the largest relative difference between the sweep's
summaries and those of full predictions at a few points (the sweep's superposition is exact).

Run: python benchmarks/bench_predict.py [--grid 10] [--points 180] [--repeat 3]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from rigval.model import solve
from rigval.model.predict import make_excitation, predict, resolve_mechanism, sweep


def best_of(repeat: int, func) -> tuple[float, object]:
    best, result = float("inf"), None
    for _ in range(repeat):
        start = time.perf_counter()
        result = func()
        best = min(best, time.perf_counter() - start)
    return best, result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grid", type=int, default=10, help="values per parameter")
    parser.add_argument("--points", type=int, default=180, help="angles per cycle")
    parser.add_argument("--repeat", type=int, default=3, help="repetitions (best is kept)")
    args = parser.parse_args()
    mechanism = resolve_mechanism("builtin:pendulum")
    frequencies = np.linspace(0.5, 1.5, args.grid)
    phases = np.linspace(0.0, 2 * np.pi, args.grid, endpoint=False)
    n = args.grid * args.grid
    solve(mechanism, np.linspace(0.0, 1.0, 16))  # warm up caches and imports

    sweep_time, result = best_of(args.repeat, lambda: sweep(
        mechanism, {"frequency": frequencies, "theta_H.phase": phases}, n_points=args.points))

    def full_solves() -> None:
        for f in frequencies:
            for p in phases:
                excitation = predict_excitation(mechanism, f, p)
                _, t = excitation.cycle_times(args.points)
                values = excitation.evaluate(t)
                solve(mechanism, t, drives={d.name: values[d.name] for d in mechanism.drivers})

    solve_time, _ = best_of(args.repeat, full_solves)

    def predictions() -> None:
        for f in frequencies:
            for p in phases:
                predict(mechanism, predict_excitation(mechanism, f, p), n_points=args.points)

    predict_time, _ = best_of(1, predictions)
    worst = 0.0
    for f, p in ((frequencies[0], phases[3]), (frequencies[-1], phases[-1])):
        direct = predict(mechanism, predict_excitation(mechanism, f, p), n_points=args.points)
        point = result.sel(frequency=f, **{"theta_H.phase": p})
        for name in ("torque_peak", "torque_rms", "tip_acceleration_peak"):
            worst = max(worst, float(np.max(np.abs(point[name] / direct[name] - 1))))
    print(f"pendulum, {args.grid} x {args.grid} = {n} points (frequency x lifting phase), "
          f"{args.points} angles per cycle, best of {args.repeat}")
    print(f"{'method':<44}{'total [s]':>11}{'per point [ms]':>16}")
    print(f"{'sweep (' + str(result.attrs['model_solves']) + ' model solves)':<44}"
          f"{sweep_time:>11.3f}{1e3 * sweep_time / n:>16.2f}")
    print(f"{'full solve per point (all outputs)':<44}{solve_time:>11.3f}"
          f"{1e3 * solve_time / n:>16.2f}")
    print(f"{'predict() per point (report quantities)':<44}{predict_time:>11.3f}"
          f"{1e3 * predict_time / n:>16.2f}")
    print(f"speed-up of the sweep over a full solve per point: {solve_time / sweep_time:.1f}x; "
          f"largest relative difference of summaries: {worst:.1e}")


def predict_excitation(mechanism, frequency: float, phase: float):
    """Return the file's excitation at ``frequency`` (Hz) with the lifting drive shifted."""
    return make_excitation(mechanism, [f"theta_F={{frequency = {float(frequency)!r}}}",
                                       f"theta_H={{phase = {float(phase)!r}}}"])


if __name__ == "__main__":
    main()
