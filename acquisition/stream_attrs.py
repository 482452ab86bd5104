"""Array attributes of a stream Dataset read back the same way in memory and from netCDF.

A stream keeps its tables (gaps, invalid samples, time fallbacks, file headers) as array
attributes of one entry per row (docs/formats.md). In memory such an attribute is a list or an
array; read back from netCDF, a one-entry array comes as a plain scalar (a ``str`` or a NumPy
scalar) and an absent one is missing. :func:`attr_list` turns all of these into one list.
Standard library only: ``rigval info`` imports it (through ``time_fallbacks``) before any data
is read.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

__all__ = ["attr_list"]


def attr_list(attrs: Mapping[str, Any], name: str) -> list[Any]:
    """Return an array attribute as a list of its entries (empty when absent).

    Parameters
    ----------
    attrs : mapping
        Attributes of a stream (``ds.attrs``), in memory or read back from netCDF.
    name : str
        The attribute, e.g. ``"gap_start_s"`` (its entries keep their own units and types).

    Returns
    -------
    list
        The entries in order; a scalar (netCDF's one entry) gives a list of one.
    """
    value = attrs.get(name, ())
    if isinstance(value, str) or not hasattr(value, "__iter__") or getattr(value, "ndim", 1) == 0:
        return [value]
    return list(value)
