"""Campaign throughput: runs per minute one after the other, in 2 child processes, on Dask.

Generates ``--runs`` runs with the virtual rig (speeds spread over 1.0 ... 2.0 rev/s, ``--duration``
seconds each, no Wi-Fi dropouts), then validates all of them as a campaign four ways, each into a
fresh folder (nothing reused), ``--repeat`` rounds interleaved, and prints the best rate per way:

* ``none``: one after the other in this process,
* ``processes`` with 2 child processes (forked, one per run; the default without Dask),
* ``local`` with 1 and with 2 worker processes (the embedded LocalCluster).

Wall time is what a user waits for ``rigval campaign``: cluster start, worker imports, the runs, and
shutting the cluster down. ``mean run s`` is the mean wall time of one validation inside its worker,
``CPU s/run`` the CPU time its process spent on it. The machine's load average is printed: other
processes on the machine stretch wall times, not CPU times.

Usage::

    python benchmarks/bench_campaign.py [--runs 6] [--duration 6] [--repeat 2]
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

from rigval.sample_data import Imperfections, RigSettings, simulate_rig
from rigval.validation.campaign.engine import run_campaign

MODES = (("none", 1), ("processes", 2), ("local", 1), ("local", 2))  # (scheduler, processes)


def generate(folder: Path, runs: int, duration: float) -> list[Path]:
    speeds = [1.0 + i / max(runs - 1, 1) for i in range(runs)]
    quiet = Imperfections(dropouts=0, start_offset_s=0.3)
    return [simulate_rig(folder / f"run{i}", RigSettings(speed=round(speed, 3), duration=duration,
                                                          seed=i, preroll=3.0,
                                                          imperfections=quiet)).path("scene.toml")
            for i, speed in enumerate(speeds)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=6)
    parser.add_argument("--duration", type=float, default=6.0, help="record length per run, s")
    parser.add_argument("--repeat", type=int, default=2, help="rounds over the four modes")
    args = parser.parse_args()

    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp)
        start = time.perf_counter()
        scenes = generate(base / "rig", args.runs, args.duration)
        print(f"generated {len(scenes)} runs of {args.duration:g} s in "
              f"{time.perf_counter() - start:.1f} s; {os.cpu_count()} CPUs")
        print(f"{'scheduler':<10} {'workers':>7} {'repeat':>6} {'runs':>5} {'errors':>6} "
              f"{'wall s':>8} {'runs/min':>9} {'mean run s':>10} {'CPU s/run':>9} "
              f"{'load avg':>8}")
        best: dict[tuple[str, int], float] = {}
        for repeat in range(args.repeat):  # interleaved, so that load changes hit every mode
            for scheduler, workers in MODES:
                start = time.perf_counter()
                outcomes = run_campaign(scenes, base / f"out-{scheduler}-{workers}-{repeat}",
                                        scheduler=scheduler, workers=workers)
                wall = time.perf_counter() - start
                errors = sum(o.status == "error" for o in outcomes)
                mean_run = statistics.fmean(o.elapsed_s for o in outcomes)
                mean_cpu = statistics.fmean(o.cpu_s for o in outcomes)
                rate = 60 * len(outcomes) / wall
                best[scheduler, workers] = max(best.get((scheduler, workers), 0.0), rate)
                print(f"{scheduler:<10} {workers:>7} {repeat:>6} {len(outcomes):>5} {errors:>6} "
                      f"{wall:8.1f} {rate:9.2f} {mean_run:10.1f} {mean_cpu:9.1f} "
                      f"{os.getloadavg()[0]:8.1f}")
        print("best runs/min: " + ", ".join(f"{s} x{w}: {rate:.2f}"
                                            for (s, w), rate in best.items()))


if __name__ == "__main__":
    main()
