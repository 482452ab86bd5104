"""Sensor health on the virtual rig: injected faults found with their place, false alarms.

For each seed, one clean run and one run with eight faults, each on its own channel (sizes set
from the clean run's own signals): tor2 clipped at 75 % of its peak, tor3 flat from 60 % of the
record, 5 spikes of 30 % of str1's span, noise 10 times tor4's floor from 30 to 70 %, tor1's zero
drifting by 10 % of its span, enc1 losing 40 counts at 50 %, a 25-count glitch on enc2 at 35 %,
and opt2's pulses 30 % wider from 50 % on. Speeds 0.7-1.3 rev/s, 20 s records (the rig's default).

A fault counts as found when a finding of its kind on its channel gives its place:

- clipping: the samples found clipped within 20 % of the samples the rig clipped;
- flat line: its first sample within 2 samples of the truth;
- spikes: every injected spike's sample listed;
- noise: the span found overlapping the true span by 70 % (intersection over union);
- zero drift: the drift found within 25 % of the injected drift;
- count jump, count glitch: the sample within 1 of the truth;
- pulse width: the first pulse found within half a period of the first widened one.

A false alarm is any finding on a clean run (per run: any finding at all).

Usage: ``python benchmarks/bench_health.py [SEEDS] [FOLDER]`` (default 40 seeds, a temporary
folder).
"""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

import numpy as np

from rigval.acquisition import read
from rigval.processing.health import Finding
from rigval.processing.health_check import stream_health
from rigval.sample_data.faults import Fault
from rigval.sample_data.rig import RigSettings
from rigval.sample_data.simulate import simulate_rig

KINDS = {"cdaq": {"acc1": "analog", "acc2": "analog", "acc3": "analog", "str1": "analog",
                  "opt1": "pulse", "enc1": "counter", "enc2": "counter"},
         "wls1": {"tor1": "analog", "tor2": "analog", "opt2": "pulse"},
         "wls2": {"tor3": "analog", "tor4": "analog", "opt3": "pulse"}}
MODULES = {"acc1": "NI 9215", "acc2": "NI 9215", "acc3": "NI 9215", "str1": "NI 9237",
           "tor1": "NI 9237", "tor2": "NI 9237", "tor3": "NI 9237", "tor4": "NI 9237"}
CPR = {"enc1": 8192, "enc2": 8192}


def run_health(folder: Path, stem: str) -> tuple[dict, list[Finding]]:
    """Read a run's three streams and check them; return the streams and the findings."""
    streams, findings = {}, []
    for name in KINDS:
        path = folder / f"{stem}_{name}.{'csv' if name == 'wls2' else 'tdms'}"
        streams[name] = next(iter(read(path).values()))
        findings += stream_health(streams[name], KINDS[name], name=name, modules=MODULES,
                                  counts_per_rev=CPR)
    return streams, findings


def _noise(x: np.ndarray) -> float:
    d3 = np.diff(x, 3)
    return 1.4826 * float(np.median(np.abs(d3 - np.median(d3)))) / np.sqrt(20.0)


def faults_for(streams: dict) -> tuple[Fault, ...]:
    """The eight faults, sized from the clean run's signals."""
    tor2 = streams["wls1"]["tor2"].to_numpy()
    str1 = streams["cdaq"]["str1"].to_numpy()
    tor1 = streams["wls1"]["tor1"].to_numpy()
    tor4 = streams["wls2"]["tor4"].to_numpy()
    return (Fault("clipping", "wls1", "tor2", 0.75 * float(np.max(np.abs(tor2)))),
            Fault("flat line", "wls2", "tor3", 0.0, 0.6, 1.0),
            Fault("spikes", "cdaq", "str1", 0.3 * float(np.ptp(str1)), 0.05, 0.95, 5),
            Fault("noise", "wls2", "tor4", 10.0 * _noise(tor4), 0.3, 0.7),
            Fault("zero drift", "wls1", "tor1", 0.1 * float(np.ptp(tor1))),
            Fault("count jump", "cdaq", "enc1", 40.0, 0.5),
            Fault("count glitch", "cdaq", "enc2", 25.0, 0.35),
            Fault("pulse width", "wls1", "opt2", 0.3, 0.5))


