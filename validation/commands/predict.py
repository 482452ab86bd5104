"""``rigval predict MECHANISM --out DIR``: what the model says about drive settings nobody measured.

Exit codes: 0 report written; 2 usage or configuration error (bad drive law, bad sweep option,
unknown mechanism); 3 data or model error (unreadable profile, mechanism that cannot be solved).
"""

from __future__ import annotations

import argparse
import shlex
from pathlib import Path
from typing import Any

__all__ = ["add_parser", "run"]


def add_parser(subparsers: Any) -> None:
    """Register the ``predict`` subcommand."""
    parser = subparsers.add_parser(
        "predict",
        help="predict tip path, torques and support forces for given drive laws (no measurement)",
        description="Run the model over one cycle for an excitation and write a report folder "
                    "(report.html, cycle.csv, peaks.csv, prediction.nc; sweep.csv with --sweep).",
        epilog="Drive laws: NAME=file | NAME=PROFILE.csv | NAME=LAW.toml | NAME='{TOML table}' "
               "with keys frequency (Hz, main drive), ratio, phase (rad), theta0 (rad), "
               "harmonics = [{amplitude, order, phase}], profile, period (s). "
               "Example: --drive 'theta_F={frequency = 1.2}' --drive 'theta_H={phase = 0.3}'. "
               "Sweeps: NAME=START:STOP:COUNT[unit] or NAME=V1,V2[unit], e.g. "
               "--sweep frequency=0.5:1.5:10 --sweep theta_H.phase=0:324:10deg. "
               "Exit codes: 0 ok, 2 usage or configuration error, 3 data or model error.",
    )
    parser.add_argument("mechanism", metavar="MECHANISM",
                        help="mechanism TOML file, or builtin:NAME (e.g. builtin:pendulum)")
    parser.add_argument("--out", required=True, metavar="DIR", help="report folder")
    parser.add_argument("--drive", action="append", default=[], metavar="NAME=LAW",
                        help="drive law of one driver (repeatable; default: the file's laws)")
    parser.add_argument("--measured", metavar="FILE.nc",
                        help="netCDF of drive angles identified from a measured run (variables "
                             "named as the drivers, dim time); replaces the file's laws")
    parser.add_argument("--measured-offset", action="append", default=[], metavar="NAME=RAD",
                        help="angle added to a measured drive angle to give the driven body's "
                             "absolute angle (encoders count from where they started)")
    parser.add_argument("--sweep", action="append", default=[], metavar="NAME=VALUES",
                        help="sweep one parameter (give at most two)")
    parser.add_argument("--summary", metavar="NAMES",
                        help="comma-separated sweep summaries (default: all of tip_vertical_range,"
                             " tip_acceleration_peak, support_force_peak, torque_peak, "
                             "torque_rms)")
    parser.add_argument("--points", type=int, default=360, metavar="N",
                        help="grid points per cycle of the prediction (default 360)")
    parser.add_argument("--sweep-points", type=int, default=180, metavar="N",
                        help="grid points per cycle of each sweep point (default 180)")
    parser.add_argument("--tip", help="the tip point (default: the mechanism's point farthest "
                                      "from its ground pins, P1 for the pendulum)")
    parser.add_argument("--joint", action="append", default=[], metavar="JOINT",
                        help="also report the force of this joint (repeatable)")
    parser.add_argument("--main", metavar="DRIVER",
                        help="main drive, the cycle's reference (default: the first driver)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Predict, optionally sweep, write the report and print where it is; return the exit code."""
    import xarray as xr

    from rigval.acquisition.errors import ChannelNotFoundError, ConfigError, DataFileError
    from rigval.validation.drive_laws import excitation_from_measured
    from rigval.validation.predict import (
        SUMMARIES,
        make_excitation,
        parse_sweep_option,
        predict,
        resolve_mechanism,
        sweep,
    )
    from rigval.validation.predict_report import write_predict_report

    if len(args.sweep) > 2:
        raise ConfigError(f"at most two --sweep options, got {len(args.sweep)}",
                          where={"option": "--sweep"}, hint="sweep one or two parameters")
    mechanism = resolve_mechanism(args.mechanism)
    if args.measured:
        if args.drive:
            raise ConfigError("--measured and --drive exclude each other",
                              where={"option": "--measured"}, hint="give one of them")
        try:
            measured = xr.load_dataset(args.measured)
        except (OSError, ValueError) as error:
            raise DataFileError(f"cannot read the measured excitation: {error}",
                                where={"file": args.measured},
                                hint="give a netCDF file with the drive angles") from None
        drives: Any = excitation_from_measured(measured, mechanism.driver_names, main=args.main,
                                               offsets=_offsets(args.measured_offset))
    else:
        drives = list(args.drive)
    try:  # a name that does not exist in the mechanism is a usage error here (exit 2)
        excitation = make_excitation(mechanism, drives, main=args.main, base_dir=Path.cwd())
        prediction = predict(mechanism, excitation, n_points=args.points, tip=args.tip,
                             joints=args.joint)
        swept = None
        if args.sweep:
            summary = tuple(SUMMARIES) if args.summary is None else tuple(
                s.strip() for s in args.summary.split(",") if s.strip())
            parameters = dict(parse_sweep_option(text) for text in args.sweep)
            swept = sweep(mechanism, parameters, drives=excitation, summary=summary,
                          n_points=args.sweep_points, tip=args.tip)
    except ChannelNotFoundError as error:
        available = ", ".join(map(str, error.extra.get("available", [])))
        raise ConfigError(f"{error.message} (available: {available or 'none'})",
                          where=error.where, hint=error.hint) from error
    files = write_predict_report(prediction, args.out, sweep=swept, command=_command_line(args))
    tip = prediction.attrs["tip_point"]
    print(f"{tip} vertical range {float(prediction['tip_vertical_range']):.4g} m, "
          f"peak |a| {float(prediction['tip_acceleration_peak']):.4g} m/s2")
    for driver in prediction["driver"].values:
        print(f"{driver}: peak torque {float(prediction['torque_peak'].sel(driver=driver)):.5g} "
              f"N m, rms {float(prediction['torque_rms'].sel(driver=driver)):.5g} N m")
    for support in prediction["support"].values:
        peak = prediction["support_force_peak"].sel(support=support, component="magnitude")
        print(f"support {support}: peak force on frame {float(peak):.5g} N")
    if swept is not None:
        print(f"sweep: {swept.attrs['points']} points, {swept.attrs['model_solves']} model "
              f"solves, {swept.attrs['elapsed_s']:.3g} s")
    print(f"report: {files.html}")
    return 0


def _offsets(options: list[str]) -> dict[str, float]:
    """Parse ``NAME=RAD`` measured-angle offsets."""
    from rigval.acquisition.errors import ConfigError

    offsets = {}
    for text in options:
        name, _, value = text.partition("=")
        try:
            offsets[name.strip()] = float(value)
        except ValueError:
            raise ConfigError(f"cannot read the offset {text!r}", where={"option": text},
                              hint="write NAME=RAD, e.g. theta_F=1.4613") from None
    return offsets


def _command_line(args: argparse.Namespace) -> str:
    """Return the command line that reproduces this prediction (for the report page)."""
    words = ["rigval", "predict", args.mechanism, "--out", args.out]
    for option, values in (("--drive", args.drive), ("--sweep", args.sweep),
                           ("--joint", args.joint), ("--measured-offset", args.measured_offset)):
        for value in values:
            words += [option, value]
    for option, value in (("--measured", args.measured), ("--summary", args.summary),
                          ("--main", args.main)):
        if value is not None:
            words += [option, value]
    words += ["--points", str(args.points), "--sweep-points", str(args.sweep_points)]
    if args.tip is not None:
        words += ["--tip", args.tip]
    return " ".join(shlex.quote(str(word)) for word in words)
