"""Issue rigval's data warnings with the same what / where / how-to-fix text as its errors."""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from typing import Any

from rigval.acquisition.errors import DataWarning

__all__ = ["warn_data"]


def warn_data(message: str, *, where: Mapping[str, Any] | None = None, hint: str | None = None,
              stacklevel: int = 3) -> None:
    """Warn with a :class:`~rigval.acquisition.errors.DataWarning`.

    Parameters
    ----------
    message : str
        What happened, with counts (recovered and expected samples, ...).
    where : mapping, optional
        File, channel, key; entries that are None are left out.
    hint : str, optional
        What to do about it.
    stacklevel : int
        As for :func:`warnings.warn`, counted from the caller of this function.
    """
    text = message
    place = {k: v for k, v in (where or {}).items() if v is not None}
    if place:
        text += " (" + ", ".join(f"{k}: {v}" for k, v in place.items()) + ")"
    if hint:
        text += f". How to fix: {hint}"
    warnings.warn(DataWarning(text), stacklevel=stacklevel + 1)
