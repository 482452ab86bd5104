"""The fallbacks a reader applied to a stream's time axis, as typed records.

A reader that cannot take a stream's time as the file gives it (no ``wf_start_offset``, an
interval rounded in the file, local date-times without a zone, ...) uses a fallback and records
it as a :class:`TimeFallback`: why, what it used instead, and for which channel.

A stream Dataset holds its records as three string-array attributes of one entry per record,
``time_fallback_reason``, ``time_fallback_used`` and ``time_fallback_channel``, so that, like
every stream attribute, they survive ``to_netcdf`` and ``open_datatree`` as data
(docs/formats.md). :func:`time_fallback_attrs` writes them and :func:`time_fallbacks` reads them
back: the one place where records and attributes meet. Standard library only: ``rigval info``
imports this before any data is read.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import astuple, dataclass, fields
from typing import Any

from rigval.acquisition.errors import DataError
from rigval.acquisition.stream_attrs import attr_list

__all__ = ["LOCAL_TIME_AS_UTC", "TimeFallback", "taken_as_utc", "time_fallback_attrs",
           "time_fallbacks"]

#: What the LVM and CSV readers use for local date-times without a zone, read without the
#: ``timezone`` option.
LOCAL_TIME_AS_UTC = "taken as UTC (pass timezone=...)"


@dataclass(frozen=True, order=True)
class TimeFallback:
    """One fallback applied to a stream's time axis.

    Attributes
    ----------
    reason : str
        What the file lacks or says (``"no wf_start_offset"``).
    used : str
        What rigval used instead (``"taken as 0 s"``).
    channel : str
        The channel whose time it concerns; ``""`` for every channel of the stream.
    """

    reason: str
    used: str
    channel: str = ""

    def text(self) -> str:
        """Return the fallback as one line (``"no wf_start_offset: taken as 0 s"``)."""
        where = f"channel {self.channel!r}: " if self.channel else ""
        return f"{where}{self.reason}: {self.used}"


_PARTS = tuple(f.name for f in fields(TimeFallback))


def taken_as_utc(fallbacks: Iterable[TimeFallback]) -> bool:
    """Return whether a reader took local date-times without a zone as UTC."""
    return any(f.used == LOCAL_TIME_AS_UTC for f in fallbacks)


def time_fallback_attrs(fallbacks: Iterable[TimeFallback]) -> dict[str, list[str]]:
    """Return a stream's fallbacks, each once and sorted, as netCDF-storable attributes.

    Parameters
    ----------
    fallbacks : iterable of TimeFallback
        As the reader met them (repeats are kept once).

    Returns
    -------
    dict
        ``time_fallback_reason``, ``time_fallback_used``, ``time_fallback_channel``: lists of
        str, one entry per fallback (empty lists when none).
    """
    rows = [astuple(f) for f in sorted(set(fallbacks))]
    return {f"time_fallback_{part}": [row[k] for row in rows] for k, part in enumerate(_PARTS)}


def time_fallbacks(attrs: Mapping[str, Any]) -> tuple[TimeFallback, ...]:
    """Return the fallbacks stored by :func:`time_fallback_attrs` (empty when absent).

    Parameters
    ----------
    attrs : mapping
        Attributes of a stream (``ds.attrs``), in memory or read back from netCDF (which
        returns a one-entry array as a plain string).

    Raises
    ------
    DataError
        When the three attributes differ in length (a file edited by hand).
    """
    columns = [[str(entry) for entry in attr_list(attrs, f"time_fallback_{part}")]
               for part in _PARTS]
    lengths = {part: len(column) for part, column in zip(_PARTS, columns, strict=True)}
    if len(set(lengths.values())) > 1:
        raise DataError(f"the time_fallback attributes differ in length: {lengths}",
                        where={"attribute": "time_fallback_reason"},
                        hint="each of the three attributes lists one entry per fallback")
    return tuple(TimeFallback(*row) for row in zip(*columns, strict=True))


