"""Acquisition: read NI TDMS, NI-style CSV and LVM files into stream Datasets.

Also home of rigval's shared basics: :mod:`rigval.acquisition.errors` (the error classes) and
:mod:`rigval.acquisition.schema` (the stream schema every reader uses).
"""

from rigval.acquisition.errors import RigvalError
from rigval.acquisition.schema import Channel, check_stream, stream_dataset

__all__ = ["Channel", "RigvalError", "check_stream", "stream_dataset"]
