"""Time cells and header start times of a delimited text file, parsed into UTC.

Absolute time cells (ISO 8601, or local date-times such as ``9/5/2014 11:53:14 AM`` and
``21.11.2026 06:00:00,125``) and start times found in the lines above a table's names row, for
:func:`rigval.acquisition.text_csv.read_csv`.
"""

from __future__ import annotations

import re
import zoneinfo
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from rigval.acquisition.errors import ConfigError, DataFileError
from rigval.acquisition.time_fallbacks import LOCAL_TIME_AS_UTC, TimeFallback

__all__ = ["header_start", "parse_datetimes"]

_START_KEYS = re.compile(r"(start|t0|wf_start_time|beginn|trigger)", re.IGNORECASE)
_LOCALE_FORMATS = ("%d.%m.%Y %H:%M:%S.%f", "%d.%m.%Y %H:%M:%S", "%m/%d/%Y %I:%M:%S.%f %p",
                   "%m/%d/%Y %I:%M:%S %p", "%m/%d/%Y %H:%M:%S.%f", "%m/%d/%Y %H:%M:%S",
                   "%Y/%m/%d %H:%M:%S.%f", "%Y/%m/%d %H:%M:%S", "%d/%m/%Y %H:%M:%S.%f",
                   "%d/%m/%Y %H:%M:%S")


def parse_datetimes(cells: Sequence[str], time_format: str | None, timezone: str | None,
                    where: Mapping[str, Any], notes: list[TimeFallback] | None = None
                    ) -> np.ndarray:
    """Parse absolute time cells into naive UTC datetime64[ns].

    Cells without a UTC offset are local times in ``timezone`` (a DST fall-back inside a column
    is resolved from the order of the cells); without ``timezone`` they are taken as UTC, noted
    in ``notes``.
    """
    texts = pd.Series([c.strip() for c in cells])
    if time_format is None and texts.str.match(r"^\d{4}-\d{2}-\d{2}[T ]").all():
        stamps = pd.to_datetime(texts.str.replace(",", ".", regex=False), format="ISO8601")
    else:
        stamps = None
        for fmt in ([time_format] if time_format else list(_LOCALE_FORMATS)):
            try:
                stamps = pd.to_datetime(texts.str.replace(",", ".", regex=False)
                                        if fmt.endswith("%f") or "%f " in fmt else texts,
                                        format=fmt)
                break
            except (ValueError, TypeError):
                continue
        if stamps is None:
            raise DataFileError(f"cannot parse time cells like {texts.iloc[0]!r}", where=where,
                                hint="pass time_format=... (strftime codes)")
    if getattr(stamps.dt, "tz", None) is not None:
        stamps = stamps.dt.tz_convert("UTC").dt.tz_localize(None)
    elif timezone:
        try:
            zone = zoneinfo.ZoneInfo(timezone)
        except (zoneinfo.ZoneInfoNotFoundError, ValueError):
            raise ConfigError(f"unknown time zone {timezone!r}",
                              where={**where, "key": "timezone"},
                              hint="use an IANA name like 'Europe/Berlin'") from None
        try:
            stamps = stamps.dt.tz_localize(
                zone, ambiguous="infer" if len(stamps) > 1 else "raise", nonexistent="raise")
        except ValueError as error:  # pandas' AmbiguousTimeError / NonExistentTimeError
            raise DataFileError(f"local times do not map to UTC in {timezone}: {error}",
                                where=where, hint="check the time zone and the DST change"
                                ) from None
        stamps = stamps.dt.tz_convert("UTC").dt.tz_localize(None)
    elif notes is not None:
        notes.append(TimeFallback("local date-times without a zone", LOCAL_TIME_AS_UTC))
    return stamps.to_numpy().astype("datetime64[ns]")


def header_start(header: Mapping[str, str], time_format: str | None, timezone: str | None,
                  where: Mapping[str, Any], notes: list[TimeFallback]) -> np.datetime64 | None:
    """Return a start time found in the header block, or None."""
    candidates = [v for k, v in header.items() if _START_KEYS.search(k) and v]
    date = next((v for k, v in header.items() if k.lower() in ("date", "datum")), None)
    clock = next((v for k, v in header.items() if k.lower() in ("time", "zeit", "uhrzeit")), None)
    if date and clock:
        candidates.append(f"{date.replace('/', '-')}T{clock.replace(',', '.')}"
                          if re.match(r"^\d{4}[/-]", date) else f"{date} {clock}")
    for text in candidates:
        try:
            return parse_datetimes([text], time_format, timezone, where, notes)[0]
        except ConfigError:
            raise
        except (DataFileError, ValueError):
            continue
    return None
