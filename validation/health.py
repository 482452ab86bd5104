"""Sensor health of a scene's channels, and what it says about each comparison.

:class:`HealthLog` checks each channel when the read plan reads it (as recorded, file units;
:mod:`rigval.validation.read_plan` reads every channel once): the first channels of each stream
(pulses, encoders; a text file's compared channels) and, later, each compared TDMS channel,
with the checks of :mod:`rigval.processing.health_check`; the zero drift is judged over
revolutions of the stream's pulse channel. :func:`comparison_health` picks the findings of a
comparison's channels; their lines go on the comparison's verdict line (``"wls1.tor2: 3.1 % of
samples clipped at 2e-05 V/V ...; not trusted"``), into ``alignment.json`` and the netCDF group
``/health`` (docs/processing.md, "Sensor health").
"""

from __future__ import annotations

import logging

import numpy as np
import xarray as xr

from rigval.processing.health import Finding
from rigval.processing.health_check import ChannelKind, period_samples, stream_health
from rigval.validation.scene_types import ComparisonSpec, Scene

__all__ = ["HealthLog", "comparison_health", "health_dataset"]

logger = logging.getLogger(__name__)


def _kind(sensor: str) -> ChannelKind:
    if sensor == "encoder":
        return "counter"
    if sensor == "reference_pulse":
        return "pulse"
    return "analog"


class HealthLog:
    """The health findings of a run's channels, gathered as the channels are read.

    Parameters
    ----------
    scene : Scene
        The scene (each channel's sensor, module and counts per revolution).
    """

    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        self.findings: list[Finding] = []
        self._period: dict[str, float | None] = {}

    def check(self, name: str, stream: xr.Dataset) -> None:
        """Check the mapped channels of stream ``name`` that ``stream`` (as read) holds.

        The stream's revolution period is taken from its pulse channel the first time that
        channel comes (with the first channels, which the alignment needs).
        """
        spec = self.scene.streams[name]
        kinds = {ch: _kind(c.sensor) for ch, c in spec.channels.items() if ch in stream}
        pulse = next((ch for ch, kind in kinds.items() if kind == "pulse"), None)
        if pulse is not None and self._period.get(name) is None:
            self._period[name] = period_samples(stream, pulse)
        self.findings += stream_health(
            stream, kinds, name=name,
            modules={ch: c.module for ch, c in spec.channels.items() if c.module},
            counts_per_rev={ch: float(c.params["counts_per_rev"])
                            for ch, c in spec.channels.items() if "counts_per_rev" in c.params},
            period=self._period.get(name))

    def in_stream_order(self) -> None:
        """Put the findings in the scene's stream order, each stream's in the order found.

        What checking the streams one after the other in the scene's order gives, when some
        were checked later than others (:func:`rigval.validation.read_stage.read_later`).
        """
        names = list(self.scene.streams)
        self.findings.sort(key=lambda finding: next(
            (k for k, name in enumerate(names) if finding.channel.startswith(f"{name}.")),
            len(names)))

    def extend(self, other: HealthLog) -> None:
        """Add the findings (and revolution periods) of a log of other streams' channels.

        A stream checked apart (in another process, :mod:`rigval.validation.pipeline`'s read
        stage) comes with a log of its own; extended in stream order, this log holds what
        checking the streams here one after the other would have given.
        """
        self.findings += other.findings
        self._period.update(other._period)


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
