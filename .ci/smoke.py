"""CI smoke run: every command of the README's command table once, on the plain install.

Run by ``.ci/run`` with the interpreter of the plain-install venv (``pip install .``, no extras)
right after the README's main job (``rigval demo``), so that a command needing an optional
package (h5netcdf, dask) fails CI. Each command gets a small input; the script checks its exit
code, that nothing printed a traceback or an internal error, that its outputs exist and that no
temporary ``.partial-`` file is left. A README command without an entry in :data:`SMOKE` fails
the run: a new command must come with its smoke invocation.

Usage: ``python .ci/smoke.py RIGVAL WORKDIR`` (RIGVAL: the venv's ``rigval`` script).
Standard library only.
"""

from __future__ import annotations

import re
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

#: command -> (arguments with {work}, {sim}, {scene} placeholders; allowed exit codes; outputs
#: that must exist afterwards, relative to the work folder). Order matters: simulate-rig writes
#: the run the later commands read. "demo" is the README's main job, run just before.
SMOKE: dict[str, tuple[list[str], tuple[int, ...], list[str]]] = {
    "simulate-rig": (["--out", "{sim}", "--speed", "1.0", "--seed", "2", "--duration", "12"],
                     (0,), ["sim/run_1p0_scene.toml", "sim/run_1p0_cdaq.tdms"]),
    "info": (["{sim}/run_1p0_cdaq.tdms", "{sim}/run_1p0_wls2.csv"], (0,), []),
    "init": (["{sim}/run_1p0_cdaq.tdms", "{sim}/run_1p0_wls1.tdms", "{sim}/run_1p0_wls2.csv",
              "--out", "{work}/init/scene.toml"], (0,), ["init/scene.toml"]),
    "validate": (["{scene}", "--out", "{work}/validate"], (0, 1),
                 ["validate/report.html", "validate/metrics.csv", "validate/run_1p0_scene.nc"]),
    "predict": (["builtin:fourbar", "--out", "{work}/predict", "--points", "36"], (0,),
                ["predict/report.html", "predict/prediction.nc"]),
    "campaign": (["{scene}", "--out", "{work}/campaign", "--no-progress"], (0, 1),
                 ["campaign/index.html", "campaign/campaign.json"]),
    "bench": (["--quick", "--stage", "model", "--out", "{work}/bench"], (0,),
              ["bench/bench.csv"]),
    "identify": (["{scene}", "--out", "{work}/identify"], (0, 1), []),
    "docs": (["scene"], (0,), []),
}

#: Commands the README's main job has already run, with the file that shows it.
MAIN_JOB = {"demo": REPO / "demo-report" / "index.html"}


def readme_commands() -> list[str]:
    """Return the subcommands of the README's command table, in order."""
    text = (REPO / "README.md").read_text(encoding="utf-8")
    return re.findall(r"^\| `rigval ([a-z][a-z-]*)", text, flags=re.M)


def main(rigval: str, work: Path) -> int:
    """Run every README command once; return 0 when all behave."""
    commands = readme_commands()
    missing = [c for c in commands if c not in SMOKE and c not in MAIN_JOB]
    if missing:
        print(f"smoke: README commands without a smoke invocation: {missing}", file=sys.stderr)
        return 1
    python = Path(rigval).with_name("python")
    for module in ("h5netcdf", "dask"):
        probe = subprocess.run([str(python), "-c", f"import {module}"], capture_output=True)
        if probe.returncode == 0:
            print(f"smoke: {module} is importable: this is not a plain install", file=sys.stderr)
            return 1
    work.mkdir(parents=True, exist_ok=True)
    values = {"work": str(work), "sim": str(work / "sim"),
              "scene": str(work / "sim" / "run_1p0_scene.toml")}
    failures = []
    for name in [c for c in SMOKE if c in commands]:  # SMOKE's order: simulate-rig first
        arguments, codes, outputs = SMOKE[name]
        argv = [rigval, name, *(a.format(**values) for a in arguments)]
        start = time.perf_counter()
        done = subprocess.run(argv, capture_output=True, text=True)
        seconds = time.perf_counter() - start
        problems = []
        if done.returncode not in codes:
            problems.append(f"exit code {done.returncode} (expected {codes})")
        if "Traceback" in done.stderr or "internal error" in done.stderr:
            problems.append("a traceback or internal error on stderr")
        problems += [f"missing output {o}" for o in outputs if not (work / o).is_file()]
        leftovers = sorted(str(p) for p in work.rglob("*.partial-*"))
        problems += [f"temporary file left: {p}" for p in leftovers]
        status = "ok" if not problems else "FAILED: " + "; ".join(problems)
        print(f"smoke: rigval {name:<13} {seconds:6.1f} s  exit {done.returncode}  {status}")
        if problems:
            failures.append(name)
            print(done.stdout[-2000:], done.stderr[-4000:], sep="\n", file=sys.stderr)
    for name, evidence in MAIN_JOB.items():
        if name in commands:
            ok = evidence.is_file()
            print(f"smoke: rigval {name:<13} (the README's main job) "
                  f"{'ok' if ok else 'FAILED: ' + str(evidence) + ' missing'}")
            if not ok:
                failures.append(name)
    if failures:
        print(f"smoke: failed: {', '.join(failures)}", file=sys.stderr)
        return 1
    print(f"smoke: all {len(commands)} README commands ran on the plain install")
    return 0


if __name__ == "__main__":
    if len(sys.argv) != 3:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    sys.exit(main(sys.argv[1], Path(sys.argv[2])))
