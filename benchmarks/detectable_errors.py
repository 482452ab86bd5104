"""Which 5 % mass or inertia errors each comparison's V&V 20 statements detect.

For each shipped sample run (or the scenes given) the run is validated with its mechanism; the
identification regressor (``rigval.model.identify.regressor``) gives each body parameter's
effect on every drive-torque and joint-force comparison (scaled, offset removed where the
comparison removes it). A parameter error of ``x`` % moves the comparison by ``x`` times the
effect of 1 %; the script prints the smallest ``x`` that reaches:

- the whole-curve statement, ``rms(effect) = k u_val`` (calibration included);
- the common-gain statement (comparisons stating ``u_measurement_rel_common``, grouped as
  ``rigval.validation.verdict.with_common_gain`` groups them): the effect's gains on the group's
  comparisons differ by ``k sqrt(u_own_1^2 + u_own_2^2)`` (two comparisons per group).

Accelerations depend on no mass or inertia (the drives are measured) and are not listed.
With ``--rig`` it also runs the virtual rig with each body parameter 5 % larger, validates the
run against the nominal file and prints the measured ``|E|/(k u_val)`` of both statements.
Usage::

    python benchmarks/detectable_errors.py [SCENE ...] [--rig --speed 0.8 --seed 1 --duration 8]
"""

from __future__ import annotations

import argparse
import re
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from rigval.model import builtin_mechanism, load_mechanism
from rigval.model.identify import nominal_parameters, regressor
from rigval.sample_data import RigSettings, runs_dir, simulate_rig
from rigval.validation.pipeline import run_scene
from rigval.validation.verdict import run_verdict

PARAMETERS = ("A.mass", "A.inertia", "B.mass", "B.inertia", "C.mass", "E.mass", "E.inertia",
              "F.mass", "G.mass", "H.mass")
_FORCES = ("driver_torque", "joint_force")


def effects(result) -> dict[str, dict[str, np.ndarray]]:
    """Per comparison and parameter, the comparison's change for a 1 % larger parameter."""
    mechanism = load_mechanism(result.scene.mechanism)
    model = result.tree["/model"].to_dataset()
    drives = None
    if result.scene.model.drives == "measured":
        drives = {d: tuple(model[f"drive_{d}{s}"].to_numpy() for s in ("", "_dot", "_ddot"))
                  for d in result.scene.model.drivers}
    used = [c for c in result.comparisons if c.spec.model.quantity in _FORCES]
    outputs = [(c.spec.model.quantity, c.spec.model.item) if c.spec.model.axis is None
               else (c.spec.model.quantity, c.spec.model.item, c.spec.model.axis) for c in used]
    reg = regressor(mechanism, model["time"].to_numpy(), outputs, drives=drives)
    nominal = nominal_parameters(mechanism)
    out = {}
    for i, comparison in enumerate(used):
        per = {}
        for name in PARAMETERS:
            effect = reg.matrix[i, :, reg.names.index(name)] * nominal[name] * 0.01
            effect = effect * comparison.spec.scale
            per[name] = effect - effect.mean() if comparison.spec.remove_offset else effect
        out[comparison.name] = per
    return out


def detectable(result) -> tuple[dict[str, dict[str, float]], dict[str, float]]:
    """Smallest detectable error in % per comparison (curve) and per parameter (common gain)."""
    table = effects(result)
    by_name = {c.name: c for c in result.comparisons}
    curve = {}
    for name, per in table.items():
        scores = by_name[name].scores
        limit = scores["vv20.curve.k"] * scores["vv20.curve.u_val"]
        curve[name] = {p: limit / float(np.sqrt(np.mean(e**2))) for p, e in per.items()}
    group = [n for n in table if "vv20.common_gain.error" in by_name[n].scores]
    gain = {}
    if len(group) == 2:
        first, second = (by_name[n] for n in group)
        u = np.hypot(first.scores["vv20.curve.u_gain_own"], second.scores["vv20.curve.u_gain_own"])
        for p in PARAMETERS:
            shift = [_gain(by_name[n].mean, table[n][p]) for n in group]
            gain[p] = first.scores["vv20.curve.k"] * u / abs(shift[0] - shift[1])
    return curve, gain


