"""The diagnosis against the virtual rig's truth over many seeds: symmetry, attribution, honesty.

Runs the cases of ``tests/validation/diagnosis_cases.py`` (20 s at 1 rev/s each) and prints, per
case, the figures of issue 25's "Done when" (docs/diagnosis.md, *Measured*):

* ``split 0.53``: the main drive's pair share's 95 % interval covers 0.53; flagged asymmetric;
* ``split 0.50``: flagged asymmetric (false alarms);
* ``gain 3 %`` (tor1 and tor2 read 3 % high: torque_F's gain), ``lag 2 ms`` (tor1),
  ``arm +8 %`` (A.mass): the most likely cause of the affected comparison is the right one
  (and the gain's interval covers 3 %);
* ``calibration``: every sensor's calibration error drawn from the scene's stated uncertainty:
  the run's statements together (:func:`rigval.validation.verdict.family_k`) detect no model
  error; ``calibration, arm +8 %``: they detect one on torque_F or torque_H. The column
  "detected (most often)" counts each comparison's own statement at k = 2.

Each run's outcome is appended to a JSON-lines file, so an interrupted sweep resumes.

Usage: ``python benchmarks/diagnosis_attribution.py OUT.jsonl [SEEDS] [CASE ...]`` (default 40
seeds, every case); ``--summary OUT.jsonl`` prints the table of a finished file.
"""

from __future__ import annotations

import importlib.util
import json
import sys
import tempfile
import time
import warnings
from pathlib import Path
from typing import Any

from rigval.acquisition.errors import RigvalError

_CASES = Path(__file__).resolve().parents[1] / "tests" / "validation" / "diagnosis_cases.py"


def _cases():
    spec = importlib.util.spec_from_file_location("diagnosis_cases", _CASES)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    assert spec.loader is not None
    spec.loader.exec_module(module)
    return module


def _right(row: dict[str, Any]) -> tuple[str, bool, str]:
    """The figure a case is judged by: (what, passed, detail)."""
    case, causes = row["case"], row["causes"]
    if case.startswith("split"):
        pair = row["pair"]
        if case == "split 0.53":
            covered = pair["lower"] <= 0.53 <= pair["upper"]
            return "covers 0.53 and flagged", covered and pair["asymmetric"], (
                f"{pair['share']:.4f} [{pair['lower']:.4f}, {pair['upper']:.4f}]")
        return "not flagged", not pair["asymmetric"], (
            f"{pair['share']:.4f} +- {pair['u_share']:.4f}")
    if case == "gain 3 %":
        c = causes["torque_F"]
        inside = abs(c["value"] - 0.03) <= 1.96 * c["std"] if c["cause"] else False
        return "gain torque_F, covers 3 %", c["cause"] == "gain torque_F" and inside, (
            f"{c['cause']} {c['value']:+.4f} +- {c['std']:.4f}")
    if case == "lag 2 ms":
        c = causes["tor1"]
        return "lag tor1", c["cause"] == "lag tor1", f"{c['cause']} {c['value']:+.5f} s"
    if case == "arm +8 %":
        c = causes["torque_F"]
        return "A.mass", c["cause"] == "A.mass", f"{c['cause']} {c['relative']:+.4f}"
    family = row["family"]
    each = ", ".join(row["detected"]) or "-"
    if case == "calibration":
        return "run passes (family k)", not family["detected"], (
            f"each at k = 2: {each}; together (k = {family['k']:.2f}): "
            f"{', '.join(family['detected_on']) or '-'}")
    hit = bool({"torque_F", "torque_H"} & set(family["detected_on"]))
    return "torque_F/H detected (family k)", hit, f"each at k = 2: {each}"


def summary(path: Path) -> None:
    """Print, per case, how often its figure held."""
    rows = [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines() if line]
    by_case: dict[str, list[dict[str, Any]]] = {}
    failed: dict[str, list[int]] = {}
    for row in rows:
        if "error" in row:
            failed.setdefault(row["case"], []).append(row["seed"])
            continue
        by_case.setdefault(row["case"], []).append(row)
    print(f"{'case':<24} {'seeds':>5} {'figure':<30} {'held':>7}  detected at k = 2 (most often)")
    for case, group in by_case.items():
        judged = [_right(row) for row in group]
        held = sum(ok for _, ok, _ in judged)
        detected: dict[str, int] = {}
        for row in group:
            for name in row["detected"]:
                detected[name] = detected.get(name, 0) + 1
        top = ", ".join(f"{n} {k}" for n, k in sorted(detected.items(), key=lambda i: -i[1])[:3])
        print(f"{case:<24} {len(group):>5} {judged[0][0]:<30} {held:>3}/{len(group):<3} {top}")
        for row, (_, ok, detail) in zip(group, judged, strict=True):
            if not ok:
                print(f"{'':<24} seed {row['seed']:>3}: {detail}")
        if case in failed:
            print(f"{'':<24} runs that failed before the diagnosis (not counted), seeds "
                  f"{failed[case]}")


def main(argv: list[str]) -> None:
    if argv and argv[0] == "--summary":
        summary(Path(argv[1]))
        return
    out = Path(argv[0])
    seeds = int(argv[1]) if len(argv) > 1 else 40
    module = _cases()
    cases = argv[2:] or list(module.CASES)
    done = set()
    if out.exists():
        done = {(r["case"], r["seed"]) for r in map(json.loads, out.read_text().splitlines())}
    warnings.simplefilter("ignore")
    for case in cases:
        for seed in range(1, seeds + 1):
            if (case, seed) in done:
                continue
            start = time.perf_counter()
            with tempfile.TemporaryDirectory() as folder:
                try:
                    row = module.run_case(case, seed, Path(folder))
                except RigvalError as error:  # the run itself failed (e.g. its alignment)
                    row = {"case": case, "seed": seed, "error": str(error)}
            row["seconds"] = time.perf_counter() - start
            if "error" in row:
                print(f"{case} seed {seed}: run failed: {row['error']}", flush=True)
                with out.open("a", encoding="utf-8") as handle:
                    handle.write(json.dumps(row) + "\n")
                continue
            with out.open("a", encoding="utf-8") as handle:
                handle.write(json.dumps(row, default=str) + "\n")
            print(f"{case} seed {seed}: {_right(row)} ({row['seconds']:.1f} s)", flush=True)
    summary(out)


if __name__ == "__main__":
    main(sys.argv[1:])
