"""Values made ready for JSON, the same way in every file rigval writes.

:func:`json_ready` turns what rigval's records hold into what :func:`json.dumps` writes as
standard JSON: numpy scalars become Python numbers, NaN and infinities ``null`` (standard JSON
has no NaN), paths strings, dataclasses and mappings objects with string keys, tuples lists. The
virtual rig's truth record, a run's ``metrics.json`` and a campaign's manifests use it.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from pathlib import PurePath
from typing import Any

import numpy as np

__all__ = ["json_ready"]

#: Types :func:`json_ready` returns as they are (a float: when finite), checked by identity.
_PLAIN = frozenset({float, int, str, bool, type(None)})


def json_ready(value: Any) -> Any:
    """Return ``value`` as plain Python values that :func:`json.dumps` writes as standard JSON.

    Parameters
    ----------
    value : Any
        A number, string, bool, None, path, numpy scalar, dataclass instance, mapping, list or
        tuple (nested in any way).

    Returns
    -------
    Any
        The same content: numpy scalars as Python numbers, non-finite floats as None, paths as
        strings, dataclasses and mappings as dicts with string keys, lists and tuples as lists.
        Other values are returned as they are.
    """
    kind = type(value)
    if kind in _PLAIN:  # most values: their checks first (numpy scalars are subclasses)
        return value if kind is not float or math.isfinite(value) else None
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: json_ready(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, Mapping):
        return {str(k): json_ready(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [json_ready(v) for v in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, PurePath):
        return str(value)
    return value
