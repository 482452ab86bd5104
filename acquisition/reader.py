"""The public entry points: read any supported file into its streams.

``read`` picks the format from the file's content (:func:`~rigval.acquisition.detect.detect_format`)
and returns **a dict stream name -> Dataset** (one stream per time base, docs/formats.md,
*What a stream carries*), in file order. ``read_stream`` returns the one stream of a file and
refuses files with several.
``iter_stream`` processes a TDMS stream larger than memory window by window.
"""

from __future__ import annotations

import importlib
import inspect
import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any

import xarray as xr

from rigval.acquisition.detect import FORMATS, detect_format
from rigval.acquisition.errors import ConfigError, DataFileError

__all__ = ["iter_stream", "read", "read_stream", "reader_options"]


def read(path: str | os.PathLike[str], *, format: str | None = None,
         channels: Sequence[str] | None = None,
         time_range: tuple[float | None, float | None] | None = None,
         device: str | None = None, **reader_options: Any) -> dict[str, xr.Dataset]:
    """Read a TDMS, LVM or CSV file into its streams.

    Parameters
    ----------
    path : str or path-like
        The data file.
    format : {"tdms", "lvm", "csv"}, optional
        Skip detection from the content.
    channels : sequence of str, optional
        Channels to read (default: all numeric ones).
    time_range : tuple of float or None, optional
        ``(t_from, t_to)`` in s since each stream's first sample, inclusive; None: open end.
        TDMS files read only the samples in range from disk.
    device : str, optional
        Device profile name (``"cDAQ-9172"``, ``"WLS-9163"``).
    **reader_options
        Options of the format's reader: :func:`~rigval.acquisition.tdms.read_tdms` (``group``,
        ``modules``, ``fs``, ``include_decimated``, ``checksum``),
        :func:`~rigval.acquisition.text_csv.read_csv` (``delimiter``, ``decimal``,
        ``time_column``, ``timezone``, ...), :func:`~rigval.acquisition.lvm.read_lvm`.

    Returns
    -------
    dict of str to xarray.Dataset
        Stream name -> stream, in file order.

    Raises
    ------
    DataFileError
        Unreadable files (with the path and what they are); unknown reader options.
    ChannelNotFoundError
        Unknown channels or groups (the message lists the available ones).
    """
    kind = detect_format(path) if format is None else format.lower()
    if kind not in _READERS:
        raise ConfigError(f"unknown format {format!r}", where={"key": "format"},
                          hint=f"use one of {', '.join(FORMATS)} or leave it unset")
    reader = _reader(kind)
    accepted = inspect.signature(reader).parameters
    unknown = sorted(set(reader_options) - set(accepted))
    if unknown:
        raise ConfigError(f"the {kind} reader has no option {unknown[0]!r}",
                          where={"file": str(path), "key": f"reader.{unknown[0]}"},
                          hint="options: " + ", ".join(k for k in accepted if k != "path"))
    return reader(path, channels=channels, time_range=time_range, device=device,
                  **reader_options)


def reader_options(kind: str | None = None) -> set[str]:
    """Return the option names a format's reader accepts (all formats' when ``kind`` is None).

    Parameters
    ----------
    kind : {"tdms", "csv", "lvm"}, optional
        The format.

    Returns
    -------
    set of str
        Keyword names besides ``path``, ``channels``, ``time_range`` and ``device``.
    """
    chosen = [_reader(k) for k in _READERS] if kind is None else [_reader(kind)]
    names = {name for reader in chosen for name in inspect.signature(reader).parameters}
    return names - {"path", "channels", "time_range", "device"}


#: Format -> module and name of its reader, imported on first use (``import rigval`` stays
#: light, and a TDMS read does not import the text readers).
_READERS = {"tdms": ("rigval.acquisition.tdms", "read_tdms"),
            "csv": ("rigval.acquisition.text_csv", "read_csv"),
            "lvm": ("rigval.acquisition.lvm", "read_lvm")}


def _reader(kind: str) -> Callable[..., dict[str, xr.Dataset]]:
    """Return the reader function of format ``kind`` (a key of :data:`_READERS`)."""
    module, name = _READERS[kind]
    return getattr(importlib.import_module(module), name)


def read_stream(path: str | os.PathLike[str], **options: Any) -> xr.Dataset:
    """Read a file that holds exactly one stream (after ``channels``/``group`` selection).

    Parameters
    ----------
    path : str or path-like
        The data file.
    **options
        As for :func:`read`.

    Returns
    -------
    xarray.Dataset
        The file's one stream, as :func:`read` returns it.

    Raises
    ------
    DataFileError
        If the file (selection) holds no or several streams; the message names them.
    """
    streams = read(path, **options)
    if len(streams) != 1:
        raise DataFileError(
            f"the file holds {len(streams)} streams, expected one: {list(streams)}",
            where={"file": str(path)},
            hint="select one with group=... (TDMS) or channels=..., or use read()")
    return next(iter(streams.values()))


def iter_stream(path: str | os.PathLike[str], *, chunk_samples: int = 1 << 20,
                channels: Sequence[str] | None = None, device: str | None = None,
                group: str | None = None, modules: Mapping[str, str] | None = None,
                fs: float | None = None, checksum: bool = True) -> Iterator[xr.Dataset]:
    """Yield one TDMS stream in consecutive windows, in memory bounded by ``chunk_samples``.

    Parameters
    ----------
    path : str or path-like
        A TDMS file (text formats are read whole: they are small next to binary logs).
    chunk_samples : int
        Samples per window.
    channels, device, group, modules, fs, checksum
        As for :func:`~rigval.acquisition.tdms.read_tdms`.

    Yields
    ------
    xarray.Dataset
        Stream windows; ``attrs["first_sample"]`` is the index of each window's first sample.

    Raises
    ------
    DataFileError
        For files that are not TDMS, or selections holding several streams.
    """
    from rigval.acquisition.tdms import iter_tdms

    if detect_format(path) != "tdms":
        raise DataFileError("streaming reads TDMS files only", where={"file": str(path)},
                            hint="read text files with read()")
    yield from iter_tdms(path, group=group, channels=channels, chunk_samples=chunk_samples,
                         device=device, modules=modules, fs=fs, checksum=checksum)
