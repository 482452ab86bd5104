"""rigval's error root, its warnings, and the errors of the acquisition layer.

Every error is a :class:`RigvalError` and also the built-in exception a caller would expect, so that
``except KeyError`` or ``except OSError`` keeps working. Each layer defines its own errors next to
its code, all rooted here (docs/errors.md lists them all):

=============================  =================  ==========================================
class                          also a             raised for
=============================  =================  ==========================================
:class:`DataFileError`         ``OSError``        unreadable, truncated, wrong-format files
:class:`ChannelNotFoundError`  ``KeyError``       an absent channel, group, body or output
:class:`ConfigError`           ``ValueError``     a bad option or configuration (key path)
:class:`ChannelMapError`       ``ValueError``     a bad ``[streams]`` channel map (key path)
:class:`UnitError`             ``ValueError``     missing, unknown or incompatible units
:class:`DataError`             ``ValueError``     data values that cannot be processed
=============================  =================  ==========================================

:mod:`rigval.processing.errors` adds ``AlignmentError``; :mod:`rigval.model.errors` adds
``MechanismError``, ``ModelError``, ``AssemblyError`` and ``SingularityError``;
:mod:`rigval.validation.errors` adds ``SceneError``.

Each error carries three parts, kept as attributes so that programs can use them and so that they
survive pickling (errors travel back from dask workers intact):

``message``
    What went wrong, with expected and actual values.
``where``
    Where it went wrong: a mapping such as
    ``{"file": ..., "channel": ..., "key": ..., "time_s": ...}``.
``hint``
    How to fix it.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

__all__ = [
    "ChannelMapError",
    "ChannelNotFoundError",
    "ConfigError",
    "DataError",
    "DataFileError",
    "DataWarning",
    "NumericsWarning",
    "RigvalError",
    "RigvalWarning",
    "UnitError",
]


def _rebuild(cls: type[RigvalError], message: str, where: dict[str, Any], hint: str | None,
             extra: dict[str, Any]) -> RigvalError:
    """Recreate an error from its fields (the pickling counterpart of ``__reduce__``)."""
    return cls(message, where=where, hint=hint, **extra)


class RigvalError(Exception):
    """Base class of every error rigval raises.

    Parameters
    ----------
    message : str
        What went wrong, with expected and actual values.
    where : mapping, optional
        Where it went wrong (file, group, channel, key path, time in s, angle in rad, ...). Entries
        whose value is None are left out.
    hint : str, optional
        How to fix it.
    **extra
        Further fields kept as attributes (for example ``available`` for a missing channel).
    """

    def __init__(self, message: str, *, where: Mapping[str, Any] | None = None,
                 hint: str | None = None, **extra: Any) -> None:
        super().__init__(message)
        self.message = message
        self.where = {k: v for k, v in (where or {}).items() if v is not None}
        self.hint = hint
        self.extra = dict(extra)
        for name, value in extra.items():
            setattr(self, name, value)

    def __reduce__(self) -> tuple[Any, ...]:
        return (_rebuild, (type(self), self.message, self.where, self.hint, self.extra))

    def _details(self) -> str:
        """Return extra text placed between the location and the hint (none by default)."""
        return ""

    def __str__(self) -> str:
        text = self.message
        if self.where:
            text += " (" + ", ".join(f"{k}: {v}" for k, v in self.where.items()) + ")"
        text += self._details()
        if self.hint:
            text += f". How to fix: {self.hint}"
        return text


class DataFileError(RigvalError, OSError):
    """A file cannot be read: missing, not the expected format, truncated beyond use."""


class ChannelNotFoundError(RigvalError, KeyError):
    """A named channel, group, body, point or output does not exist.

    Pass ``available=[...]`` so that the message lists what does exist.
    """

    def _details(self) -> str:
        available = self.extra.get("available")
        if available is None:
            return ""
        return f". Available: {', '.join(map(str, available)) or 'none'}"


class ConfigError(RigvalError, ValueError):
    """A configuration (scene, mechanism file, option) is invalid; ``where`` names the key path."""


class ChannelMapError(ConfigError):
    """A channel map (a scene's ``[streams]`` tables) is invalid; ``where`` names the key path."""


class UnitError(RigvalError, ValueError):
    """Units are missing, unknown or incompatible with what a conversion needs."""


class DataError(RigvalError, ValueError):
    """Data values cannot be processed (too short, all invalid, non-monotonic time, ...)."""


class RigvalWarning(UserWarning):
    """Base class of rigval's warnings."""


class DataWarning(RigvalWarning):
    """Data were recovered only in part or needed a fallback (truncation, missing metadata)."""


class NumericsWarning(RigvalWarning):
    """A numerical result is less trustworthy than usual (ill-conditioning, redundancy)."""
