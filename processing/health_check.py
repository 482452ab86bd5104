"""Sensor health of a whole stream: every check each channel's kind calls for.

:func:`stream_health` runs :func:`~rigval.processing.health.analog_health` on analog channels,
:func:`~rigval.processing.health_events.counter_health` on counters and
:func:`~rigval.processing.health_events.pulse_health` on pulse channels; the zero drift is judged
over whole revolutions of the stream's pulse channel (docs/processing.md, "Sensor health").
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from typing import Literal

import numpy as np
import xarray as xr

from rigval.acquisition.errors import DataError
from rigval.acquisition.sample_times import sample_times
from rigval.processing.health import Finding, analog_health, channel_range
from rigval.processing.health_events import counter_health, pulse_health
from rigval.processing.pulses import detect_edges

__all__ = ["ChannelKind", "period_samples", "stream_health"]

logger = logging.getLogger(__name__)

#: What a channel is, for the checks: an analog signal, a counter or a pulse channel.
ChannelKind = Literal["analog", "counter", "pulse"]


def period_samples(stream: xr.Dataset, pulse: str) -> float | None:
    """Return the samples per revolution from a pulse channel's median rising-edge interval.

    None when the channel has fewer than 3 edges or no two levels.
    """
    try:
        rises = detect_edges(stream[pulse].to_numpy(), sample_times(stream),
                             valid=stream["valid"].to_numpy(),
                             segment=stream["segment"].to_numpy())
    except DataError as error:  # no two levels: no pulses, no drift check
        logger.info("no revolution period from %s: %s", pulse, error)
        return None
    fs = float(stream.attrs["fs_nominal"])
    return float(np.median(np.diff(rises))) * fs if rises.size > 2 else None


def stream_health(stream: xr.Dataset, kinds: Mapping[str, ChannelKind], *, name: str = "",
                  modules: Mapping[str, str] | None = None,
                  counts_per_rev: Mapping[str, float] | None = None,
                  period: float | None = None) -> list[Finding]:
    """Return the health findings of the named channels of one stream.

    Parameters
    ----------
    stream : xarray.Dataset
        A stream as read (file units; ``valid`` and ``segment`` variables).
    kinds : mapping of str to {"analog", "counter", "pulse"}
        The channels to check and what each is.
    name : str, optional
        Stream name: findings name their channel ``"<name>.<channel>"`` (just the channel
        when empty).
    modules : mapping of str to str, optional
        Module of each channel (its input range, when its attributes give none).
    counts_per_rev : mapping of str to float, optional
        Counts per revolution of each counter.
    period : float, optional
        Samples per revolution for the zero-drift check (default: from the first pulse channel
        of ``kinds``, :func:`period_samples`; no drift check without either).

    Returns
    -------
    list of Finding
        Findings in the order of ``kinds``.
    """
    fs = float(stream.attrs["fs_nominal"])
    time = sample_times(stream)  # looked up at a few samples, never made whole
    valid = stream["valid"].to_numpy()
    segment = stream["segment"].to_numpy()
    pulse = next((c for c, k in kinds.items() if k == "pulse" and c in stream), None)
    if period is None and pulse is not None:
        period = period_samples(stream, pulse)
    findings: list[Finding] = []
    for channel, kind in kinds.items():
        if channel not in stream:
            continue
        label = f"{name}.{channel}" if name else channel
        values = stream[channel].to_numpy()
        if kind == "counter":
            findings += counter_health(values, time, channel=label, valid=valid,
                                       counts_per_rev=(counts_per_rev or {}).get(channel))
        elif kind == "pulse":
            findings += pulse_health(values, time, channel=label, valid=valid, segment=segment)
        else:
            attrs = stream[channel].attrs
            findings += analog_health(
                values, time, channel=label, fs=fs, valid=valid, segment=segment,
                unit=str(attrs.get("units", "")),
                limits=channel_range(attrs, (modules or {}).get(channel)),
                period_samples=period)
    for found in findings:
        logger.info("health: %s", found.line())
    return findings
