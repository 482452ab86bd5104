"""Speed against error of rigval.model: full inverse dynamics of pendulum.toml.

Run: python benchmarks/bench_model.py [--steps 100000] [--baseline-steps 2000] [--repeats 3]

Prints, on one core (BLAS threads pinned to 1):
1. the batched solver on all steps (20 s at 5 kHz): steps per second, wall and CPU time;
2. the plain step-by-step full-coordinate solve (rigval.model.solve_stepwise) on every k-th step
   (spread over the whole run) as the baseline, and the batched solver's errors against it;
3. Newton tolerance against speed and error;
4. evaluation points per cycle (solve_cycle + periodic cubic interpolation to every sample's main
   drive angle) against speed and torque error.
Timings are the best of the repeats (the machine is shared); a calibration line (a numpy batched
solve) shows how loaded the machine was.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

import rigval.model as rm  # noqa: E402

FULL = ["position", "velocity", "acceleration", "joint_force", "driver_torque"]
FS = 5000.0


def timed(func, repeats):
    best_wall, best_cpu, result = np.inf, np.inf, None
    for _ in range(repeats):
        wall, cpu = time.perf_counter(), time.process_time()
        result = func()
        best_wall = min(best_wall, time.perf_counter() - wall)
        best_cpu = min(best_cpu, time.process_time() - cpu)
    return result, best_wall, best_cpu


def rel_error(value, reference):
    value, reference = np.asarray(value), np.asarray(reference)
    return float(np.max(np.abs(value - reference)) / np.max(np.abs(reference)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=100_000)
    parser.add_argument("--baseline-steps", type=int, default=2_000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    mech = rm.load_mechanism(rm.builtin_mechanism("pendulum"))
    t = np.arange(args.steps) / FS
    print(f"pendulum.toml, {args.steps} steps at {FS:g} Hz, load average "
          f"{os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    stack = np.random.default_rng(0).standard_normal((100_000, 6, 6)) + 3 * np.eye(6)
    rhs = np.ones((100_000, 6, 1))
    _r, calib, _c = timed(lambda: np.linalg.solve(stack, rhs), args.repeats)
    print(f"machine state: numpy solve of 100,000 6x6 systems took {1e3 * calib:.0f} ms "
          "(47 ms on this machine when idle)\n")

    rm.solve(mech, t[:2000], outputs=FULL)  # warm up
    fast, wall, cpu = timed(lambda: rm.solve(mech, t, outputs=FULL), args.repeats)
    stride = max(1, args.steps // args.baseline_steps)
    picked = slice(0, None, stride)  # spread over the whole run
    n_base = t[picked].size
    base, base_wall, base_cpu = timed(lambda: rm.solve_stepwise(mech, t[picked]), 1)
    print("1-2. batched solver against the plain step-by-step solve")
    print(f"{'solver':28s} {'steps':>8s} {'wall s':>8s} {'cpu s':>8s} {'steps/s (cpu)':>14s}")
    print(f"{'batched (rigval.model.solve)':28s} {args.steps:8d} {wall:8.3f} {cpu:8.3f} "
          f"{args.steps / cpu:14,.0f}")
    print(f"{'step-by-step (solve_stepwise)':28s} {n_base:8d} {base_wall:8.3f} {base_cpu:8.3f} "
          f"{n_base / base_cpu:14,.0f}")
    head = fast.isel(time=picked)
    for name in ("position", "acceleration", "joint_force", "driver_torque"):
        print(f"   max error of {name:14s} relative to its peak: "
              f"{rel_error(head[name], base[name]):.2e}")

    print("\n3. Newton tolerance: speed and error (forces against the step-by-step solve)")
    print(f"{'tol':>8s} {'cpu s':>8s} {'steps/s':>12s} {'joint_force':>12s} {'torque':>12s}")
    for tol in (1e-4, 1e-6, 1e-8, 1e-10, 1e-12, 1e-14):
        result, _w, c = timed(lambda tol=tol: rm.solve(mech, t, outputs=FULL, tol=tol),
                              args.repeats)
        part = result.isel(time=picked)
        print(f"{tol:8.0e} {c:8.3f} {args.steps / c:12,.0f} "
              f"{rel_error(part['joint_force'], base['joint_force']):12.2e} "
              f"{rel_error(part['driver_torque'], base['driver_torque']):12.2e}")

    print("\n4. evaluation points per cycle, interpolated to every sample's phi_F")
    theta_f = mech.drivers[0].motion(t)[0]
    phi = np.mod(theta_f - theta_f[0], 2 * np.pi)
    torque = fast["driver_torque"].to_numpy()
    print(f"{'points':>8s} {'cpu s':>8s} {'steps/s':>12s} {'torque error':>13s}")
    for points in (16, 32, 64, 128, 256, 512, 1024, 4096):
        def run(points=points):
            cycle = rm.solve_cycle(mech, points, outputs=["driver_torque"])
            return rm.interpolate_cycle(cycle, phi)
        result, _w, c = timed(run, args.repeats)
        print(f"{points:8d} {c:8.3f} {args.steps / c:12,.0f} "
              f"{rel_error(result['driver_torque'], torque):13.2e}")


if __name__ == "__main__":
    main()
