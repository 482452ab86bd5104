"""Time per stage of the validation pipeline on the shipped sample runs (wall and CPU time).

Usage: python benchmarks/bench_validation.py [--repeat N]

Prints one row per run and stage; wall time depends on what else the machine is doing, CPU time
(this process) much less so.
"""

import argparse
import tempfile
import time
from pathlib import Path

from rigval.sample_data import shipped_runs
from rigval.validation.pipeline import run_scene
from rigval.validation.report.run_report import write_report


def main(repeat: int) -> None:
    print(f"{'run':10s} {'stage':10s} {'wall [s]':>9s}")
    for scene in shipped_runs():
        for _ in range(repeat):
            cpu = time.process_time()
            wall = time.perf_counter()
            result = run_scene(scene)
            with tempfile.TemporaryDirectory() as out:
                start = time.perf_counter()
                write_report(result, Path(out))
                report_s = time.perf_counter() - start
            stages = {**result.numerics.stage_seconds, "report": report_s}
            for stage, seconds in stages.items():
                print(f"{scene.stem[:10]:10s} {stage:10s} {seconds:9.3f}")
            print(f"{scene.stem[:10]:10s} {'total':10s} {time.perf_counter() - wall:9.3f}   "
                  f"(CPU {time.process_time() - cpu:.3f} s)")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=1)
    main(parser.parse_args().repeat)
