"""Acquisition: read NI TDMS, NI-style CSV and LVM files into stream Datasets.

Entry points: :func:`read` (any format, detected from the content; returns a dict stream name ->
Dataset), :func:`read_stream` (exactly one stream), :func:`iter_stream` (bounded-memory windows of a
TDMS stream) and the format readers :func:`read_tdms`, :func:`read_csv`, :func:`read_lvm`. See
``docs/formats.md``.

Also home of rigval's shared basics: :mod:`rigval.acquisition.errors` (the error classes) and
:mod:`rigval.acquisition.schema` (the stream schema every reader uses).
"""

from importlib import import_module
from typing import Any

from rigval.acquisition.errors import RigvalError

#: Readers and the schema (numpy, xarray, pandas), imported on first use so that
#: ``import rigval.acquisition.errors`` (every command line start) stays light.
_LAZY = {"iter_stream": "reader", "read": "reader", "read_stream": "reader", "read_lvm": "lvm",
         "iter_tdms": "tdms", "read_tdms": "tdms", "read_csv": "text_csv",
         "Channel": "schema", "check_stream": "schema", "stream_dataset": "schema"}

__all__ = ["Channel", "RigvalError", "check_stream", "iter_stream", "iter_tdms", "read",
           "read_csv", "read_lvm", "read_stream", "read_tdms", "stream_dataset"]


def __getattr__(name: str) -> Any:
    """Import a reader on first access (PEP 562)."""
    if name in _LAZY:
        return getattr(import_module(f"rigval.acquisition.{_LAZY[name]}"), name)
    raise AttributeError(f"module 'rigval.acquisition' has no attribute {name!r}")


def __dir__() -> list[str]:
    """List the module's names including the lazily imported readers (for ``dir`` and IDEs)."""
    return sorted(set(globals()) | set(_LAZY))
