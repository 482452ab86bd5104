"""rigval's one unit vocabulary: names as files write them, UDUNITS strings, and their dimensions.

Every layer uses this module, so a unit a reader writes is a unit the scene accepts.

Names
    NI writes ``unit_string = "Volts"``, LVM headers ``Newtons`` or ``m/s^2``, CSV headers
    ``acc1 [m/s^2]``. :func:`udunits` maps the common NI names and turns ``a/b^n`` into ``a b-n``;
    anything else is kept as written (the original text is always kept in the channel attribute
    ``units_in_file``, docs/formats.md).
Arithmetic
    A UDUNITS string (docs/formats.md) is a product of space-separated factors: a number
    (``9.80665``, ``1e-6``), or a symbol with an optional SI prefix and an optional integer exponent
    (``mV``, ``m s-2``, ``kg m2``, ``s^-1``); one ``/`` divides by everything after it (``mV/V``).
    :func:`parse_unit` reduces it to a :class:`Unit`: a scale times exponents of m, kg, s, A, K and
    rad (kept apart from 1, so that an angle is not mistaken for a strain). ``"N m-2"`` equals
    ``"Pa"``; ``"mV"`` is 1e-3 ``"V"``; ``"degree"`` is pi/180 ``"rad"``; ``"9.80665 m s-2"`` is
    one standard gravity.

Scales compare with a relative tolerance of 1e-12: far above the rounding of a product of a few
factors (~1e-16 each), far below any real difference between two units.
"""

from __future__ import annotations

import math
import re
from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass, field

from rigval.acquisition.errors import UnitError

__all__ = [
    "Unit",
    "dimension",
    "factor_between",
    "factor_or_none",
    "multiply",
    "parse_unit",
    "same_dimension",
    "same_unit",
    "split_name_and_unit",
    "udunits",
]

# --- names as NI software writes them -------------------------------------------------------

_NI_NAMES = {
    "volts": "V", "volt": "V", "v": "V", "millivolts": "mV", "mv": "mV",
    "amps": "A", "amperes": "A",
    "strain": "1", "ε": "1", "microstrain": "1e-6", "µε": "1e-6", "ue": "1e-6",
    "newtons": "N", "newton meters": "N m", "nm": "N m", "n·m": "N m", "n*m": "N m",
    "pascals": "Pa", "deg c": "degC", "°c": "degC", "degrees": "degree", "deg": "degree",
    "radians": "rad", "seconds": "s", "sec": "s", "hertz": "Hz", "ticks": "1", "counts": "1",
    "g": "9.80665 m s-2", "g's": "9.80665 m s-2",
    "v/v": "V/V", "mv/v": "mV/V",
}

_RATIO = re.compile(
    r"^\s*([A-Za-zµ°]+(?:\s*[A-Za-zµ°]+)*)\s*/\s*([A-Za-zµ°]+)\s*(?:\^\s*(\d+))?\s*$")
_BRACKETED = re.compile(r"^(?P<name>.*?)\s*[\[(](?P<unit>[^\])]*)[\])]\s*$")


def udunits(text: str) -> str:
    """Return the UDUNITS form of a unit name as NI software writes it.

    Parameters
    ----------
    text : str
        Unit text from a file (``"Volts"``, ``"m/s^2"``, ``"V/V"``, ``"g"``, ``""``).

    Returns
    -------
    str
        ``"V"``, ``"m s-2"``, ``"V/V"``, ``"9.80665 m s-2"``; ``"1"`` for an empty unit; other
        text unchanged. Every name mapped here is accepted by :func:`parse_unit`.
    """
    stripped = text.strip()
    if not stripped:
        return "1"
    known = _NI_NAMES.get(stripped.lower())
    if known is not None:
        return known
    ratio = _RATIO.match(stripped)
    if ratio and ratio.group(1) != ratio.group(2):
        power = ratio.group(3) or "1"
        return f"{ratio.group(1)} {ratio.group(2)}-{power}"
    return stripped


def split_name_and_unit(header: str) -> tuple[str, str | None]:
    """Split a column header like ``"acc1 [m/s^2]"`` or ``"tor3 (V/V)"`` into name and unit.

    Returns
    -------
    tuple of str and str or None
        The name without the unit, and the unit text as written (None when there is none).
    """
    match = _BRACKETED.match(header.strip())
    if match and match.group("name"):
        return match.group("name").strip(), match.group("unit").strip()
    return header.strip(), None


