"""``rigval predict MECHANISM --out DIR``: what the model says about drive settings nobody measured.

Exit codes: 0 report written; 2 usage or configuration error (bad drive law, bad sweep option,
unknown mechanism); 3 data or model error (unreadable profile, mechanism that cannot be solved).
"""

from __future__ import annotations

import argparse
import re
import shlex
from pathlib import Path
from typing import Any

from rigval.validation.commands.common import add_command, out_folder

__all__ = ["add_parser", "run"]


_HELP = "predict tip path, torques and support forces for given drive laws (no measurement)"
_DESCRIPTION = ("Run the model over one cycle for an excitation and write a report folder "
                "(report.html, cycle.csv, peaks.csv, prediction.nc; sweep.csv with --sweep).")
_EPILOG = ("Drive laws: NAME=file | NAME=PROFILE.csv | NAME=LAW.toml | NAME='{TOML table}' "
           "with keys frequency (Hz, main drive), ratio, phase (rad), theta0 (rad), "
           "harmonics = [{amplitude, order, phase}], profile, period (s). "
           "Example: --drive 'theta_F={frequency = 1.2}' --drive 'theta_H={phase = 0.3}'; "
           "a number alone is the main drive's speed: --drive theta_F=1.2 (rev/s, or "
           "1.2Hz, 72rpm). --list-drivers shows a mechanism's drivers. "
           "Sweeps: NAME=START:STOP:COUNT[unit] or NAME=V1,V2[unit], e.g. "
           "--sweep frequency=0.5:1.5:10 --sweep theta_H.phase=0:324:10deg.")


def add_parser(subparsers: Any) -> None:
    """Register the ``predict`` subcommand."""
    parser = add_command(subparsers, run, "predict", help=_HELP, description=_DESCRIPTION,
                         epilog=_EPILOG,
                         exit_codes="0 ok, 2 usage or configuration error, 3 data or model error.")
    parser.add_argument("mechanism", metavar="MECHANISM",
                        help="mechanism TOML file, or builtin:NAME (e.g. builtin:pendulum)")
    parser.add_argument("--out", type=out_folder, metavar="DIR",
                        help="report folder (required unless --list-drivers)")
    parser.add_argument("--list-drivers", action="store_true",
                        help="print the mechanism's drivers and their laws from the file, "
                             "then stop")
    parser.add_argument("--speed", type=float, metavar="REV_S",
                        help="speed of the main drive, rev/s (cycles per second); default: the "
                             "file's law. Same as --drive MAIN=REV_S")
    parser.add_argument("--drive", action="append", default=[], metavar="NAME=LAW",
                        help="drive law of one driver (repeatable; default: the file's laws); "
                             "MAIN=1.5 sets the main drive's speed in rev/s")
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


