"""The read stage of a run: each stream's first channels, converted, checked and digested.

:func:`read_streams` reads the channels the alignment and the model need (the read plan's
first channels, :mod:`rigval.validation.read_plan`), one stream after the other, converts them
to physical units and checks their health; the main reference pulse is held as its edges and
the samples near them. Small files of the other streams are read in a child beside this process
(:class:`~rigval.validation.beside.Standby`), where their clock pulses are found too, and taken
back in the scene's order: the same results, findings and first error as reading them here.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from contextlib import nullcontext
from dataclasses import dataclass
from pathlib import Path

import xarray as xr

from rigval.acquisition.detect import source_checksum
from rigval.acquisition.errors import RigvalError
from rigval.processing.pulses import StreamPulses
from rigval.processing.stream_alignment import (
    AlignmentSettings,
    ReferencePulses,
    clock_pulses,
    reference_pulses,
)
from rigval.validation.beside import Standby, can_fork
from rigval.validation.health import HealthLog
from rigval.validation.note import read_note
from rigval.validation.read_plan import ReadPlan, convert_first, read_first
from rigval.validation.scene_types import Scene
from rigval.validation.stage_settings import check_sample_rates
from rigval.validation.stopwatch import Stopwatch

__all__ = ["BESIDE_BYTES", "Inputs", "Read", "read_later", "read_streams", "reads_beside"]

logger = logging.getLogger(__name__)


def _read_stream(scene: Scene, plan: ReadPlan, name: str, watch: Stopwatch, health: HealthLog
                 ) -> tuple[xr.Dataset, str, xr.Dataset | None]:
    """Return one stream's first channels converted, its file's SHA-256 and, kept, as read.

    The channels' health is checked on them as read (``health``).
    """
    stream = read_first(scene, plan, name)
    check_sample_rates(scene, {name: stream})
    with watch.stage("health"):
        health.check(name, stream)
    with watch.stage("convert"):
        converted = convert_first(scene, name, stream)
    return converted, str(stream.attrs["source_sha256"]), stream if scene.output.raw else None


@dataclass(frozen=True)
class Inputs:
    """What the run read besides the channels: kept for the result."""

    raw: Mapping[str, xr.Dataset]
    note: str | None
    digests: tuple[tuple[Path, str], ...]
    health: HealthLog


@dataclass(frozen=True)
class Read:
    """The read stage's output: the main reference pulses apart when found as read.

    ``clock_pulses``: the other streams' pulses their clocks are fitted on, where found as they
    were read (beside, :func:`read_streams`); the align stage finds the others'. ``later``: the
    other streams left to :func:`read_later`, whose files' digests ``inputs`` lacks till then.
    """

    inputs: Inputs
    converted: Mapping[str, xr.Dataset]
    reference: ReferencePulses | None
    clock_pulses: Mapping[str, StreamPulses]
    later: tuple[str, ...] = ()


#: The other streams' files, together, up to which they are read beside the reference stream
#: (:func:`read_streams`): bytes. Beyond, their streams as read would travel pickled between
#: processes, a copy of each in memory, and the record's stages dwarf the read.
BESIDE_BYTES = 64 * 2**20


@dataclass(frozen=True)
class _StreamRead:
    """One stream as read: converted, its file's SHA-256, kept as read, its health, its pulses.

    ``pulses``: those its clock is fitted on when found as it was read, else None.
    """

    converted: xr.Dataset
    digest: str
    raw: xr.Dataset | None
    health: HealthLog
    pulses: StreamPulses | None = None


def _read_other(scene: Scene, plan: ReadPlan, settings: AlignmentSettings, name: str
                ) -> _StreamRead:
    """Read another stream than the reference, and find the pulses its clock is fitted on.

    Runs beside this process (:func:`read_streams`): a problem of the pulses is left to the
    align stage, which finds them again and reports it where it always does, after phi_F.
    """
    health = HealthLog(scene)
    converted, digest, kept = _read_stream(scene, plan, name, Stopwatch(quiet=True), health)
    try:
        pulses = clock_pulses(settings, name, converted)
    except RigvalError:
        pulses = None
    return _StreamRead(converted, digest, kept, health, pulses)


def reads_beside(scene: Scene, settings: AlignmentSettings) -> bool:
    """Whether the other streams are read beside the reference stream (:func:`read_streams`)."""
    others = [spec.file for name, spec in scene.streams.items() if name != settings.reference]
    if not others or not can_fork():
        return False
    try:
        return sum(path.stat().st_size for path in others) <= BESIDE_BYTES
    except OSError:  # a missing file: the read says which, here
        return False


def read_streams(scene: Scene, plan: ReadPlan, settings: AlignmentSettings, watch: Stopwatch
                 ) -> Read:
    """Read and convert each stream's first channels, one stream after the other.

    Stream by stream, so that memory holds one stream as read beside the converted ones; the
    main reference pulse channel, needed for its edges alone, is held as they and the samples
    near them once its stream is converted. The data files' SHA-256 come from this read, the
    mechanism's and the note's are computed here.

    Where a core is free and the other streams' files are small (:data:`BESIDE_BYTES`), the
    other streams are read, converted and checked, and their clock pulses found, in a child
    forked now (:class:`~rigval.validation.beside.Standby`) while this process reads the
    reference stream; they are taken in the scene's order, so the results, the health findings'
    order and the first error reported are those of the reading here. Otherwise only the
    reference stream is read here, and the others when the align stage takes them
    (:attr:`Read.later`, :func:`read_later`): a long record's phi_F is made without them in
    memory.
    """
    converted: dict[str, xr.Dataset] = {}
    raw: dict[str, xr.Dataset] = {}
    digests: dict[Path, str] = {}
    pulses: dict[str, StreamPulses] = {}
    health = HealthLog(scene)
    reference = None
    beside = reads_beside(scene, settings)
    later = () if beside else tuple(name for name in scene.streams if name != settings.reference)
    with Standby() if beside else nullcontext() as standby:
        pending = {name: standby.submit(_read_other, scene, plan, settings, name)
                   for name in scene.streams if beside and name != settings.reference}
        if pending:
            logger.info("streams %s read beside the reference stream %s, in a child process",
                        ", ".join(pending), settings.reference)
        for name, spec in scene.streams.items():
            if name in later:
                continue
            if name in pending:
                read = pending[name].result()
                if read.pulses is not None:
                    pulses[name] = read.pulses
                health.extend(read.health)
                converted[name], digests[spec.file], kept = read.converted, read.digest, read.raw
            else:
                converted[name], digests[spec.file], kept = _read_stream(
                    scene, plan, name, watch, health)
            if name == settings.reference and plan.edges_only(name,
                                                              settings.reference_pulse.name):
                converted[name], reference = reference_pulses(settings, converted[name])
            if kept is not None:
                raw[name] = kept
    unread = {scene.streams[name].file for name in later}
    inputs = tuple((path, digests.get(path) or source_checksum(path))
                   for path in scene.input_files if path not in unread)
    note = read_note(scene.note) if scene.note is not None else None
    return Read(Inputs(raw, note, inputs, health), converted, reference, pulses, later)


def read_later(scene: Scene, plan: ReadPlan, names: tuple[str, ...], inputs: Inputs,
               watch: Stopwatch) -> tuple[Inputs, dict[str, xr.Dataset]]:
    """Read the other streams :func:`read_streams` left for later (:attr:`Read.later`).

    Each as :func:`read_streams` reads it, timed as the read stage. Returns ``inputs`` complete
    (the streams kept as read, the files' digests and the health findings in the scene's
    order, as reading every stream in :func:`read_streams` gives them) and the streams.
    """
    converted: dict[str, xr.Dataset] = {}
    raw, digests, health = dict(inputs.raw), dict(inputs.digests), inputs.health
    with watch.stage("read"):
        for name in names:
            file = scene.streams[name].file
            converted[name], digests[file], kept = _read_stream(scene, plan, name, watch, health)
            if kept is not None:
                raw[name] = kept
    health.in_stream_order()
    complete = Inputs({name: raw[name] for name in scene.streams if name in raw}, inputs.note,
                      tuple((path, digests[path]) for path in scene.input_files), health)
    return complete, converted
