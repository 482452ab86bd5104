"""What the virtual rig's devices record: sampled channels, streams and pieces of a stream.

Plain records with no behaviour of their own: :mod:`rigval.sample_data.streams` fills them,
:mod:`rigval.sample_data.faults` alters them and :mod:`rigval.sample_data.simulate` writes them
out, so none of these needs to import the sampling stage (or the rig it draws from).
"""

from __future__ import annotations

from dataclasses import dataclass

from numpy.typing import NDArray

from rigval.processing.arrays import FloatArray
from rigval.sample_data.devices import DeviceClock

__all__ = ["SampledChannel", "Stream", "StreamPiece"]


@dataclass(frozen=True)
class SampledChannel:
    """One channel as its device recorded it.

    Parameters
    ----------
    name : str
        Channel name.
    module : str
        Module model (key of :data:`~rigval.sample_data.devices.MODULES`).
    unit : str or None
        Unit string in the file (None for counters).
    raw : list of numpy.ndarray
        Raw codes or counts, one array per gap-free segment.
    slope : float
        Scale from raw to ``unit``.
    delay : float
        Module input delay in s.
    truth : numpy.ndarray or None
        Physical truth at the sample instants (segments concatenated), or None where the truth is
        kept elsewhere (pulses: edge lists; encoders: the drive law).
    truth_unit : str or None
        UDUNITS unit of ``truth``.
    """

    name: str
    module: str
    unit: str | None
    raw: list[NDArray]
    slope: float
    delay: float
    truth: FloatArray | None
    truth_unit: str | None


@dataclass(frozen=True)
class Stream:
    """One device's record: its clock and its channels.

    Parameters
    ----------
    name : str
        ``"cdaq"``, ``"wls1"`` or ``"wls2"``.
    device : str
        Device model.
    clock : DeviceClock
        Sample clock and segments.
    channels : tuple of SampledChannel
        Channels in file order.
    """

    name: str
    device: str
    clock: DeviceClock
    channels: tuple[SampledChannel, ...]


@dataclass(frozen=True)
class StreamPiece:
    """The samples of one stream within one window of true time.

    Parameters
    ----------
    stream : str
        Stream name.
    parts : tuple of (int, int)
        For each gap-free segment the window touches: the segment's index and the index of the
        piece's first sample within it, in time order.
    raw : mapping of str to list of numpy.ndarray
        Raw codes or counts per channel, one array per entry of ``parts``.
    truth : mapping of str to numpy.ndarray
        Physical truth at the piece's samples (parts concatenated) of the analog channels that
        have one.
    """

    stream: str
    parts: tuple[tuple[int, int], ...]
    raw: dict[str, list[NDArray]]
    truth: dict[str, FloatArray]
