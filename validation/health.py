"""Sensor health of a scene's channels, and what it says about each comparison.

:func:`scene_health` reads each mapped channel of each stream once more, as recorded (file
units), and runs the checks of :mod:`rigval.processing.health_check` on it: TDMS channels one
at a time with their stream's pulse channel (the revolutions of the zero-drift check), text
files whole. :func:`comparison_health` picks the findings of a comparison's channels; their
lines go on the comparison's verdict line (``"wls1.tor2: 3.1 % of samples clipped at 2e-05 V/V
...; not trusted"``), into ``alignment.json`` and the netCDF file (docs/processing.md,
"Sensor health").
"""

from __future__ import annotations

import dataclasses
import json
import logging
from types import MappingProxyType

from rigval.acquisition.channel_map import StreamSpec, load_stream
from rigval.processing.health import Finding
from rigval.processing.health_check import ChannelKind, stream_health
from rigval.validation.scene_types import ComparisonSpec, Scene

__all__ = ["comparison_health", "health_json", "scene_health"]

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


def health_json(findings: tuple[Finding, ...]) -> str:
    """Return the findings as one JSON text (a netCDF attribute)."""
    return json.dumps([f.record() for f in findings])
