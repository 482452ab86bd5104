"""``rigval simulate-rig``: write one run of the virtual test rig (files, truth, scene, note).

The same seed and options give byte-identical files.
"""

from __future__ import annotations

import argparse
from typing import Any

from rigval.validation.commands.common import add_command, add_out_option

__all__ = ["add_parser", "run"]


def add_parser(subparsers: Any) -> None:
    """Register the ``simulate-rig`` subcommand."""
    parser = add_command(
        subparsers, run, "simulate-rig",
        help="write a virtual rig run with known truth",
        description="Run the virtual test rig (a mechanism file, the rig's sensors and DAQ) and "
                    "write the cDAQ and WLS #1 TDMS files, the WLS #2 CSV, the truth, a scene "
                    "that validates the run and the operator's note into a folder.")
    add_out_option(parser)
    parser.add_argument("--speed", type=float, default=1.0, help="main-shaft speed, rev/s")
    parser.add_argument("--duration", type=float, default=20.0, help="record length, s")
    parser.add_argument("--seed", type=int, default=1, help="random seed")
    parser.add_argument("--mechanism", metavar="FILE",
                        help="mechanism file (default: built-in pendulum)")
    parser.add_argument("--index-reset", action="store_true",
                        help="the main-shaft counter (enc1) reloads 0 at every index pulse")
    group = parser.add_argument_group("imperfections (defaults: typical rig)")
    group.add_argument("--ideal", action="store_true",
                       help="no imperfections at all (only ADC quantisation); the options "
                            "below then start from zero")
    group.add_argument("--start-offset", type=float, help="bound of the wireless start offsets, s")
    group.add_argument("--drift-ppm", type=float, help="bound of each clock's drift, ppm")
    group.add_argument("--stamp-error", type=float,
                       help="software start-time error of the wireless carriers, s rms")
    group.add_argument("--host-clock", type=float,
                       help="bound of the WLS #2 laptop's clock offset, s")
    group.add_argument("--dropouts", type=int, help="Wi-Fi dropouts per wireless carrier")
    group.add_argument("--missing-pulses", type=float,
                       help="probability of a missing optical pulse")
    group.add_argument("--spurious-pulses", type=float,
                       help="spurious optical pulses per minute per sensor")
    group.add_argument("--noise", type=float, help="scale of all sensor noise (1 = typical)")
    group.add_argument("--torque-split", type=float,
                       help="bound of |share - 0.5| of each shaft pair's torque")
    group.add_argument("--bridge-drift", type=float,
                       help="scale of bridge zero offsets and thermal drift (1 = typical)")
    group.add_argument("--speed-wander", type=float,
                       help="relative speed wander that makes cycles uneven (0: an exactly "
                            "periodic drive)")
    group.add_argument("--stamp-offset", type=float,
                       help="extra error of WLS #1's start stamps that its scene does not "
                            "declare, s")
    group.add_argument("--running-clock", action="store_const", const=True,
                       help="the wireless clocks run on through each dropout (no restart)")
    group.add_argument("--fast-pulses", action="store_const", const=True,
                       help="1 us optical edges (opt1 on the NI 9215 sample-switched)")
    truths = parser.add_argument_group(
        "departures from the rigid planar model and the scene (default: none; docs/diagnosis.md)")
    truths.add_argument("--mode-body", choices=("A", "B"),
                        help="body with a flexible mode: B rod B (str1, acc2), A the arm (acc1, "
                             "acc2)")
    truths.add_argument("--mode-hz", type=float, help="the mode's natural frequency, Hz (18)")
    truths.add_argument("--mode-damping", type=float, help="the mode's damping ratio (0.02)")
    truths.add_argument("--mode-level", type=float,
                        help="the mode's amplitude (sqrt 2 rms) over its channel's range (0.05)")
    truths.add_argument("--rod-bending", type=float,
                        help="adds gauges str2/str3 on rod B's faces, seeing this times the "
                             "bending of the rod's weight and inertia")
    truths.add_argument("--calibration-error", type=float,
                        help="each sensor's calibration error, drawn from this times the "
                             "scene's stated uncertainties")
    truths.add_argument("--lag", metavar="CHANNEL=SECONDS",
                        help="an undeclared lag of one channel, e.g. tor1=0.002")
    truths.add_argument("--split-main", type=float, help="tor1's share of the main torque")
    truths.add_argument("--split-lift", type=float, help="tor3's share of the lifting torque")
    truths.add_argument("--mass-scale", metavar="BODY=FACTOR", action="append",
                        help="the rig's body mass times FACTOR, the scene's mechanism "
                             "unchanged, e.g. A=1.08 (repeatable)")


#: Command-line option -> Imperfections field.
_OPTIONS = {"start_offset": "start_offset_s", "drift_ppm": "drift_ppm",
            "stamp_error": "stamp_error_s", "host_clock": "host_clock_s", "dropouts": "dropouts",
            "missing_pulses": "missing_pulse_probability",
            "spurious_pulses": "spurious_pulses_per_minute", "noise": "noise",
            "torque_split": "torque_split", "bridge_drift": "bridge_drift",
            "speed_wander": "speed_wander", "stamp_offset": "stamp_offset_s",
            "running_clock": "running_clock", "fast_pulses": "fast_pulses"}


#: Command-line option -> Departures field (plain values).
_DEPARTURES = ("mode_body", "mode_hz", "mode_damping", "mode_level", "rod_bending",
               "calibration_error", "split_main", "split_lift")


def _pair(text: str, option: str) -> tuple[str, float]:
    """Split ``NAME=NUMBER`` of an option, or raise a ConfigError naming the option."""
    from rigval.acquisition.errors import ConfigError

    name, _, value = text.partition("=")
    try:
        return name.strip(), float(value)
    except ValueError:
        raise ConfigError(f"{option} {text!r} is not NAME=NUMBER", where={"key": option},
                          hint=f"e.g. {option} tor1=0.002") from None


def _departures(args: argparse.Namespace) -> Any:
    """Return the Departures the options ask for."""
    from rigval.sample_data.departures import Departures

    values = {name: getattr(args, name) for name in _DEPARTURES if getattr(args, name) is not None}
    if args.lag:
        values["lag_channel"], values["lag_s"] = _pair(args.lag, "--lag")
    if args.mass_scale:
        values["mass_scale"] = tuple(_pair(text, "--mass-scale") for text in args.mass_scale)
    return Departures(**values)


def run(args: argparse.Namespace) -> int:
    """Write the run and print the files written."""
    import dataclasses

    from rigval.sample_data import Imperfections, RigSettings, simulate_rig

    base = Imperfections.none() if args.ideal else Imperfections()
    changes = {field: getattr(args, option) for option, field in _OPTIONS.items()
               if getattr(args, option) is not None}
    settings = RigSettings(speed=args.speed, duration=args.duration, seed=args.seed,
                           imperfections=dataclasses.replace(base, **changes),
                           mechanism=args.mechanism, index_reset=args.index_reset,
                           departures=_departures(args))
    files = simulate_rig(args.out, settings)
    for path in files.files:
        print(path)
    return 0
