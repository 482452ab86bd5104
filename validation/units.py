"""Just enough unit algebra to check that a comparison's two sides have the same unit.

Units are UDUNITS-style strings as rigval writes them: space-separated factors, each a symbol
with an optional integer exponent (``"m s-2"``, ``"N m"``, ``"kg m2"``, ``"m-2"``, ``"1"``). A
unit is reduced to exponents of the SI base units plus ``rad`` (kept separate, so that an angle is
not mistaken for a strain), which makes ``"N m-2"`` and ``"Pa"`` equal.
"""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Mapping

from rigval.acquisition.errors import UnitError

__all__ = ["dimension", "multiply", "same_unit"]

#: Each known symbol as exponents of m, kg, s, A, rad.
_SYMBOLS: Mapping[str, Mapping[str, int]] = {
    "1": {},
    "m": {"m": 1},
    "kg": {"kg": 1},
    "s": {"s": 1},
    "A": {"A": 1},
    "rad": {"rad": 1},
    "Hz": {"s": -1},
    "N": {"kg": 1, "m": 1, "s": -2},
    "Pa": {"kg": 1, "m": -1, "s": -2},
    "J": {"kg": 1, "m": 2, "s": -2},
    "W": {"kg": 1, "m": 2, "s": -3},
    "V": {"kg": 1, "m": 2, "s": -3, "A": -1},
}

_FACTOR = re.compile(r"^([A-Za-z]+|1)(?:\^?(-?\d+))?$")


def dimension(unit: str) -> dict[str, int]:
    """Return a unit string as exponents of the base symbols ``m, kg, s, A, rad``.

    Parameters
    ----------
    unit : str
        UDUNITS-style unit such as ``"m s-2"`` or ``"N m"``; ``"1"`` or ``""`` is dimensionless.

    Raises
    ------
    UnitError
        If a factor is not one of the known symbols.
    """
    total: Counter[str] = Counter()
    for factor in unit.replace(".", " ").replace("*", " ").split():
        match = _FACTOR.match(factor)
        if not match or match.group(1) not in _SYMBOLS:
            raise UnitError(
                f"unknown unit factor {factor!r} in {unit!r}",
                hint=f"write units as UDUNITS factors of {', '.join(_SYMBOLS)} with integer "
                     "exponents, e.g. 'm s-2' or 'N m'",
            )
        power = int(match.group(2) or 1)
        for base, exponent in _SYMBOLS[match.group(1)].items():
            total[base] += exponent * power
    return {base: exponent for base, exponent in total.items() if exponent}


def multiply(first: str, second: str) -> dict[str, int]:
    """Return the dimension of the product of two units."""
    total = Counter(dimension(first))
    total.update(dimension(second))
    return {base: exponent for base, exponent in total.items() if exponent}


def same_unit(first: str, second: str) -> bool:
    """Whether two unit strings denote the same unit (``"Pa"`` and ``"N m-2"`` do)."""
    return dimension(first) == dimension(second)
