"""Acquisition: read NI TDMS, NI-style CSV and LVM files into stream Datasets.

Entry points: :func:`read` (any format, detected from the content; returns a dict stream name ->
Dataset), :func:`read_stream` (exactly one stream), :func:`iter_stream` (bounded-memory windows of a
TDMS stream) and the format readers :func:`read_tdms`, :func:`read_csv`, :func:`read_lvm`. See
``docs/formats.md``.

Also home of rigval's shared basics, which every layer uses: :mod:`rigval.acquisition.errors`
(the error root and warnings; each layer adds its own errors, docs/errors.md),
:mod:`rigval.acquisition.units` (the one unit vocabulary), :mod:`rigval.acquisition.tables`
(strict TOML tables with key-path errors), :mod:`rigval.acquisition.lazy` (the packages' lazy
public API) and :mod:`rigval.acquisition.schema` (the stream schema every reader uses).
"""

from rigval.acquisition.errors import RigvalError
from rigval.acquisition.lazy import lazy_exports

#: Readers and the schema (numpy, xarray, pandas), imported on first use so that
#: ``import rigval.acquisition.errors`` (every command line start) stays light.
_LAZY = {"iter_stream": "reader", "read": "reader", "read_stream": "reader", "read_lvm": "lvm",
         "iter_tdms": "tdms", "read_tdms": "tdms", "read_csv": "text_csv",
         "Channel": "schema", "check_stream": "schema", "stream_dataset": "schema"}

__all__ = ["Channel", "RigvalError", "check_stream", "iter_stream", "iter_tdms", "read",
           "read_csv", "read_lvm", "read_stream", "read_tdms", "stream_dataset"]

__getattr__, __dir__ = lazy_exports(__name__, _LAZY, globals())