def located(truth: dict, found: list[Finding], period_samples: float) -> bool:
    """Whether a finding of the truth's kind on its channel gives its place (module docstring)."""
    mine = [f for f in found if f.channel == f"{truth['stream']}.{truth['channel']}"
            and f.fault == truth["kind"]]
    if not mine:
        return False
    kind = truth["kind"]
    if kind == "clipping":
        return abs(sum(f.samples for f in mine) - truth["samples"]) <= 0.2 * truth["samples"]
    if kind == "flat line":
        return any(abs(f.first_sample - truth["first_sample"]) <= 2 for f in mine)
    if kind == "spikes":
        listed = {i for f in mine for i in f.indices}
        return set(truth["indices"]) <= listed
    if kind == "noise":
        lo, hi = truth["first_sample"], truth["last_sample"]
        return any((min(hi, f.last_sample) - max(lo, f.first_sample))
                   / (max(hi, f.last_sample) - min(lo, f.first_sample)) >= 0.7 for f in mine)
    if kind == "zero drift":
        return any(abs(f.value - truth["size"]) <= 0.25 * abs(truth["size"]) for f in mine)
    if kind in ("count jump", "count glitch"):
        return any(abs(i - truth["first_sample"]) <= 1 for f in mine for i in f.indices)
    return any(abs(f.first_sample - truth["first_sample"]) <= 0.5 * period_samples
               for f in mine)


def main(argv: list[str]) -> None:
    seeds = int(argv[0]) if argv else 40
    base = Path(argv[1]) if len(argv) > 1 else Path(tempfile.mkdtemp(prefix="rigval-health-"))
    found: dict[str, list[bool]] = {}
    clean_alarms, other_alarms = [], []
    for seed in range(1, seeds + 1):
        speed = round(0.7 + 0.6 * np.random.default_rng(seed).uniform(), 2)
        settings = RigSettings(speed=speed, duration=20.0, seed=seed)
        files = simulate_rig(base / f"clean{seed}", settings)
        streams, clean = run_health(files.folder, files.stem)
        clean_alarms.append([f.line() for f in clean])
        faulted = simulate_rig(base / f"faults{seed}",
                               RigSettings(speed=speed, duration=20.0, seed=seed,
                                           faults=faults_for(streams)))
        _, findings = run_health(faulted.folder, faulted.stem)
        truth = json.loads(faulted.path("truth.json").read_text())["faults"]
        hurt = {f"{t['stream']}.{t['channel']}" for t in truth}
        other_alarms.append([f.line() for f in findings if f.channel not in hurt])
        period = 1612.9 / speed
        for t in truth:
            found.setdefault(t["kind"], []).append(located(t, findings, period))
        print(f"seed {seed} ({speed} rev/s): clean {len(clean)} findings, faults found "
              f"{sum(located(t, findings, period) for t in truth)}/{len(truth)}", flush=True)
        for line in clean_alarms[-1] + other_alarms[-1]:
            print(f"    false alarm: {line}", flush=True)
    print(f"\n{'fault':<14} {'seeds':>5} {'found with its place':>21}")
    for kind, hits in found.items():
        print(f"{kind:<14} {len(hits):>5} {100.0 * np.mean(hits):>20.1f} %")
    print(f"clean runs with any finding (15 channels each): "
          f"{sum(bool(a) for a in clean_alarms)} of {len(clean_alarms)}")
    print(f"faulted runs with a finding on an unfaulted channel (7 each): "
          f"{sum(bool(a) for a in other_alarms)} of {len(other_alarms)}")


if __name__ == "__main__":
    main(sys.argv[1:])
