"""Strict reading of TOML tables, with errors that name the file and the key path.

Every rigval file format written in TOML (the scene, docs/scene.md; its channel map,
docs/formats.md; the mechanism, docs/mechanism.md; drive laws, docs/predict.md) reads its tables
through one :class:`TableReader`, so that an unknown key, a wrong type or a missing key is
reported the same way everywhere: the key path (``bodies[0].mass``,
``streams.cdaq.channels.acc1.sensor``) starts the message and is ``where["key"]``, the file is
``where["file"]`` when known, the message says what was expected and what was found, and the hint
says how to fix it (at the least, which docs page describes the table). :func:`toml_value`
writes one value back as TOML text (for the files rigval writes: ``rigval init`` scenes,
identified mechanisms).
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from rigval.acquisition.errors import ConfigError

__all__ = ["REQUIRED", "TableReader", "key_path", "toml_value"]

#: Marker for :meth:`TableReader.get`: the key has no default and must be present.
REQUIRED: Any = ...

_KIND_NAMES = {str: "a string", float: "a number", int: "an integer", bool: "true or false",
               list: "an array", dict: "a table"}


def key_path(key: str, name: str | int) -> str:
    """Return the key path of ``name`` inside the table at ``key`` (``a.b``, ``a[0]``, ``b``)."""
    if isinstance(name, int):
        return f"{key}[{name}]"
    return f"{key}.{name}" if key else name


def _kind_name(kind: type | tuple[type, ...]) -> str:
    kinds = kind if isinstance(kind, tuple) else (kind,)
    return " or ".join(_KIND_NAMES.get(k, k.__name__) for k in kinds)


@dataclass(frozen=True)
class TableReader:
    """Checks the tables of one TOML file format, raising ``error`` with the key path.

    Parameters
    ----------
    error : type of ConfigError
        Class raised (``SceneError``, ``MechanismError``, ``ChannelMapError``, ...).
    docs : str
        The docs page describing the format (``"docs/scene.md"``), named in default hints.
    file : str, optional
        The file being read, put in every error's ``where``.
    """

    error: type[ConfigError] = ConfigError
    docs: str = ""
    file: str | None = None

    def fail(self, key: str, message: str, hint: str | None = None, **extra: Any) -> ConfigError:
        """Return (for the caller to raise) an error at ``key``: ``"<key>: <message>"``."""
        text = f"{key}: {message}" if key else message
        default = f"see {self.docs} for this table" if self.docs else None
        return self.error(text, where={"file": self.file, "key": key or None},
                          hint=hint or default, **extra)

    def table(self, value: Any, key: str) -> Mapping[str, Any]:
        """Return ``value`` if it is a table, else raise naming ``key``."""
        if not isinstance(value, Mapping):
            raise self.fail(key, f"expected a table, got {type(value).__name__} {value!r}")
        return value

    def check_keys(self, table: Any, key: str, allowed: Collection[str],
                   required: Sequence[str] = (), *, what: str = "") -> Mapping[str, Any]:
        """Check that a table holds only ``allowed`` keys and every ``required`` one.

        Parameters
        ----------
        table : Any
            The value at ``key`` (refused unless it is a table).
        key : str
            Its key path (``""`` for the file's top level).
        allowed, required : collection of str
            Keys allowed and keys that must be present.
        what : str, optional
            What the table is, for the message (``"for a linear channel"``).

        Returns
        -------
        mapping
            The table.
        """
        table = self.table(table, key)
        unknown = sorted(set(table) - set(allowed))
        if unknown:
            suffix = f" {what}" if what else ""
            raise self.fail(key_path(key, unknown[0]), f"unknown key {unknown[0]!r}{suffix}",
                            hint=f"allowed keys here: {', '.join(sorted(allowed))}"
                                 + (f" ({self.docs})" if self.docs else ""))
        for name in required:
            if name not in table:
                suffix = f" {what}" if what else ""
                raise self.fail(key_path(key, name), f"missing key {name!r}{suffix}")
        return table

    def get(self, table: Mapping[str, Any], name: str, key: str, kind: type | tuple[type, ...],
            default: Any = REQUIRED, choices: Sequence[Any] | None = None, *,
            hint: str | None = None) -> Any:
        """Return ``table[name]`` checked against a type (and a set of choices).

        Integers are accepted (and returned as float) where a number is asked for; booleans only
        where ``bool`` is; floats must be finite (TOML has ``nan`` and ``inf``).

        Parameters
        ----------
        table : mapping
            The table.
        name : str
            The key inside it.
        key : str
            The table's key path.
        kind : type or tuple of type
            Expected type(s): ``str``, ``float``, ``int``, ``bool``, ``list``, ``dict``.
        default : Any, optional
            Returned when the key is absent; :data:`REQUIRED` (the default) makes it required.
        choices : sequence, optional
            Allowed values.
        hint : str, optional
            How to fix a missing or wrong value (default: the docs page).
        """
        path = key_path(key, name)
        if name not in table:
            if default is REQUIRED:
                raise self.fail(path, f"missing required key {name!r}", hint)
            return default
        value = table[name]
        if kind is float and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        if isinstance(value, bool) and kind is not bool:
            raise self.fail(path, f"expected {_kind_name(kind)}, got {value!r}", hint)
        if not isinstance(value, kind):
            raise self.fail(path, f"expected {_kind_name(kind)}, got {type(value).__name__} "
                                  f"{value!r}", hint)
        if choices is not None and value not in choices:
            raise self.fail(path, f"expected one of {', '.join(map(repr, choices))}, got "
                                  f"{value!r}", hint)
        if isinstance(value, float) and not math.isfinite(value):
            raise self.fail(path, f"expected a finite number, got {value!r}",
                            hint="write a finite number (TOML's nan and inf are not values here)")
        return value

    def number(self, value: Any, key: str, *, minimum: float | None = None,
               why_minimum: str | None = None, largest: float | None = None,
               why_largest: str | None = None) -> float:
        """Return a finite number (an int is accepted) in the range asked for.

        The number is at least ``minimum`` and at most ``largest`` in magnitude; ``why_minimum``
        and ``why_largest`` are the hints given when it is outside.
        """
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.fail(key, f"expected a number, got {value!r}",
                            hint="write a plain number in SI units"
                                 + (f" ({self.docs})" if self.docs else ""))
        number = float(value)
        if not math.isfinite(number):
            raise self.fail(key, f"expected a finite number, got {value!r}",
                            hint="write a finite number (TOML's nan and inf are not values here)")
        if minimum is not None and number < minimum:
            raise self.fail(key, f"expected a value >= {minimum}, got {number}", hint=why_minimum)
        if largest is not None and abs(number) > largest:
            raise self.fail(key, f"expected a magnitude of at most {largest:g}, got {number:g}",
                            hint=why_largest)
        return number

    def text(self, value: Any, key: str) -> str:
        """Return a non-empty string."""
        if not isinstance(value, str) or not value.strip():
            raise self.fail(key, f"expected a non-empty string, got {value!r}",
                            hint="write a quoted name")
        return value

    def path(self, value: Any, key: str) -> str:
        """Return a non-empty string without control characters (a file path)."""
        text = self.text(value, key)
        if any(ord(c) < 32 or ord(c) == 127 for c in text):
            raise self.fail(key, f"the path {text!r} holds a control character",
                            hint="write the file's path as plain text (no NUL, tab or line end)")
        longest = max(len(part.encode()) for part in re.split(r"[/\\]", text))
        if longest > MAX_FILE_NAME or len(text.encode()) > MAX_PATH:
            raise self.fail(key, f"the path ({len(text)} characters, a name of {longest} bytes) "
                            "is longer than file systems allow",
                            hint=f"file names have at most {MAX_FILE_NAME} bytes, paths "
                                 f"{MAX_PATH}; check the value")
        return text

    def name(self, value: Any, key: str) -> str:
        """Return a name that can label netCDF groups and variables and report files.

        At most :data:`MAX_NAME` characters, no ``/`` and no control characters.
        """
        text = self.text(value, key)
        if len(text) > MAX_NAME or "/" in text or any(ord(c) < 32 or ord(c) == 127
                                                      for c in text):
            raise self.fail(key, f"the name {text[:40]!r}{'...' if len(text) > 40 else ''} "
                            f"({len(text)} characters) is not a usable name",
                            hint=f"use at most {MAX_NAME} characters, without '/' and control "
                                 "characters (names label netCDF groups, variables and files)")
        return text


#: Longest name (of a comparison, stream or channel) accepted, characters.
MAX_NAME = 256
#: Longest file name and path (bytes) file systems take (Linux NAME_MAX and PATH_MAX).
MAX_FILE_NAME, MAX_PATH = 255, 4096


def toml_value(value: Any, key: str = "") -> str:
    """Return the TOML text of one value.

    Parameters
    ----------
    value : str, bool, int, float, mapping or sequence
        A string (written as a basic string, escaped as JSON escapes it, which TOML reads back),
        a boolean, a finite number (floats with ``repr``, so they read back exactly), an inline
        table or an array of these.
    key : str
        Key path of the value, for the error.

    Returns
    -------
    str

    Raises
    ------
    ConfigError
        A non-finite float or a value of another type.
    """
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        if isinstance(value, float) and not math.isfinite(value):
            raise ConfigError(f"{key or 'value'}: not a finite number: {value!r}",
                              where={"key": key} if key else None,
                              hint="TOML files written by rigval hold finite numbers")
        return repr(float(value)) if isinstance(value, float) else str(int(value))
    if isinstance(value, Mapping):
        return "{ " + ", ".join(f"{k} = {toml_value(v, key_path(key, str(k)))}"
                                for k, v in value.items()) + " }"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(toml_value(v, key_path(key, i)) for i, v in enumerate(value)) + "]"
    raise ConfigError(f"{key or 'value'}: cannot write {value!r} as a TOML value",
                      where={"key": key} if key else None,
                      hint="write strings, numbers, booleans, arrays and tables")
