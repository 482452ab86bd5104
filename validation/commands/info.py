"""``rigval info FILE...``: what a data file holds, read from its metadata where possible.

For each file: format, streams (group, rate, samples, duration, start time), channels (samples,
units, start offsets), gaps, time-axis fallbacks, and any damage found. A file that cannot be read
is reported with its reason and the command goes on with the next one; the exit code is then 3.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from rigval.validation.commands.common import add_command, input_file

__all__ = ["add_parser", "run"]


def add_parser(subparsers: Any) -> None:
    """Register the ``info`` subcommand."""
    parser = add_command(
        subparsers, run, "info",
        help="describe TDMS, LVM and CSV files (streams, channels, rates, gaps)",
        description="Describe data files: groups, channels, rates, lengths, units, start times "
                    "and gaps. TDMS files are described from their metadata only.")
    parser.add_argument("files", nargs="+", type=input_file, metavar="FILE", help="data files")
    parser.add_argument("--json", action="store_true", help="print one JSON document")
    parser.add_argument("--all-groups", action="store_true",
                        help="include SignalExpress decimated groups")
    parser.add_argument("--timezone", metavar="ZONE",
                        help="time zone of local date-times in LVM and CSV files (IANA name, "
                             "e.g. Europe/Berlin); default: taken as UTC, with a note")


def _print_text(info: dict[str, Any], timezone: str | None) -> None:
    """Print one file's description as indented text (start times as :func:`start_time_text`)."""
    from rigval.acquisition.start_time import start_time_text
    from rigval.acquisition.time_fallbacks import TimeFallback, taken_as_utc

    head = f"{info['file']}: {info['format'].upper()}, {info['bytes']} bytes"
    if info["format"] == "tdms":
        head += (f", {info['segments']} segments, version {info['tdms_version']}"
                 + (", big-endian" if info["big_endian"] else "")
                 + (", DAQmx raw data" if info["daqmx_raw"] else ""))
    print(head)
    if info.get("problem"):
        print(f"  problem: {info['problem']}")
    for group in info.get("skipped_groups", []):
        print(f"  skipped group (decimated): {group}")
    for stream in info["streams"]:
        fallbacks = [TimeFallback(**record) for record in stream["time_fallbacks"]]
        start = start_time_text(stream["start_time"], timezone=timezone,
                                zone_unknown=taken_as_utc(fallbacks))
        print(f"  stream {stream['name']!r}: {stream['fs_hz']:.9g} Hz, {stream['samples']} "
              f"samples, {stream['duration_s']:.6g} s, start {start}")
        for gap in stream["gaps"]:
            print(f"    gap after {gap['after_s']:.6f} s: {gap['duration_s']:.6g} s, "
                  f"{gap['missing_samples']} samples missing")
        for fallback in fallbacks:
            print(f"    time: {fallback.text()}")
        for channel in stream["channels"]:
            line = (f"    {channel['name']!r}: {channel['samples']} samples, "
                    f"units {channel['units'] or '-'!r}")
            if channel.get("expected_samples", channel["samples"]) != channel["samples"]:
                line += f" (file announces {channel['expected_samples']})"
            if channel.get("time_offset_s"):
                line += f", starts {channel['time_offset_s']:.6g} s after the stream"
            if channel.get("empty_cells"):
                line += f", {channel['empty_cells']} empty cells"
            print(line)
    for warning in info["warnings"]:
        print(f"  warning: {warning}")


def _reader_options(path: str, timezone: str | None) -> dict[str, Any]:
    """Return the reader options of one file: the time zone for the text formats."""
    from rigval.acquisition.detect import detect_format
    from rigval.acquisition.errors import RigvalError

    if timezone is None:
        return {}
    try:
        kind = detect_format(path)
    except RigvalError:  # describe() reports the file's problem
        return {}
    return {"timezone": timezone} if kind in ("lvm", "csv") else {}


def run(args: argparse.Namespace) -> int:
    """Describe each file; return 0, or 3 if any file could not be read.

    A missing file ends the command with code 2 before any file is read (:func:`input_file`).
    """
    from rigval.acquisition.errors import RigvalError
    from rigval.acquisition.summary import describe

    results: list[dict[str, Any]] = []
    status = 0
    for path in args.files:
        try:
            info = describe(path, include_decimated=args.all_groups,
                            **_reader_options(path, args.timezone))
        except RigvalError as error:
            print(f"rigval: {path}: {error}", file=sys.stderr)
            status = 3
            continue
        except Exception as error:  # never a traceback for a damaged file
            print(f"rigval: {path}: cannot describe the file ({type(error).__name__}: {error})",
                  file=sys.stderr)
            status = 3
            continue
        results.append(info)
        if not args.json:
            _print_text(info, args.timezone)
    if args.json:
        print(json.dumps(results, indent=2, default=str))
    return status
