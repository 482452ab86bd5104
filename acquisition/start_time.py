"""How a stream's start time is shown: in UTC, in its reader's zone, or as a local time.

A stream's ``start_time`` attribute is always UTC (ISO 8601 with ``Z``, docs/formats.md). LVM
and CSV files hold the writing PC's local time without a zone; read without a ``timezone``
option, that local time is *taken as* UTC and the reader says so in its time fallbacks
(:func:`rigval.acquisition.time_fallbacks.taken_as_utc`). Showing such a time with a ``Z``
makes two devices of one run look an hour or more apart, so :func:`start_time_text` shows it
as what it is. Standard library only: ``rigval info`` imports
this before any data is read.
"""

from __future__ import annotations

import datetime as dt
import zoneinfo

__all__ = ["start_time_text"]


def start_time_text(start_time: str, *, zone_unknown: bool = False,
                    timezone: str | None = None) -> str:
    """Return a start time as a person should read it.

    Parameters
    ----------
    start_time : str
        The stream's ``start_time`` attribute, ISO 8601 UTC (``2026-03-11T09:07:23.506000000Z``).
    zone_unknown : bool
        The reader took a local time without a zone as UTC (:func:`taken_as_utc`).
    timezone : str, optional
        The IANA zone the reader was given (``Europe/Berlin``): the time is shown in it.

    Returns
    -------
    str
        ``2026-03-11 09:07:23.506 local time, zone unknown`` for a local time taken as UTC;
        ``2026-03-11T09:07:23.506000+01:00 (Europe/Berlin)`` with a zone; else ``start_time``.
    """
    if not start_time.endswith("Z"):
        return start_time
    if zone_unknown:
        day, _, clock = start_time[:-1].partition("T")
        whole, _, fraction = clock.partition(".")
        fraction = fraction.rstrip("0")
        return f"{day} {whole}{'.' + fraction if fraction else ''} local time, zone unknown"
    if timezone:
        head, _, fraction = start_time[:-1].partition(".")
        moment = dt.datetime.fromisoformat(f"{head}.{(fraction + '000000')[:6]}+00:00")
        return f"{moment.astimezone(zoneinfo.ZoneInfo(timezone)).isoformat()} ({timezone})"
    return start_time