# --- arithmetic -----------------------------------------------------------------------------

#: Each symbol as (scale, exponents of the base symbols m, kg, s, A, K, rad).
_SYMBOLS: Mapping[str, tuple[float, Mapping[str, int]]] = {
    "1": (1.0, {}),
    "m": (1.0, {"m": 1}),
    "g": (1e-3, {"kg": 1}),
    "kg": (1.0, {"kg": 1}),
    "s": (1.0, {"s": 1}),
    "min": (60.0, {"s": 1}),
    "h": (3600.0, {"s": 1}),
    "A": (1.0, {"A": 1}),
    "K": (1.0, {"K": 1}),
    "degC": (1.0, {"K": 1}),
    "rad": (1.0, {"rad": 1}),
    "degree": (math.pi / 180.0, {"rad": 1}),
    "Hz": (1.0, {"s": -1}),
    "N": (1.0, {"kg": 1, "m": 1, "s": -2}),
    "Pa": (1.0, {"kg": 1, "m": -1, "s": -2}),
    "J": (1.0, {"kg": 1, "m": 2, "s": -2}),
    "W": (1.0, {"kg": 1, "m": 2, "s": -3}),
    "C": (1.0, {"A": 1, "s": 1}),
    "V": (1.0, {"kg": 1, "m": 2, "s": -3, "A": -1}),
    "Ohm": (1.0, {"kg": 1, "m": 2, "s": -3, "A": -2}),
}
#: Symbols that take no SI prefix (a prefixed "kdegree" or "mmin" is a typing error).
_UNPREFIXED = frozenset({"1", "kg", "min", "h", "degC", "degree", "rad"})
_PREFIXES = {"p": 1e-12, "n": 1e-9, "u": 1e-6, "µ": 1e-6, "μ": 1e-6, "m": 1e-3, "c": 1e-2,
             "k": 1e3, "M": 1e6, "G": 1e9}
_NUMBER = re.compile(r"^[+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?$")
_FACTOR = re.compile(r"^([A-Za-zµμ]+)(?:\^?(-?\d+))?$")
_SCALE_RTOL = 1e-12


@dataclass(frozen=True)
class Unit:
    """A unit as a scale times integer exponents of the base symbols m, kg, s, A, K, rad.

    Attributes
    ----------
    scale : float
        Size of the unit in the base symbols (1e-3 for ``mV``, 9.80665 for ``9.80665 m s-2``).
    dims : dict of str to int
        Non-zero exponents of the base symbols (``{"m": 1, "s": -2}``).
    """

    scale: float = 1.0
    dims: Mapping[str, int] = field(default_factory=dict)

    def __mul__(self, other: Unit) -> Unit:
        total = Counter(self.dims)
        total.update(other.dims)
        return Unit(self.scale * other.scale, {k: v for k, v in total.items() if v})

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Unit):
            return NotImplemented
        return dict(self.dims) == dict(other.dims) and math.isclose(
            self.scale, other.scale, rel_tol=_SCALE_RTOL)

    def __hash__(self) -> int:
        return hash(tuple(sorted(self.dims.items())))


def _symbol(name: str, factor: str, unit: str) -> tuple[float, Mapping[str, int]]:
    """Return (scale, dims) of one symbol, with an SI prefix if it has one."""
    if name in _SYMBOLS:
        return _SYMBOLS[name]
    for prefix, size in _PREFIXES.items():
        rest = name[len(prefix):]
        if name.startswith(prefix) and rest in _SYMBOLS and rest not in _UNPREFIXED:
            scale, dims = _SYMBOLS[rest]
            return size * scale, dims
    raise _unknown(factor, unit)


def _unknown(factor: str, unit: str) -> UnitError:
    """Return the error for a factor that is neither a number nor a known symbol."""
    return UnitError(
        f"unknown unit factor {factor!r} in {unit!r}",
        hint="write units as UDUNITS factors: a number, or one of "
             f"{', '.join(s for s in _SYMBOLS if s != '1')} with an optional SI prefix "
             f"({', '.join(p for p in _PREFIXES if p != 'μ')}) and integer exponent, e.g. "
             "'m s-2', 'mV', 'N m' or '9.80665 m s-2'")


