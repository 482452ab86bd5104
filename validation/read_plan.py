"""The read plan of a run: which channels of each stream each stage needs, each read once.

A validation needs few channels at a time: the alignment the pulse channels and the main
encoder, the model the drives' encoders, the angle stage one comparison's channels after the
other. :func:`read_plan` says, per stream, what is read before the alignment
(:attr:`ReadPlan.first`), which of those the model takes (:attr:`ReadPlan.drives`), and per
comparison which channels are read when it comes and which are let go after it
(:attr:`ReadPlan.compared`): every channel is read once, and a compared channel lives from its
first comparison to its last. A text file (CSV, LVM) is parsed whole for any channel, so its
compared channels come with the first read; with ``[output] raw`` or ``aligned`` every channel is
read first and kept (the streams go into the output).

:func:`measured_signals` walks the plan's comparisons over the aligned streams, reading and
letting go channels as the plan says; memory then holds the alignment's channels and one
comparison's channels, not every channel of the record (docs/performance.md, long records).
The plan is per channel and per comparison; reading in time blocks would add a time range to
each read (:func:`rigval.acquisition.channel_map.load_stream` takes one).
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np
import xarray as xr

from rigval.acquisition.channel_map import StreamSpec, load_stream
from rigval.acquisition.errors import DataError
from rigval.acquisition.heap import release_free_heap
from rigval.processing.clock_fit import input_delay
from rigval.processing.encoder import compact_counts
from rigval.processing.stream_alignment import AlignmentSettings
from rigval.validation.scene_types import ComparisonSpec, Scene
from rigval.validation.stage_settings import convert_stream

__all__ = [
    "ComparisonRead",
    "MeasuredSignal",
    "ReadPlan",
    "convert_first",
    "measured_signals",
    "read_first",
    "read_plan",
    "read_streams",
]

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class ComparisonRead:
    """What the angle stage reads for one comparison and lets go after it.

    Parameters
    ----------
    comparison : ComparisonSpec
        The comparison.
    read : tuple of str
        Channels of its stream read when it comes (not read before).
    release : tuple of str
        Channels of its stream no later comparison needs.
    last : bool
        The stream's last comparison: the stream itself (its times, validity and segments) is
        let go after it, unless the output keeps it.
    """

    comparison: ComparisonSpec
    read: tuple[str, ...]
    release: tuple[str, ...]
    last: bool = False


@dataclass(frozen=True)
class ReadPlan:
    """Which channels each stage needs, per stream.

    Parameters
    ----------
    first : mapping of str to tuple of str
        Per stream, the channels read before the alignment.
    drives : tuple of str
        Encoders of the measured drives on the reference stream (read first, kept aligned until
        the model has its drives).
    compared : tuple of ComparisonRead
        The comparisons, grouped by stream, with their reads and releases.
    whole : bool
        Every channel is read first and kept (``[output] raw`` or ``aligned``).
    """

    first: Mapping[str, tuple[str, ...]]
    drives: tuple[str, ...]
    compared: tuple[ComparisonRead, ...]
    whole: bool

    def kept_after_alignment(self, stream: str) -> set[str]:
        """Return the channels of a stream the later stages still need after the alignment."""
        needed = {ref.channel for step in self.compared for _, ref in step.comparison.terms
                  if ref.stream == stream}
        return needed & set(self.first[stream])

    def edges_only(self, stream: str, channel: str) -> bool:
        """Return True when a pulse channel read first is needed for its edges alone.

        It is then let go once its edges are found (neither compared nor kept for the output).
        """
        return not self.whole and channel not in self.kept_after_alignment(stream)


def _first_channels(scene: Scene, settings: AlignmentSettings, whole: bool
                    ) -> dict[str, tuple[str, ...]]:
    """Return the channels read before the alignment: pulses, encoders of phi_F and the drives.

    A stream aligned by its start stamps needs no channel; its first is read for its samples.
    A stream in a text file brings its compared channels too.
    """
    if whole:
        return {name: tuple(spec.channels) for name, spec in scene.streams.items()}
    needs: dict[str, set[str]] = {name: set() for name in scene.streams}
    needs[settings.reference] |= {settings.encoder.name, settings.reference_pulse.name}
    if scene.model.drives == "measured":
        for driver in scene.model.drivers.values():
            needs[driver.encoder.stream].add(driver.encoder.channel)
    for name, clock in settings.streams.items():
        if clock.pulse is not None:
            needs[name].add(clock.pulse.name)
    for name, names in needs.items():
        if not names:
            names.add(next(iter(scene.streams[name].channels)))
        if scene.streams[name].file.suffix.lower() != ".tdms":
            # a text file is parsed whole for any channel: its compared channels come along
            names.update(ref.channel for c in scene.comparisons for _, ref in c.terms
                         if ref.stream == name)
    return {name: tuple(c for c in scene.streams[name].channels if c in needs[name])
            for name in scene.streams}


def read_plan(scene: Scene, settings: AlignmentSettings) -> ReadPlan:
    """Return the read plan of a scene.

    Parameters
    ----------
    scene : Scene
        The scene.
    settings : AlignmentSettings
        Its alignment settings (which pulse channel each stream's clock is fitted on).
    """
    whole = scene.output.raw or scene.output.aligned
    first = _first_channels(scene, settings, whole)
    by_stream: dict[str, list[ComparisonSpec]] = {}
    for comparison in scene.comparisons:
        by_stream.setdefault(comparison.measured.stream, []).append(comparison)
    steps = []
    for stream, comparisons in by_stream.items():
        have = set(first[stream])
        for i, comparison in enumerate(comparisons):
            names = list(dict.fromkeys(ref.channel for _, ref in comparison.terms))
            later = {ref.channel for c in comparisons[i + 1:] for _, ref in c.terms}
            read = tuple(n for n in names if n not in have)
            have.update(read)
            release = () if whole else tuple(n for n in names if n not in later)
            steps.append(ComparisonRead(comparison, read, release,
                                        last=not whole and i == len(comparisons) - 1))
    drives = tuple(d.encoder.channel for d in scene.model.drivers.values()) \
        if scene.model.drives == "measured" else ()
    return ReadPlan(first=MappingProxyType(first), drives=drives, compared=tuple(steps),
                    whole=whole)


def stream_part(spec: StreamSpec, names: Iterable[str]) -> StreamSpec:
    """Return the stream table with only the named channels (in table order)."""
    keep = set(names)
    return dataclasses.replace(spec, channels=MappingProxyType(
        {name: channel for name, channel in spec.channels.items() if name in keep}))


def read_streams(scene: Scene, channels: Mapping[str, Iterable[str]] | None = None, *,
                 only: str | None = None) -> dict[str, xr.Dataset]:
    """Read every stream of a scene: the mapped channels under their scene names.

    Parameters
    ----------
    scene : Scene
        The scene.
    channels : mapping of str to iterable of str, optional
        Per stream, only these scene channels; default every mapped channel.
    only : str, optional
        Read only this stream.

    Returns
    -------
    dict of str to xarray.Dataset
        Stream name -> stream as read (raw units).
    """
    names = list(scene.streams) if only is None else [only]
    if channels is None:
        return {name: load_stream(scene.streams[name]) for name in names}
    return {name: load_stream(stream_part(scene.streams[name], channels[name]))
            for name in names}


def read_first(scene: Scene, plan: ReadPlan, name: str) -> xr.Dataset:
    """Read a stream's first channels (those the plan reads before the alignment).

    The values as they are; unless every channel is kept, encoder counters are stored as
    32-bit integers where that is exact (:func:`rigval.processing.encoder.compact_counts`:
    values are never altered), before the health checks and the conversion see them (memory).
    A TDMS file's counters are then read one at a time, each compacted before the next is
    read, and its other first channels after them (:func:`_counters_apart`): a long record's
    float64 counters are never held together (1 h at 5 kS/s: 137 MiB each). The file's
    SHA-256 is computed on the first read (``source_sha256``), and remembered for the others.
    """
    spec = scene.streams[name]
    if plan.whole:
        return load_stream(stream_part(spec, plan.first[name]))
    counters = [channel for channel in plan.first[name]
                if spec.channels[channel].sensor == "encoder"]
    if spec.file.suffix.lower() == ".tdms" and counters:
        return _counters_apart(spec, plan.first[name], counters)
    stream = load_stream(stream_part(spec, plan.first[name]))
    for channel in counters:
        stream[channel] = _compacted(stream[channel])
    return stream


def _compacted(channel: xr.DataArray) -> xr.DataArray:
    """Return a counter channel as 32-bit integers where that is exact (else as it is)."""
    return channel.copy(data=compact_counts(channel.to_numpy()))


def _counters_apart(spec: StreamSpec, channels: Iterable[str], counters: list[str]
                    ) -> xr.Dataset:
    """Read a TDMS stream's counters one at a time, compacted, then its other channels.

    The stream is the one a single read of ``channels`` gives, with the counters compacted:
    every read of a file gives the stream's own samples, ``time``, ``valid``, ``segment`` and
    attributes (a counter of another sample count, a damaged file, is refused), its channels
    in the table's order.
    """
    kept = set(channels)
    others = [channel for channel in spec.channels if channel in kept and channel not in counters]
    read, stream = {}, None
    for counter in counters:
        part = load_stream(stream_part(spec, [counter]))
        read[counter] = _compacted(part[counter])
        if stream is None and not others:
            stream = part.drop_vars(counter)  # the stream's samples, as every read gives them
        del part
    if stream is None:
        stream = load_stream(stream_part(spec, others))
    for counter, values in read.items():
        if values.sizes["time"] != stream.sizes["time"]:
            raise DataError(f"channel {counter!r} of {spec.file.name} holds "
                            f"{values.sizes['time']} samples where the stream's other channels "
                            f"hold {stream.sizes['time']}",
                            where={"file": str(spec.file), "channel": counter},
                            hint="the file is damaged; rigval info FILE lists its channels")
    stream = stream.assign(read)
    order = [channel for channel in spec.channels if channel in kept]
    return stream[[*order, *(v for v in stream.data_vars if v not in kept)]]


def convert_first(scene: Scene, name: str, stream: xr.Dataset) -> xr.Dataset:
    """Convert a stream's first channels (:func:`read_first`) to physical units."""
    return convert_stream(stream, stream_part(scene.streams[name], stream.data_vars))


def _add_channels(scene: Scene, name: str, aligned: xr.Dataset, channels: Iterable[str],
                  on_read: Callable[[str, xr.Dataset], None] | None = None) -> xr.Dataset:
    """Read, convert and put on the reference timeline channels of an aligned stream.

    The samples are those of the alignment's read of the same file, so they take its
    reference times; each channel's module delay is scaled by the stream's clock drift as
    :func:`rigval.processing.clock_fit.align_stream` does.

    ``on_read(name, channels as read)`` is called before the conversion (the health checks);
    the channels as read are then converted in their own memory, no copy (memory).

    Raises
    ------
    DataError
        If the file holds another number of samples than when the stream was aligned.
    """
    spec = stream_part(scene.streams[name], channels)
    read = load_stream(spec, checksum=False)
    if on_read is not None:
        on_read(name, read)
    part = convert_stream(read, spec, overwrite=True)  # the read is let go here
    del read
    if part.sizes["time"] != aligned.sizes["time"]:
        raise DataError(f"stream {name}: {spec.file.name} gave {part.sizes['time']} samples for "
                        f"{list(spec.channels)} but {aligned.sizes['time']} when it was aligned",
                        where={"file": str(spec.file), "stream": name},
                        hint="the file changed during the validation: validate a finished "
                             "copy of the run")
    drift = float(aligned.attrs.get("clock_drift_ppm", 0.0)) * 1e-6
    fs = float(part.attrs["fs_nominal"])
    out = aligned.copy()
    for channel in spec.channels:
        var = part[channel]
        out[channel] = xr.Variable("time", var.to_numpy(), {
            **var.attrs, "input_delay_s": input_delay(var.attrs, fs) * (1.0 + drift)})
    return out


@dataclass(frozen=True)
class MeasuredSignal:
    """Where a comparison's measured values lie on its stream's reference timeline.

    Parameters
    ----------
    held : list of numpy.ndarray
        The measured values, handed over once by :meth:`take_values`.
    valid : numpy.ndarray
        Samples that are valid and finite.
    segment : numpy.ndarray
        Gap-free segment index per sample.
    time : xarray.DataArray
        Reference time per sample, s.
    delay_s : float
        Module input delay of the measured channel, s (subtract from ``time``).
    fs : float
        Nominal sampling rate, Hz.
    long_name : str
        Label of the measured channel.
    owned : bool
        The values are the signal's alone (a sum, or a channel its stream has let go): the
        caller may filter them in place; else they are a channel the stream keeps for a later
        comparison or the output.
    """

    held: list[np.ndarray] = field(repr=False)
    valid: np.ndarray
    segment: np.ndarray
    time: xr.DataArray
    delay_s: float
    fs: float
    long_name: str
    owned: bool

    def take_values(self) -> np.ndarray:
        """Return the measured values, handing them over: the signal keeps no reference to them.

        The values are the measured channel plus or minus the summed ones, float64, in the
        converted unit; the caller's filters can then free them as they make their output, or
        write their output into them when :attr:`owned`.
        """
        return self.held.pop()


def measured_signals(scene: Scene, plan: ReadPlan, aligned: dict[str, xr.Dataset], *,
                     on_read: Callable[[str, xr.Dataset], None] | None = None
                     ) -> Iterator[tuple[ComparisonSpec, MeasuredSignal]]:
    """Yield each comparison and its measured signal, reading and letting go as planned.

    ``aligned`` is updated as the plan says: a comparison's channels not read yet are added to
    its stream, and those no later comparison needs are dropped before its signal is yielded,
    so that the consumer's filters can free their input as they make their output, or filter
    it in place (:attr:`MeasuredSignal.owned`); after a
    stream's last comparison the stream itself is dropped. Streams whose compared channels are
    all held already come first (letting them go frees memory before anything is read), then
    the others longest first, so that the longest channels are worked on while the fewest
    comparisons' results are held (a stream not compared yet holds its masks only: its time
    axis is lazy); a stream's comparisons keep their order. ``on_read`` sees each stream's
    channels as read, before their conversion (:meth:`rigval.validation.health.HealthLog.check`).
    """
    length = {name: ds.sizes["time"] for name, ds in aligned.items()}
    reads = {step.comparison.measured.stream for step in plan.compared if step.read}

    def order(step: ComparisonRead) -> tuple[bool, int]:
        stream = step.comparison.measured.stream
        return (True, -length[stream]) if stream in reads else (False, length[stream])

    steps = sorted(plan.compared, key=order)
    for step in steps:
        stream = step.comparison.measured.stream
        if step.read:
            # the last comparison's freed pages go back before the next channel is read, not
            # left idle beside it (glibc; docs/performance.md)
            release_free_heap()
            aligned[stream] = _add_channels(scene, stream, aligned[stream], step.read, on_read)
        signal = _signal(step.comparison, aligned[stream],
                         owned=step.comparison.measured.channel in step.release)
        if step.last:
            aligned.pop(stream)
        elif step.release:
            aligned[stream] = aligned[stream].drop_vars(list(step.release))
        yield step.comparison, signal


def _signal(comparison: ComparisonSpec, ds: xr.Dataset, *, owned: bool) -> MeasuredSignal:
    """Return a comparison's measured signal from its aligned stream.

    ``owned``: the stream lets the measured channel go after (released); a sum is the
    signal's own in any case.
    """
    name = comparison.measured.channel
    values = np.asarray(ds[name].to_numpy(), dtype=np.float64)  # no copy (memory)
    for sign, ref in comparison.terms[1:]:  # channels of the same stream and unit, summed
        values = values + sign * ds[ref.channel].to_numpy().astype(np.float64)
    valid = np.isfinite(values)
    valid &= ds["valid"].to_numpy()  # in place: one mask of the record made, not two
    return MeasuredSignal(
        held=[values], valid=valid,
        segment=ds["segment"].to_numpy(), time=ds["time"],
        delay_s=float(ds[name].attrs.get("input_delay_s", 0.0)),
        fs=float(ds.attrs["fs_nominal"]),
        long_name=(comparison.measured_text if comparison.summed
                   else str(ds[name].attrs.get("long_name", name))),
        owned=owned or len(comparison.terms) > 1)
