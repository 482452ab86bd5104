"""Acquisition: read NI TDMS, NI-style CSV and LVM files into stream Datasets.

Entry points: :func:`read` (any format, detected from the content; returns a dict stream name ->
Dataset), :func:`read_stream` (exactly one stream), :func:`iter_stream` (bounded-memory windows of a
TDMS stream) and the format readers :func:`read_tdms`, :func:`read_csv`, :func:`read_lvm`. See
``docs/formats.md``.

Also home of rigval's shared basics: :mod:`rigval.acquisition.errors` (the error classes) and
:mod:`rigval.acquisition.schema` (the stream schema every reader uses).
"""

from rigval.acquisition.errors import RigvalError
from rigval.acquisition.lvm import read_lvm
from rigval.acquisition.read import iter_stream, read, read_stream
from rigval.acquisition.schema import Channel, check_stream, stream_dataset
from rigval.acquisition.tdms import iter_tdms, read_tdms
from rigval.acquisition.text_csv import read_csv

__all__ = ["Channel", "RigvalError", "check_stream", "iter_stream", "iter_tdms", "read",
           "read_csv", "read_lvm", "read_stream", "read_tdms", "stream_dataset"]