def run(args: argparse.Namespace) -> int:
    """Predict, optionally sweep, write the report and print where it is; return the exit code."""
    import xarray as xr

    from rigval.acquisition.errors import ChannelNotFoundError, ConfigError, DataFileError
    from rigval.model.drive_laws import excitation_from_measured
    from rigval.model.predict import (
        SUMMARIES,
        make_excitation,
        parse_sweep_option,
        predict,
        resolve_mechanism,
        sweep,
    )
    from rigval.validation.report.predict_report import write_predict_report

    if len(args.sweep) > 2:
        raise ConfigError(f"at most two --sweep options, got {len(args.sweep)}",
                          where={"option": "--sweep"}, hint="sweep one or two parameters")
    mechanism = resolve_mechanism(args.mechanism)
    if args.list_drivers:
        _print_drivers(mechanism, args.main)
        return 0
    if args.out is None:
        raise ConfigError("--out DIR is required", where={"option": "--out"},
                          hint="give the report folder, e.g. --out predict-report")
    main_drive = args.main or (mechanism.driver_names[0] if mechanism.driver_names else None)
    if args.measured:
        if args.drive or args.speed is not None:
            raise ConfigError("--measured excludes --drive and --speed",
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
        drives = [_shorthand(text, main_drive) for text in args.drive]
        if args.speed is not None:
            drives.append(_shorthand(f"{main_drive}={args.speed!r}", main_drive))
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
            for text in args.sweep:  # the report shows angles in the unit they were given in
                name = text.partition("=")[0].strip()
                if text.strip().lower().endswith("deg") and name in swept.coords:
                    swept[name].attrs["given_units"] = "deg"
    except ChannelNotFoundError as error:
        available = ", ".join(map(str, error.extra.get("available", [])))
        raise ConfigError(f"{error.message} (available: {available or 'none'})",
                          where=error.where, hint=error.hint) from error
    files = write_predict_report(prediction, args.out, sweep=swept, command=_command_line(args),
                                 mechanism=mechanism)
    tip = prediction.attrs["tip_point"]

    def unit(name: str) -> str:  # the spelling of the files (CF units of prediction.nc)
        return str(prediction[name].attrs.get("units", ""))

    print(f"{tip} vertical range {float(prediction['tip_vertical_range']):.4g} "
          f"{unit('tip_vertical_range')}, peak |a| "
          f"{float(prediction['tip_acceleration_peak']):.4g} {unit('tip_acceleration_peak')}")
    for driver in prediction["driver"].values:
        print(f"{driver}: peak torque {float(prediction['torque_peak'].sel(driver=driver)):.5g} "
              f"{unit('torque_peak')}, rms "
              f"{float(prediction['torque_rms'].sel(driver=driver)):.5g} {unit('torque_rms')}")
    for support in prediction["support"].values:
        peak = prediction["support_force_peak"].sel(support=support, component="magnitude")
        print(f"support {support}: peak force on frame {float(peak):.5g} "
              f"{unit('support_force_peak')}")
    if swept is not None:
        print(f"sweep: {swept.attrs['points']} points, {swept.attrs['model_solves']} model "
              f"solves, {swept.attrs['elapsed_s']:.3g} s")
    print(f"report: {files.html}")
    return 0


#: Speed units of the ``NAME=NUMBER`` shorthand, in rev/s (= Hz) per unit.
_SPEED_UNITS = {"": 1.0, "rev/s": 1.0, "hz": 1.0, "rpm": 1.0 / 60.0}


def _shorthand(text: str, main: str | None) -> str:
    """Turn ``MAIN=1.5`` (rev/s; or ``1.5Hz``, ``90rpm``) into ``MAIN={frequency = 1.5}``.

    Any other drive option is returned unchanged.
    """
    from rigval.acquisition.errors import ConfigError

    name, sep, law = (part.strip() for part in text.partition("="))
    match = re.fullmatch(r"([-+0-9.eE]+)\s*(rev/s|hz|rpm)?", law, flags=re.IGNORECASE)
    if not sep or match is None:
        return text
    try:
        speed = float(match.group(1)) * _SPEED_UNITS[(match.group(2) or "").lower()]
    except ValueError:
        return text  # not a number: the drive-law parser reports it
    if name != main:
        raise ConfigError(f"a number alone sets the speed of the main drive {main}, not of {name}",
                          where={"option": text},
                          hint=f"write {main}={law}, or for {name} a law such as "
                               f"'{name}={{ratio = 1.0, phase = 0.3}}'")
    if not speed > 0:
        raise ConfigError(f"the main drive's speed must be positive, got {speed:g} rev/s",
                          where={"option": text}, hint=f"write e.g. {main}=1.5 (rev/s)")
    return f"{name}={{frequency = {speed!r}}}"


def _print_drivers(mechanism: Any, main: str | None) -> None:
    """Print each driver with its law from the mechanism file (``--list-drivers``)."""
    from rigval.model.predict import file_excitation

    excitation = file_excitation(mechanism, main=main)
    print(f"{len(excitation.names)} drivers; main drive {excitation.main} at "
          f"{excitation.frequency:.6g} rev/s (cycle frequency, Hz)")
    for name, law in excitation.laws:
        role = "main drive" if name == excitation.main else f"ratio {law.ratio:g} to the main"
        print(f"  {name}: {role}, theta0 {law.theta0:.6g} rad, phase {law.phase:.6g} rad, "
              f"{len(law.harmonics)} harmonics")
    print("change them with --speed REV_S or --drive NAME=LAW (rigval predict --help)")


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
    if args.speed is not None:
        words += ["--speed", repr(args.speed)]
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
