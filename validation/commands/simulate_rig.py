"""``rigval simulate-rig``: write one run of the virtual test rig (files, truth, scene, note).

The same seed and options give byte-identical files.
"""

from __future__ import annotations

import argparse
from collections.abc import Iterable, Mapping
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
    _add_options(group, {option: (kind, text) for option, (_, kind, text)
                         in _IMPERFECTIONS.items()})
    truths = parser.add_argument_group(
        "departures from the rigid planar model and the scene (default: none; docs/diagnosis.md)")
    truths.add_argument("--mode-body", choices=("A", "B"),
                        help="body with a flexible mode: B rod B (str1, acc2), A the arm (acc1, "
                             "acc2)")
    _add_options(truths, _DEPARTURES)
    truths.add_argument("--lag", metavar="CHANNEL=SECONDS",
                        help="an undeclared lag of one channel, e.g. tor1=0.002")
    truths.add_argument("--mass-scale", metavar="BODY=FACTOR", action="append",
                        help="the rig's body mass times FACTOR, the scene's mechanism "
                             "unchanged, e.g. A=1.08 (repeatable)")


#: Imperfection option -> (Imperfections field, value type or None for a flag, help).
_IMPERFECTIONS: dict[str, tuple[str, type | None, str]] = {
    "start-offset": ("start_offset_s", float, "bound of the wireless start offsets, s"),
    "drift-ppm": ("drift_ppm", float, "bound of each clock's drift, ppm"),
    "stamp-error": ("stamp_error_s", float,
                    "software start-time error of the wireless carriers, s rms"),
    "host-clock": ("host_clock_s", float, "bound of the WLS #2 laptop's clock offset, s"),
    "dropouts": ("dropouts", int, "Wi-Fi dropouts per wireless carrier"),
    "missing-pulses": ("missing_pulse_probability", float,
                       "probability of a missing optical pulse"),
    "spurious-pulses": ("spurious_pulses_per_minute", float,
                        "spurious optical pulses per minute per sensor"),
    "torque-split": ("torque_split", float, "bound of |share - 0.5| of each shaft pair's torque"),
    "bridge-drift": ("bridge_drift", float,
                     "scale of bridge zero offsets and thermal drift (1 = typical)"),
    "noise": ("noise", float, "scale of all sensor noise (1 = typical)"),
    "speed-wander": ("speed_wander", float,
                     "relative speed wander that makes cycles uneven (0: an exactly periodic "
                     "drive)"),
    "stamp-offset": ("stamp_offset_s", float,
                     "extra error of WLS #1's start stamps that its scene does not declare, s"),
    "running-clock": ("running_clock", None,
                      "the wireless clocks run on through each dropout (no restart)"),
    "fast-pulses": ("fast_pulses", None,
                    "1 us optical edges (opt1 on the NI 9215 sample-switched)"),
}

#: Departure option with a plain value (its Departures field: the option's words joined by
#: ``_``) -> (value type, help).
_DEPARTURES: dict[str, tuple[type, str]] = {
    "mode-hz": (float, "the mode's natural frequency, Hz (18)"),
    "mode-damping": (float, "the mode's damping ratio (0.02)"),
    "mode-level": (float, "the mode's amplitude (sqrt 2 rms) over its channel's range (0.05)"),
    "rod-bending": (float, "adds gauges str2/str3 on rod B's faces, seeing this times the "
                           "bending of the rod's weight and inertia"),
    "calibration-error": (float, "each sensor's calibration error, drawn from this times the "
                                 "scene's stated uncertainties"),
    "split-main": (float, "tor1's share of the main torque"),
    "split-lift": (float, "tor3's share of the lifting torque"),
}


def _add_options(group: Any, options: Mapping[str, tuple[type | None, str]]) -> None:
    """Add optional ``--OPTION`` arguments, absent (None) unless given.

    Parameters
    ----------
    group : argparse argument group
        Where they go.
    options : mapping of str to (type or None, str)
        Option without its dashes -> (the value's type, None for a flag that stores True; the
        help line).
    """
    for option, (kind, text) in options.items():
        if kind is None:
            group.add_argument(f"--{option}", action="store_const", const=True, help=text)
        else:
            group.add_argument(f"--{option}", type=kind, help=text)


def _given(args: argparse.Namespace, options: Iterable[str]) -> dict[str, Any]:
    """Return option (without its dashes) -> value, of the ``options`` given (not None)."""
    values = {option: getattr(args, option.replace("-", "_")) for option in options}
    return {option: value for option, value in values.items() if value is not None}


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

    values = {option.replace("-", "_"): value
              for option, value in _given(args, ("mode-body", *_DEPARTURES)).items()}
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
    changes = {_IMPERFECTIONS[option][0]: value
               for option, value in _given(args, _IMPERFECTIONS).items()}
    settings = RigSettings(speed=args.speed, duration=args.duration, seed=args.seed,
                           imperfections=dataclasses.replace(base, **changes),
                           mechanism=args.mechanism, index_reset=args.index_reset,
                           departures=_departures(args))
    files = simulate_rig(args.out, settings)
    for path in files.files:
        print(path)
    return 0
