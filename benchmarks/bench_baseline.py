"""CPU time of the periodic ISO rating and of the batched per-cycle baseline (docs/metrics.md).

Run: python benchmarks/bench_baseline.py
"""

import time

import numpy as np

from rigval.validation.metrics.compare import baseline, iso18571_periodic

rng = np.random.default_rng(0)
for n in (360, 720):
    angle = np.linspace(0, 2 * np.pi, n, endpoint=False)
    model = np.sin(angle) + 0.3 * np.sin(3 * angle)
    cycles = model[None] + 0.01 * rng.standard_normal((20, n))
    start = time.process_time()
    for _ in range(5):
        iso18571_periodic(cycles[0], model, angle)
    one = (time.process_time() - start) / 5
    start = time.process_time()
    baseline(cycles, angle=angle)
    many = time.process_time() - start
    print(f"n={n}: iso18571_periodic {one * 1e3:.0f} ms, baseline of 20 cycles {many:.2f} s CPU")
