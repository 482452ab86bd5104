"""Which channels of a set of aligned streams a step works on, and what it calls them.

:func:`rigval.processing.angle.angle_domain` and :func:`rigval.processing.timeline.common_timeline`
both take an optional ``channels`` mapping (stream -> channel names) and write one output
variable per channel; :func:`selected_channels` resolves that mapping once for both, and
:func:`merged_history` gives their outputs the history of the streams used.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence

import xarray as xr

from rigval.acquisition.errors import ChannelNotFoundError

__all__ = ["data_channels", "merged_history", "selected_channels"]


def data_channels(stream: xr.Dataset) -> list[str]:
    """Return a stream's channel variables: every data variable but ``valid`` and ``segment``."""
    return [str(v) for v in stream.data_vars if v not in ("valid", "segment")]


def selected_channels(aligned: Mapping[str, xr.Dataset],
                      channels: Mapping[str, Sequence[str]] | None = None
                      ) -> list[tuple[str, str, str]]:
    """Return ``(stream, channel, output name)`` for every selected channel, in order.

    Parameters
    ----------
    aligned : mapping of str to xarray.Dataset
        Aligned streams by name.
    channels : mapping of str to list of str, optional
        Channels per stream; default every channel of every stream (:func:`data_channels`).

    Returns
    -------
    list of (str, str, str)
        The output name is the channel's name, prefixed with ``<stream>_`` when two selected
        streams hold a channel of that name.

    Raises
    ------
    ChannelNotFoundError
        When a selected stream or channel does not exist (``where`` names it).
    """
    selection = channels or {name: data_channels(ds) for name, ds in aligned.items()}
    chosen: list[tuple[str, str]] = []
    for stream, names in selection.items():
        if stream not in aligned:
            raise ChannelNotFoundError(f"no aligned stream {stream!r}",
                                       where={"key": "channels"}, available=list(aligned))
        for name in names:
            if name not in aligned[stream]:
                raise ChannelNotFoundError(f"channel {name!r} not in stream {stream!r}",
                                           where={"channel": name},
                                           available=data_channels(aligned[stream]))
            chosen.append((stream, name))
    uses: dict[str, int] = {}
    for _, name in chosen:
        uses[name] = uses.get(name, 0) + 1
    return [(stream, name, name if uses[name] == 1 else f"{stream}_{name}")
            for stream, name in chosen]


def merged_history(aligned: Mapping[str, xr.Dataset], streams: Iterable[str]) -> str:
    """Return the ``history`` lines of the given streams, each line once, in order."""
    lines: list[str] = []
    for name in streams:
        for line in str(aligned[name].attrs.get("history", "")).splitlines():
            if line and line not in lines:
                lines.append(line)
    return "\n".join(lines)
