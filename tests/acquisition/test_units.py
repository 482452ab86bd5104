"""One unit vocabulary: every name a reader writes is a unit the scene accepts, with its scale."""

from __future__ import annotations

import math

import pytest

from rigval.acquisition.errors import UnitError
from rigval.acquisition.units import (
    dimension,
    factor_between,
    factor_or_none,
    multiply,
    parse_unit,
    same_unit,
    udunits,
)

GRAVITY = 9.80665  # m s-2, standard gravity (ISO 80000-3)


@pytest.mark.parametrize(("ni_name", "written", "si_unit", "factor"), [
    ("millivolts", "mV", "V", 1e-3),
    ("g", "9.80665 m s-2", "m s-2", GRAVITY),
    ("microstrain", "1e-6", "1", 1e-6),
    ("degrees", "degree", "rad", math.pi / 180.0),
    ("mV/V", "mV/V", "V/V", 1e-3),
    ("Newton meters", "N m", "kg m2 s-2", 1.0),
    ("m/s^2", "m s-2", "m s-2", 1.0),
])
def test_reader_names_round_trip_into_arithmetic(ni_name: str, written: str, si_unit: str,
                                                 factor: float) -> None:
    assert udunits(ni_name) == written
    # the string a reader writes parses, and converts back by the independent SI factor
    assert factor_between(written, si_unit) == pytest.approx(factor, rel=1e-15)
    assert factor_between(si_unit, written) == pytest.approx(1.0 / factor, rel=1e-15)
    assert dimension(written) == dimension(si_unit)


def test_every_mapped_ni_name_is_accepted() -> None:
    from rigval.acquisition.units import _NI_NAMES
    for name in _NI_NAMES:
        parse_unit(udunits(name))  # raises UnitError if a reader could write an unknown unit


def test_prefixes_exponents_and_products() -> None:
    assert factor_between("kPa", "N m-2") == pytest.approx(1e3)
    assert factor_between("mm2", "m2") == pytest.approx(1e-6)
    assert factor_between("ms-1", "Hz") == pytest.approx(1e3)
    assert factor_between("us", "s") == pytest.approx(1e-6)
    assert factor_between("µm", "m") == pytest.approx(1e-6)
    assert factor_between("m.s^-2", "m s-2") == 1.0
    assert multiply("N", "m-2") == parse_unit("Pa")
    assert same_unit("Pa", "N m-2") and not same_unit("mV", "V") and not same_unit("rad", "1")


def test_wrong_units_are_refused_with_a_hint() -> None:
    with pytest.raises(UnitError, match="unknown unit factor 'foo'") as error:
        parse_unit("m foo")
    assert "SI prefix" in str(error.value)
    with pytest.raises(UnitError, match="different dimensions"):
        factor_between("N", "m")
    with pytest.raises(UnitError, match="offset"):
        factor_between("degC", "K")
    with pytest.raises(UnitError, match="more than one"):
        parse_unit("m/s/s")
    with pytest.raises(UnitError, match="unknown unit factor 'kdegree'"):
        parse_unit("kdegree")
    assert factor_or_none("V/V", "V") is None
    assert factor_or_none("kV", "V") == pytest.approx(1e3)
