"""Virtual rig: time to write a run, and how well the pipeline recovers the rig's known clocks.

Usage: python benchmarks/bench_sample_data.py [--speed 1.0] [--duration 20] [--seed 1]

Prints the wall time of ``simulate_rig`` and the size of its files, then runs the validation
pipeline on the run's scene and compares each stream's fitted clock (``t_ref = offset + (1 +
drift) t_dev`` on the first segment, after the module delay) with the clock the rig used:
``drift = (1 + d_ref) / (1 + d_dev) - 1`` and ``offset = (1 + d_ref) (T_0 - delay d_dev / (1 +
d_dev))`` with ``T_0`` the true start of the stream's first sample (reference: cDAQ, T_0 = 0).
"""

from __future__ import annotations

import argparse
import tempfile
import time
import warnings
from pathlib import Path

from rigval.sample_data import RigSettings, load_truth, simulate_rig


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--speed", type=float, default=1.0)
    parser.add_argument("--duration", type=float, default=20.0)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        files = simulate_rig(tmp, RigSettings(speed=args.speed, duration=args.duration,
                                              seed=args.seed))
        elapsed = time.perf_counter() - start
        size = sum(p.stat().st_size for p in files.files)
        print(f"simulate_rig {args.duration:g} s at {args.speed:g} rev/s: {elapsed:.2f} s, "
              f"{size / 1e6:.2f} MB in {len(files.files)} files")
        _clock_table(files.path("scene.toml"), files.path("truth.json"))


def _clock_table(scene: Path, truth_path: Path) -> None:
    from rigval.validation.pipeline import run_scene

    truth = load_truth(truth_path, signals=False).record["streams"]
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = run_scene(scene)
    print(f"run_scene: {time.perf_counter() - start:.2f} s, passed {result.passed}")
    d_ref = truth["cdaq"]["drift_ppm"] * 1e-6
    print(f"{'stream':8} {'offset true s':>14} {'offset err us':>14} {'drift true ppm':>15} "
          f"{'drift err ppm':>14} {'residual us':>12}")
    for name, fit in result.alignment.items():
        if name == "cdaq":
            continue
        info = truth[name]
        d_dev = info["drift_ppm"] * 1e-6
        delay = max(c["input_delay_s"] for c in info["channels"].values())
        drift = (1 + d_ref) / (1 + d_dev) - 1
        offset = (1 + d_ref) * (info["segments"][0]["true_start_s"] - delay * d_dev / (1 + d_dev))
        print(f"{name:8} {offset:14.6f} {(fit.offset_s - offset) * 1e6:14.1f} "
              f"{drift * 1e6:15.3f} {fit.drift_ppm - drift * 1e6:14.3f} "
              f"{fit.residual_rms_s * 1e6:12.1f}")
    for comparison in result.comparisons:
        print(f"  {comparison.name:6} ISO 18571 rating "
              f"{comparison.scores['iso18571_periodic.rating']:.3f}")


if __name__ == "__main__":
    main()