def parse_unit(unit: str) -> Unit:
    """Return a UDUNITS-style unit string as a :class:`Unit`.

    Parameters
    ----------
    unit : str
        ``"m s-2"``, ``"N m"``, ``"mV/V"``, ``"1e-6"``, ``"degree"``; ``"1"`` or ``""`` is
        dimensionless.

    Raises
    ------
    UnitError
        If a factor is neither a number nor a known (prefixed) symbol, or ``/`` appears twice.
    """
    parts = unit.split("/")
    if len(parts) > 2:
        raise UnitError(f"unit {unit!r} has more than one '/'",
                        hint="write the denominator with negative exponents, e.g. 'm s-2'")
    total = Unit()
    for sign, part in zip((1, -1), parts, strict=False):
        # '.' and '*' separate factors too, but a '.' inside a number is a decimal point
        for factor in re.sub(r"(?<=[A-Za-zµμ\d])[.*](?=[A-Za-zµμ])", " ", part).replace(
                "*", " ").split():
            if _NUMBER.match(factor):
                value = float(factor)
                if value == 0:
                    raise UnitError(f"zero unit factor {factor!r} in {unit!r}",
                                    hint="a unit's numeric factor must be positive")
                total = total * Unit(value ** sign)
                continue
            match = _FACTOR.match(factor)
            if not match:
                raise _unknown(factor, unit)
            scale, dims = _symbol(match.group(1), factor, unit)
            power = sign * int(match.group(2) or 1)
            total = total * Unit(scale ** power, {k: v * power for k, v in dims.items()})
    return total


def dimension(unit: str) -> dict[str, int]:
    """Return a unit string as exponents of the base symbols ``m, kg, s, A, K, rad``.

    The scale is dropped: ``dimension("mV") == dimension("V")``. Use :func:`same_unit` or
    :func:`factor_between` to compare units.

    Raises
    ------
    UnitError
        If a factor is unknown (see :func:`parse_unit`).
    """
    return dict(parse_unit(unit).dims)


def multiply(first: str, second: str) -> Unit:
    """Return the product of two unit strings (scale and dimension)."""
    return parse_unit(first) * parse_unit(second)


def same_dimension(first: str, second: str) -> bool:
    """Whether two unit strings measure the same kind of quantity (``"mV"`` and ``"V"`` do)."""
    return parse_unit(first).dims == parse_unit(second).dims


def same_unit(first: str, second: str) -> bool:
    """Whether two unit strings denote the same unit (``"Pa"`` is ``"N m-2"``, not ``"kPa"``)."""
    return parse_unit(first) == parse_unit(second)


def factor_between(source: str, target: str) -> float:
    """Return the number that turns a value in ``source`` units into ``target`` units.

    Parameters
    ----------
    source, target : str
        Unit strings of the same dimension (``"mV"``, ``"V"``).

    Returns
    -------
    float
        ``value_in_target = factor * value_in_source`` (1e-3 for ``"mV"`` to ``"V"``).

    Raises
    ------
    UnitError
        If the dimensions differ, or one of them is the offset unit ``degC`` and the other is not
        (a temperature in degC cannot be scaled to K).
    """
    first, second = parse_unit(source), parse_unit(target)
    if first.dims != second.dims:
        raise UnitError(f"cannot convert {source!r} to {target!r}: different dimensions "
                        f"({dict(first.dims) or 'none'} vs {dict(second.dims) or 'none'})")
    if ("degC" in source.split()) != ("degC" in target.split()):
        raise UnitError(f"cannot convert {source!r} to {target!r}: degC has an offset",
                        hint="convert temperatures with their offset, not a factor")
    return first.scale / second.scale


def factor_or_none(source: str, target: str) -> float | None:
    """Return :func:`factor_between` ``(source, target)``, or None if it cannot convert.

    For questions such as "is this channel in volts, and how many volts per unit?": ``"mV"``
    gives 1e-3, ``"kV"`` 1e3, ``"V/V"`` or an unknown name None.
    """
    try:
        return factor_between(source, target)
    except UnitError:
        return None
