"""``rigval identify SCENE --out DIR``: the inertial parameters the measured torques support.

Writes ``identified.json`` (value, standard error and nominal value per parameter, condition
number, parameters that are not identifiable and why), ``mechanism.toml`` (the scene's mechanism
with the identified values), ``report.html`` (the V&V 20 verdict and the ratings of the nominal
and the identified model side by side) and the two validation report folders ``nominal/`` and
``identified/``. Exit codes: 0 done, 2 bad scene or parameter, 3 data error. See
``docs/identify.md``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
from pathlib import Path
from typing import Any

from rigval.validation.commands.common import add_command, add_out_option, add_scene_argument

__all__ = ["add_parser", "run", "write_identification"]


def add_parser(subparsers: Any) -> None:
    """Register the ``identify`` subcommand."""
    parser = add_command(
        subparsers, run, "identify",
        help="identify masses, inertias (and drive friction) from a run",
        description="Fit the inertial parameters of the scene's mechanism to the measured drive "
                    "torques (linear least squares on the revolution-averaged curves), write "
                    "identified.json, mechanism.toml and a report that re-validates the run with "
                    "the identified values beside the nominal ones.",
        exit_codes="0 done, 2 bad scene or parameter, 3 data error.")
    add_scene_argument(parser)
    parser.add_argument("--parameters", default="auto",
                        help='"auto" (identifiable base parameters) or a comma list such as '
                             "A.mass,A.inertia,E.mass (kinds: mass, mx, my, inertia; friction: "
                             "DRIVER.viscous, DRIVER.coulomb)")
    parser.add_argument("--friction", action="store_true",
                        help="with auto: also viscous and Coulomb friction of each drive")
    parser.add_argument("--comparisons", default=None,
                        help="comma list of the scene's torque/force comparisons to use "
                             "(default: the drive torques)")
    add_out_option(parser)


def write_identification(identification: Any, out_dir: Path, measurement: Any = None,
                         drawers: Any = None, nominal_figures: Any = None) -> list[Path]:
    """Write ``identified.json``, ``mechanism.toml`` and the re-validation reports.

    Parameters
    ----------
    identification : rigval.validation.identify.Identification
        The result of :func:`rigval.validation.identify.identify`.
    out_dir : pathlib.Path
        Output folder (created).
    measurement : rigval.validation.pipeline.Measurement, optional
        The nominal run's kept measurement: the identified mechanism is validated against it
        without reading and aligning the files again (default: the scene is run again).
    drawers : rigval.validation.report.drawing.Drawers, optional
        Where the reports' figures are drawn (:func:`~rigval.validation.report.drawing.
        standby_drawers`); default: here.
    nominal_figures : rigval.validation.report.drawing.Drawing, optional
        The nominal report's figures, started on ``drawers`` as soon as the nominal run was
        validated; default: started here.

    Returns
    -------
    list of pathlib.Path
        Files written: ``report.html``, ``identified.json``, ``mechanism.toml`` and the report
        folders' files.
    """
    from rigval.acquisition.outputs import write_text_atomic
    from rigval.model.mechanism import load_mechanism
    from rigval.model.mechanism_text import apply_parameters, mechanism_toml
    from rigval.validation.diagnosis.rigidity import run_rigidity_pair
    from rigval.validation.pipeline import run_scene
    from rigval.validation.report.run_report import start_figures, write_report

    out_dir.mkdir(parents=True, exist_ok=True)
    nominal = identification.nominal_result
    if nominal_figures is None:
        nominal_figures = start_figures(nominal, drawers)
    scene = nominal.scene
    document = apply_parameters(load_mechanism(scene.mechanism),
                                dict(zip(identification.names, identification.value,
                                         strict=True)))
    mechanism_path = out_dir / "mechanism.toml"
    write_text_atomic(mechanism_path, mechanism_toml(document, header=(
        f"{document.get('name', 'mechanism')}: inertial parameters identified by rigval "
        f"identify\nfrom {scene.path.name} ({', '.join(identification.comparisons)}); see "
        "identified.json")))
    json_path = out_dir / "identified.json"
    write_text_atomic(json_path, json.dumps(identification.as_dict(), indent=2) + "\n")
    identified = (measurement.against(mechanism_path.resolve()) if measurement is not None
                  else run_scene(dataclasses.replace(scene, mechanism=mechanism_path.resolve())))
    identified_figures = start_figures(identified, drawers)
    # one measurement against two mechanisms: their residuals' analyses share what they can
    rigidity = run_rigidity_pair(nominal, identified)
    written = [json_path, mechanism_path,
               *write_report(nominal, out_dir / "nominal", nominal_figures, rigidity[0]),
               *write_report(identified, out_dir / "identified", identified_figures, rigidity[1])]
    written.insert(0, _page(identification, identified).write(out_dir / "report.html"))
    return written


def _page(identification: Any, identified: Any) -> Any:
    """Build the side-by-side page: verdicts, parameters, ratings per comparison."""
    from rigval.validation.report.page import Link, Page
    from rigval.validation.verdict import run_verdict

    nominal = identification.nominal_result
    verdicts = {"nominal": run_verdict(nominal), "identified": run_verdict(identified)}
    page = Page(f"rigval identify: {nominal.scene.title}",
                subtitle=f"{len(identification.names)} parameters from "
                         f"{', '.join(identification.comparisons)}")
    page.section("Summary")
    for which, verdict in verdicts.items():
        page.paragraph(f"ASME V&V 20, {which} model: {verdict['statement']}",
                       css_class="bad" if verdict["detected"] else "ok")
    page.facts({"condition number": identification.condition_number,
                "revolutions": identification.n_cycles,
                "not identifiable": ", ".join(identification.not_identifiable) or "none"})
    page.section("Parameters")
    page.table([{"parameter": name, "identified": value, "std": std, "nominal": nom,
                 "change [%]": 100.0 * (value / nom - 1.0) if nom else None,
                 "calibration part": cal, "unit": unit}
                for name, value, std, nom, cal, unit in zip(
                    identification.names, identification.value, identification.std,
                    identification.nominal, identification.u_calibration, identification.units,
                    strict=True)], digits=5)
    if identification.not_identifiable:
        page.table([{"parameter": k, "why": v}
                    for k, v in identification.not_identifiable.items()])
    page.section("Re-validation")
    ratios = {which: {row["comparison"]: row["ratio"] for row in verdict["comparisons"]}
              for which, verdict in verdicts.items()}
    rows = []
    for a, b in zip(nominal.comparisons, identified.comparisons, strict=True):
        rows.append({"comparison": a.name,
                     "|E|/(k u_val) nominal": ratios["nominal"].get(a.name, math.nan),
                     "|E|/(k u_val) identified": ratios["identified"].get(b.name, math.nan),
                     "ISO rating nominal": a.scores.get("iso18571_periodic.rating"),
                     "ISO rating identified": b.scores.get("iso18571_periodic.rating")})
    page.table(rows, digits=3)
    page.table([{"report": Link(f"{which}/report.html", f"{which}/report.html"),
                 "the run validated with": what}
                for which, what in (("nominal", "the mechanism file's values"),
                                    ("identified", "the identified values"))],
               caption="full reports")
    return page


def run(args: argparse.Namespace) -> int:
    """Identify, write the outputs and print the parameters; return 0."""
    from rigval.validation.report.drawing import standby_drawers

    parameters = ("auto" if args.parameters.strip() == "auto"
                  else [p.strip() for p in args.parameters.split(",") if p.strip()])
    comparisons = (None if args.comparisons is None
                   else [c.strip() for c in args.comparisons.split(",") if c.strip()])
    # the drawers, forked before the pipeline's imports, import matplotlib on the core idle
    # meanwhile, draw the nominal run's figures while the parameters are identified, then the
    # identified run's (this process: the data files); they keep the other core busy, so BLAS
    # threads here would only wait
    with standby_drawers() as drawers:
        from rigval.acquisition.threads import single_blas_thread
        from rigval.validation.identify import identify
        from rigval.validation.pipeline import run_scene_kept
        from rigval.validation.report.run_report import (
            start_figures,
            start_model_figures,
            start_sketch,
        )

        with single_blas_thread():
            nominal, measurement = run_scene_kept(
                args.scene, after_assembly=lambda assembly: start_sketch(assembly, drawers),
                after_model=lambda run: start_model_figures(run, drawers))
            nominal_figures = start_figures(nominal, drawers)
            identification = identify(nominal.scene, parameters, friction=args.friction,
                                      comparisons=comparisons, result=nominal)
            write_identification(identification, args.out, measurement, drawers,
                                 nominal_figures)
    stream = sys.stdout
    for name, value, std, nom, unit in zip(identification.names, identification.value,
                                           identification.std, identification.nominal,
                                           identification.units, strict=True):
        print(f"  {name:<18} {value:12.6g} +- {std:.3g} {unit:<12} (nominal {nom:.6g})",
              file=stream)
    for name, why in identification.not_identifiable.items():
        print(f"  {name:<18} not identifiable: {why}", file=stream)
    print(f"condition number {identification.condition_number:.3g}; report: "
          f"{args.out / 'report.html'}", file=stream)
    return 0
