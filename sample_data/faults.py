"""Sensor faults the virtual rig can inject, and their truth.

A :class:`Fault` names a channel of a stream and where (a share of the stream's samples) it
acts; :class:`FaultInjector` applies the faults to the raw codes or counts as the rig writes
them, window by window, and records what it changed (``faults`` in ``truth.json``: the samples
affected as indices into the stream as read, its gap-free segments concatenated).

Kinds (``size`` in the channel's file unit unless said):

- ``"clipping"``: the codes clipped at ``+-size`` (a range set too small);
- ``"flat line"``: the reading stuck at its value at ``start`` until ``stop`` (a broken gauge);
- ``"spikes"``: ``count`` single samples ``+-size`` off, at random places in ``start ... stop``;
- ``"noise"``: white noise of ``size`` rms added from ``start`` to ``stop``;
- ``"zero drift"``: a ramp from 0 at ``start`` to ``size`` at the record's end;
- ``"count jump"``: ``size`` counts added from ``start`` on (counts lost or gained);
- ``"count glitch"``: ``size`` counts added to the one sample at ``start``;
- ``"pulse width"``: every pulse falling after ``start`` stays high ``size`` times its width
  longer (a pulse channel).
"""

from __future__ import annotations

import dataclasses
import logging
from dataclasses import dataclass
from typing import Any

import numpy as np

from rigval.acquisition.errors import ConfigError
from rigval.sample_data.devices import Stream, StreamPiece

__all__ = ["FAULT_KINDS", "Fault", "FaultInjector"]

logger = logging.getLogger(__name__)

FAULT_KINDS = ("clipping", "flat line", "spikes", "noise", "zero drift", "count jump",
               "count glitch", "pulse width")
#: Samples of the falling edge (and the low level after it) and of the plateau before it moved
#: with a widened pulse.
_FALL_SAMPLES, _PLATEAU_SAMPLES = 24, 6


@dataclass(frozen=True)
class Fault:
    """One injected sensor fault.

    Parameters
    ----------
    kind : str
        One of :data:`FAULT_KINDS`.
    stream, channel : str
        Where (``"wls1"``, ``"tor2"``).
    size : float
        How large (module docstring).
    start, stop : float, default 0 and 1
        Share of the stream's samples where the fault begins and ends.
    count : int, default 5
        Spikes.
    """

    kind: str
    stream: str
    channel: str
    size: float
    start: float = 0.0
    stop: float = 1.0
    count: int = 5

    def check(self, streams: dict[str, Stream] | None = None) -> None:
        """Raise ConfigError for an unknown kind, channel or a share outside 0 ... 1."""
        key = f"faults.{self.stream}.{self.channel}"
        if self.kind not in FAULT_KINDS:
            raise ConfigError(f"unknown fault kind {self.kind!r}", where={"key": key},
                              hint=f"use one of {', '.join(FAULT_KINDS)}")
        if not 0.0 <= self.start < self.stop <= 1.0:
            raise ConfigError(f"a fault needs 0 <= start < stop <= 1, got {self.start} and "
                              f"{self.stop}", where={"key": key})
        if streams is not None and not any(
                c.name == self.channel for c in getattr(streams.get(self.stream), "channels",
                                                        ())):
            raise ConfigError(f"no channel {self.channel!r} in stream {self.stream!r}",
                              where={"key": key}, hint="name a channel of the rig's streams")


