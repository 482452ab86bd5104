"""Sensor health of a scene's channels, and what it says about each comparison.

:func:`scene_health` reads each mapped channel of each stream once more, as recorded (file
units), and runs the checks of :mod:`rigval.processing.health_check` on it: TDMS channels one
at a time with their stream's pulse channel (the revolutions of the zero-drift check), text
files whole. :func:`comparison_health` picks the findings of a comparison's channels; their
lines go on the comparison's verdict line (``"wls1.tor2: 3.1 % of samples clipped at 2e-05 V/V
...; not trusted"``), into ``alignment.json`` and the netCDF group ``/health``
(docs/processing.md, "Sensor health").
"""

from __future__ import annotations

import dataclasses
import logging
from types import MappingProxyType

import numpy as np
import xarray as xr

from rigval.acquisition.channel_map import StreamSpec, load_stream
from rigval.processing.health import Finding
from rigval.processing.health_check import ChannelKind, stream_health
from rigval.validation.scene_types import ComparisonSpec, Scene

__all__ = ["comparison_health", "health_dataset", "scene_health"]

logger = logging.getLogger(__name__)


def _kind(sensor: str) -> ChannelKind:
    if sensor == "encoder":
        return "counter"
    if sensor == "reference_pulse":
        return "pulse"
    return "analog"


def _part(spec: StreamSpec, names: list[str]) -> StreamSpec:
    return dataclasses.replace(spec, channels=MappingProxyType(
        {name: channel for name, channel in spec.channels.items() if name in names}))


def scene_health(scene: Scene) -> tuple[Finding, ...]:
    """Return the health findings of every mapped channel of the scene's streams.

    Parameters
    ----------
    scene : Scene
        The scene.

    Returns
    -------
    tuple of Finding
        Channels named ``"<stream>.<channel>"``.
    """
    findings: list[Finding] = []
    for name, spec in scene.streams.items():
        kinds = {ch: _kind(c.sensor) for ch, c in spec.channels.items()}
        modules = {ch: c.module for ch, c in spec.channels.items() if c.module}
        cpr = {ch: float(c.params["counts_per_rev"]) for ch, c in spec.channels.items()
               if "counts_per_rev" in c.params}
        pulse = next((ch for ch, kind in kinds.items() if kind == "pulse"), None)
        groups = ([list(kinds)] if spec.file.suffix.lower() != ".tdms"
                  else [[ch] if pulse in (None, ch) else [ch, pulse] for ch in kinds])
        for names in groups:
            stream = load_stream(_part(spec, names), checksum=False)
            checked = {ch: kinds[ch] for ch in names if ch == names[0] or len(groups) == 1}
            findings += stream_health(stream, checked, name=name, modules=modules,
                                      counts_per_rev=cpr, period_channel=pulse)
    return tuple(findings)


def comparison_health(comparison: ComparisonSpec, findings: tuple[Finding, ...]
                      ) -> tuple[Finding, ...]:
    """Return the findings on the channels a comparison measures."""
    channels = {f"{ref.stream}.{ref.channel}" for _, ref in comparison.terms}
    return tuple(f for f in findings if f.channel in channels)


def health_dataset(findings: tuple[Finding, ...]) -> xr.Dataset:
    """Return the findings as a Dataset along ``finding`` (the netCDF group ``/health``).

    Variables ``channel``, ``fault``, ``text`` (str), ``samples``, ``first_sample``,
    ``last_sample`` (int64), ``first_s``, ``last_s``, ``value`` (float64) and ``trusted``
    (int8: 1 when the finding cannot change a verdict); empty along ``finding`` when the
    channels are healthy.
    """
    def column(name: str, dtype: str) -> np.ndarray:
        return np.array([getattr(f, name) for f in findings], dtype=dtype)

    data = {name: ("finding", column(name, "str" if name in ("channel", "fault", "text")
                                     else "int64"))
            for name in ("channel", "fault", "text", "samples", "first_sample", "last_sample")}
    data.update({name: ("finding", column(name, "float64"), {"units": "s"} if name != "value"
                        else {}) for name in ("first_s", "last_s", "value")})
    data["trusted"] = ("finding", np.array([f.trusted for f in findings], dtype=np.int8))
    return xr.Dataset(data, attrs={"description": "sensor health findings "
                                                  "(docs/processing.md, Sensor health)"})