def _gain(measured: np.ndarray, effect: np.ndarray) -> float:
    centred = measured - measured.mean()
    return float(effect @ centred / (centred @ centred))


def _scaled(folder: Path, parameter: str, factor: float) -> Path:
    body, key = parameter.split(".")
    text = Path(builtin_mechanism("pendulum")).read_text(encoding="utf-8")
    text, count = re.subn(rf'(name = "{body}"\n(?:.*\n)*?){key} = ([0-9.]+)',
                          lambda m: f"{m[1]}{key} = {float(m[2]) * factor!r}", text, count=1)
    assert count == 1, parameter
    path = folder / f"{parameter}.toml"
    path.write_text(text, encoding="utf-8")
    return path


def rig_rows(args: argparse.Namespace) -> None:
    """Validate virtual-rig runs with each parameter 5 % larger against the nominal file."""
    print(f"\nvirtual rig, {args.speed} rev/s, seed {args.seed}, {args.duration} s, "
          "validated with the nominal file: |E|/(k u_val) of the curve / common gain")
    with tempfile.TemporaryDirectory() as tmp:
        for parameter in ("nominal", *args.parameters):
            start = time.perf_counter()
            mech = (Path(builtin_mechanism("pendulum")) if parameter == "nominal"
                    else _scaled(Path(tmp), parameter, 1.05))
            files = simulate_rig(Path(tmp) / parameter, RigSettings(
                speed=args.speed, duration=args.duration, seed=args.seed, mechanism=mech))
            scene = files.path("scene.toml")
            scene.write_text(re.sub(r"^mechanism = .*$", 'mechanism = "builtin:pendulum"',
                                    scene.read_text(encoding="utf-8"), flags=re.M),
                             encoding="utf-8")
            result = run_scene(scene)
            cells = []
            for c in result.comparisons:
                s = c.scores
                text = f"{s['vv20.curve.error'] / (s['vv20.curve.k'] * s['vv20.curve.u_val']):.2f}"
                if "vv20.common_gain.normalised_error" in s:
                    ratio = abs(s["vv20.common_gain.normalised_error"]) / s["vv20.curve.k"]
                    text += f"/{ratio:.2f}"
                cells.append(f"{c.name} {text}")
            verdict = run_verdict(result)
            print(f"{parameter:10s} {', '.join(cells)}; detected on "
                  f"{', '.join(verdict['detected_on']) or 'none'}; passed {result.passed} "
                  f"({time.perf_counter() - start:.0f} s)", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", nargs="*", type=Path)
    parser.add_argument("--rig", action="store_true", help="also run perturbed virtual rigs")
    parser.add_argument("--speed", type=float, default=0.8)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--duration", type=float, default=8.0)
    parser.add_argument("--parameters", default="A.mass,A.inertia,E.mass,E.inertia,G.mass")
    args = parser.parse_args()
    args.parameters = args.parameters.split(",")
    warnings.simplefilter("ignore")     # the sample runs' Wi-Fi dropouts are not the subject
    scenes = args.scenes or [runs_dir() / "run_0p8_scene.toml", runs_dir() / "run_1p2_scene.toml"]
    for scene in scenes:
        result = run_scene(scene)
        curve, gain = detectable(result)
        print(f"\n{scene.name}: smallest detectable error, % of the file's value (>100: '-')")
        print(f"{'comparison':20s}" + "".join(f"{p:>11s}" for p in PARAMETERS))
        for name, row in curve.items():
            print(f"{name:20s}" + "".join(f"{_cell(row[p]):>11s}" for p in PARAMETERS))
        if gain:
            print(f"{'common gain':20s}" + "".join(f"{_cell(gain[p]):>11s}" for p in PARAMETERS))
    if args.rig:
        rig_rows(args)


def _cell(value: float) -> str:
    return "-" if value > 100 else f"{value:.1f}"


if __name__ == "__main__":
    main()
