"""Turn unit names written by NI software or in text headers into UDUNITS strings.

NI writes ``unit_string = "Volts"``, LVM headers ``Newtons`` or ``m/s^2``, CSV headers
``acc1 [m/s^2]``. Streams carry UDUNITS strings (docs/formats.md), so readers map the common NI
names and turn simple ``a/b^n`` forms into ``a b-n``; anything else is kept as written (and the
original text is always kept in the channel attribute ``units_in_file``).
"""

from __future__ import annotations

import re

__all__ = ["split_name_and_unit", "udunits"]

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
        Unit text from a file (``"Volts"``, ``"m/s^2"``, ``"V/V"``, ``""``).

    Returns
    -------
    str
        ``"V"``, ``"m s-2"``, ``"V/V"``; ``"1"`` for an empty unit; other text unchanged.
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
