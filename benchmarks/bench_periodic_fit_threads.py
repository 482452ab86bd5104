"""Drive-angle estimation with the default BLAS threads against one (docs/performance.md).

Run it as installed (no OPENBLAS_NUM_THREADS) and with ``OPENBLAS_NUM_THREADS=1``; on a busy
machine start ``python -c "while True: pass"`` beside it once per core. Prints wall / CPU s of
three calls per method on a 40,000-sample quantised 0.8 rev/s record.
"""

import time

import numpy as np

from rigval.processing.excitation import drive_angle

FS = 2000.0
STEP = 2 * np.pi / 4096
t = np.arange(40_000) / FS
phase = 2 * np.pi * 0.8 * t
theta = phase + 0.05 * np.sin(phase) + 0.01 * np.sin(2 * phase + 1)
theta = np.round(theta / STEP) * STEP
for method in ("fourier", "butterworth"):
    times = []
    for _ in range(3):
        cpu, wall = time.process_time(), time.perf_counter()
        drive_angle(t, theta, fs=FS, step_rad=STEP, method=method)
        times.append(f"{time.perf_counter() - wall:.2f} / {time.process_time() - cpu:.2f}")
    print(f"{method}: wall / CPU s {', '.join(times)}")