class FaultInjector:
    """Apply faults to the rig's stream pieces and keep their truth.

    Parameters
    ----------
    faults : sequence of Fault
        The faults.
    streams : dict of str to Stream
        The rig's streams (their clocks give each segment's samples; their channels the slope
        from codes to file units).
    seed : int
        Seed of the spikes' places and the added noise.
    """

    def __init__(self, faults: tuple[Fault, ...], streams: dict[str, Stream], seed: int) -> None:
        for fault in faults:
            fault.check(streams)
        self.faults = faults
        self.streams = streams
        self.rng = np.random.default_rng([seed, 7919])
        self.first = {name: np.concatenate(([0], np.cumsum(
            [s.n_samples for s in stream.clock.segments]))) for name, stream in streams.items()}
        self.truth: list[dict[str, Any]] = []
        self.spikes: list[np.ndarray] = []
        self.stuck: list[int | None] = []
        for fault in faults:
            total = int(self.first[fault.stream][-1])
            lo, hi = self._span(fault)
            places = (np.sort(self.rng.choice(np.arange(lo, hi), size=min(fault.count, hi - lo),
                                              replace=False))
                      if fault.kind == "spikes" else np.zeros(0, dtype=np.int64))
            self.spikes.append(places)
            self.stuck.append(None)
            self.truth.append({"kind": fault.kind, "stream": fault.stream,
                               "channel": fault.channel, "size": fault.size,
                               "start_sample": lo, "stop_sample": hi, "samples": 0,
                               "first_sample": None, "last_sample": None,
                               "indices": places.tolist(), "stream_samples": total})

    def _span(self, fault: Fault) -> tuple[int, int]:
        total = int(self.first[fault.stream][-1])
        return int(fault.start * total), int(fault.stop * total)

    def _slope(self, fault: Fault) -> float:
        return next(c.slope for c in self.streams[fault.stream].channels
                    if c.name == fault.channel)

    def apply(self, piece: StreamPiece) -> StreamPiece:
        """Return the piece with the faults of its stream applied (codes copied)."""
        mine = [(n, f) for n, f in enumerate(self.faults) if f.stream == piece.stream]
        if not mine:
            return piece
        raw = {name: list(arrays) for name, arrays in piece.raw.items()}
        for n, fault in mine:
            for p, (segment, k0) in enumerate(piece.parts):
                codes = raw[fault.channel][p]
                index = self.first[piece.stream][segment] + k0 + np.arange(codes.size)
                raw[fault.channel][p] = self._apply(n, fault, codes, index)
        return dataclasses.replace(piece, raw=raw)

    def _note(self, n: int, hit: np.ndarray) -> None:
        """Record affected sample indices of fault n."""
        if hit.size == 0:
            return
        record = self.truth[n]
        record["samples"] += int(hit.size)
        record["first_sample"] = int(hit[0]) if record["first_sample"] is None else min(
            record["first_sample"], int(hit[0]))
        record["last_sample"] = int(hit[-1]) if record["last_sample"] is None else max(
            record["last_sample"], int(hit[-1]))

    def _apply(self, n: int, fault: Fault, codes: np.ndarray, index: np.ndarray) -> np.ndarray:
        lo, hi = self._span(fault)
        inside = (index >= lo) & (index < hi)
        if not inside.any():
            return codes
        dtype = codes.dtype
        if fault.kind in ("count jump", "count glitch"):
            counts = codes.astype(np.int64)
            hit = (index >= lo) if fault.kind == "count jump" else (index == lo)
            counts[hit] += round(fault.size)
            self._note(n, index[hit] if fault.kind == "count glitch" else index[hit][:1])
            return (counts % 2**32).astype(dtype) if dtype.kind == "u" else counts.astype(dtype)
        if fault.kind == "pulse width":
            return self._widen(n, fault, codes, index, inside)
        value = codes.astype(np.float64)
        step = fault.size / self._slope(fault)
        if fault.kind == "clipping":
            hit = inside & (np.abs(value) > step)
            value[inside] = np.clip(value[inside], -round(step), round(step))
        elif fault.kind == "flat line":
            if self.stuck[n] is None:
                self.stuck[n] = int(value[np.flatnonzero(inside)[0]])
            hit = inside
            value[inside] = self.stuck[n]
        elif fault.kind == "spikes":
            hit = np.isin(index, self.spikes[n])
            signs = self.rng.choice([-1.0, 1.0], size=int(hit.sum()))
            value[hit] += np.rint(signs * step)
        elif fault.kind == "noise":
            hit = inside
            value[inside] += np.rint(self.rng.normal(0.0, step, int(inside.sum())))
        else:  # zero drift
            hit = inside
            total = int(self.first[fault.stream][-1])
            value[inside] += np.rint(step * (index[inside] - lo) / max(total - lo, 1))
        self._note(n, index[hit])
        return value.astype(dtype)

    def _widen(self, n: int, fault: Fault, codes: np.ndarray, index: np.ndarray,
               inside: np.ndarray) -> np.ndarray:
        """Keep each pulse falling inside the span high ``size`` times its width longer."""
        x = codes.astype(np.float64)
        low, high = np.median(x), np.percentile(x, 99.5)  # pulses are high a few % of the time
        up = x > 0.5 * (low + high)
        rises = np.flatnonzero(~up[:-1] & up[1:]) + 1
        falls = np.flatnonzero(up[:-1] & ~up[1:]) + 1
        out = codes.copy()
        changed = []
        for f in falls:
            r = rises[rises < f]
            if r.size == 0 or not inside[f]:
                continue
            width = f - r[-1]
            extra = round(fault.size * width)
            if extra <= 0 or f + extra + _FALL_SAMPLES > codes.size or extra > width:
                continue
            later = rises[rises > f]
            if later.size and later[0] <= f + extra + _FALL_SAMPLES:
                continue
            # the fall and what follows move ``extra`` samples later; plateau samples from
            # before the fall fill the gap
            s = f - _PLATEAU_SAMPLES
            if s - extra <= r[-1]:
                continue
            out[s + extra:f + extra + _FALL_SAMPLES] = codes[s:f + _FALL_SAMPLES]
            out[s:s + extra] = codes[s - extra:s]
            changed.append(index[f])
        self._note(n, np.asarray(changed, dtype=np.int64))
        return out

    def records(self) -> list[dict[str, Any]]:
        """Return the truth of every fault (``faults`` in ``truth.json``)."""
        return [dict(record) for record in self.truth]
