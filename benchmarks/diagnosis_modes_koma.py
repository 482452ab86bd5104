"""rigval's resonance fit against koma-python's covariance-driven SSI on the virtual rig's truth.

Issue 25 asks to measure one operational-modal-analysis library against rigval's own peak fit
before depending on it. koma-python (``koma.oma.covssi`` and ``find_stable_poles``, Kvale et
al.) is the one measured here; it is not a dependency of rigval. Run it with koma's wheel
unpacked on ``PYTHONPATH`` (its ``koma.oma`` needs only numpy and scipy; the package itself
pulls in pyvista, trame, ipywidgets and plotly):

```
d=$(mktemp -d); pip download --no-deps -d $d koma-python==1.3.6
(cd $d && unzip -q koma_python-*.whl)
PYTHONPATH=$d python benchmarks/diagnosis_modes_koma.py [SEEDS]
```

Both methods see the same input: str1's non-synchronous residual
(:func:`rigval.validation.diagnosis.spectra.residual_parts`) of runs like those of
``benchmarks/diagnosis_modes.py`` (a rod-B mode drawn from 12-30 Hz, 1-5 % damping, 5 % of
str1's range; and the same rig without a mode). For SSI: block rows 40, model orders 2-40,
poles within the band rigval searches (damping 0.2-20 %) chained across orders (``_ssi``).
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from koma.oma import covssi

from rigval.sample_data import RigSettings, simulate_rig
from rigval.sample_data.departures import Departures
from rigval.validation.diagnosis.modes import default_band, find_resonances
from rigval.validation.diagnosis.residual import residual_series
from rigval.validation.diagnosis.spectra import residual_parts, residual_spectra
from rigval.validation.pipeline import run_scene


def _ssi(x: np.ndarray, fs: float, band: tuple[float, float]) -> tuple[float, float] | None:
    """Covariance SSI of one channel; the stable pole seen at the most model orders, or None.

    koma's own ``find_stable_poles`` kept no pole of a single channel here at its usual
    criteria, so the stabilisation is the plain one: poles within the band (damping 0.2-20 %)
    are chained by frequency (1 %), and a chain seen at half the model orders or more is a
    mode; the longest chain is reported (median frequency and damping).
    """
    orders = np.arange(2, 42, 2)
    lambd, _, pole_orders = covssi(x[:, None], fs, 40, orders, showinfo=False)
    freq = np.abs(lambd) / (2 * np.pi)
    damping = -np.real(lambd) / np.abs(lambd)
    keep = (freq >= band[0]) & (freq <= band[1]) & (damping > 0.002) & (damping < 0.2)
    freq, damping, pole_orders = freq[keep], damping[keep], pole_orders[keep]
    best = None
    for f in freq:
        near = np.abs(freq / f - 1) < 0.01
        count = np.unique(pole_orders[near]).size
        if count >= orders.size / 2 and (best is None or count > best[0]):
            best = (count, float(np.median(freq[near])), float(np.median(damping[near])))
    return None if best is None else best[1:]


def _run(settings: RigSettings):
    with tempfile.TemporaryDirectory() as folder:
        files = simulate_rig(Path(folder), settings)
        result = run_scene(files.path("scene.toml"))
    series = residual_series(result, "str1")
    upper = min(40.0, 0.25 * series.fs)
    parts = residual_parts(series, upper)
    band = default_band(series.speed_rev_s, upper)
    start = time.perf_counter()
    ours = find_resonances(residual_spectra(series, upper).nonsynchronous,
                           series.speed_rev_s, band)
    t_ours = time.perf_counter() - start
    longest = max(np.unique(parts.run), key=lambda k: np.sum(parts.run == k))
    start = time.perf_counter()
    theirs = _ssi(parts.nonsynchronous[parts.run == longest], parts.fs, band)
    return ours, theirs, t_ours, time.perf_counter() - start


def main(argv: list[str]) -> None:
    seeds = int(argv[0]) if argv else 12
    table = {"rigval": [], "koma": []}
    false = {"rigval": 0, "koma": 0}
    times = {"rigval": [], "koma": []}
    for seed in range(1, seeds + 1):
        rng = np.random.default_rng(1000 + seed)
        hz, zeta = round(rng.uniform(12.0, 30.0), 2), round(rng.uniform(0.01, 0.05), 4)
        speed = float(rng.choice([0.8, 1.0, 1.2]))
        ours, theirs, t1, t2 = _run(RigSettings(
            speed=speed, duration=20.0, seed=1000 + seed, departures=Departures(
                mode_body="B", mode_hz=hz, mode_damping=zeta, mode_level=0.05)))
        times["rigval"].append(t1)
        times["koma"].append(t2)
        near = [r for r in ours if abs(r.frequency_hz / hz - 1) <= 0.02]
        table["rigval"].append((near[0].frequency_hz / hz - 1, near[0].damping / zeta)
                               if near else None)
        table["koma"].append((theirs[0] / hz - 1, theirs[1] / zeta)
                             if theirs and abs(theirs[0] / hz - 1) <= 0.02 else None)
        print(f"seed {seed:2d} {hz:5.2f} Hz zeta {zeta:.4f}: rigval "
              f"{[(round(r.frequency_hz, 2), round(r.damping, 4)) for r in ours]}, koma "
              f"{None if theirs is None else (round(theirs[0], 2), round(theirs[1], 4))}",
              flush=True)
        ours, theirs, _, _ = _run(RigSettings(speed=speed, duration=20.0, seed=2000 + seed))
        false["rigval"] += bool(ours)
        false["koma"] += theirs is not None
        print(f"seed {seed:2d} no mode: rigval {len(ours)} resonances, koma "
              f"{None if theirs is None else round(theirs[0], 2)}", flush=True)
    for name, rows in table.items():
        hits = [r for r in rows if r is not None]
        err = np.abs([h[0] for h in hits]) * 100 if hits else np.array([np.nan])
        ratio = np.array([h[1] for h in hits]) if hits else np.array([np.nan])
        print(f"{name}: found within 2 % {len(hits)}/{seeds}; |f error| median "
              f"{np.median(err):.2f} %, max {np.max(err):.2f} %; damping found/true median "
              f"{np.median(ratio):.2f}, range {np.min(ratio):.2f}-{np.max(ratio):.2f}; "
              f"false alarms {false[name]}/{seeds}; median time {np.median(times[name]):.3f} s")


if __name__ == "__main__":
    main(sys.argv[1:])
