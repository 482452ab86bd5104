"""Device facts (NI 9237 delay and rates) and the piecewise time axis."""

from __future__ import annotations

import numpy as np
import pytest

from rigval.acquisition.devices import (
    coerce_rate,
    get_device,
    get_module,
    ni9237_input_delay,
    rate_divider,
)
from rigval.acquisition.errors import ChannelNotFoundError
from rigval.acquisition.timebase import Block, TimeBase, exact_increment


def test_ni9237_input_delay_matches_the_published_figures() -> None:
    assert ni9237_input_delay(50_000) == pytest.approx(0.80e-3, abs=0.01e-3)
    assert ni9237_input_delay(10_000) == pytest.approx(4.0e-3, abs=0.01e-3)
    assert ni9237_input_delay(2_000) == pytest.approx(20.0e-3, abs=0.01e-3)
    assert ni9237_input_delay(50_000 / 31) == pytest.approx(24.8e-3, abs=0.02e-3)


def test_delta_sigma_rates_are_coerced_up_to_master_over_n() -> None:
    module = get_module("ni9237")
    assert coerce_rate(module, 1000.0) == pytest.approx(50_000 / 31)  # 1612.9 S/s
    assert coerce_rate(module, 5000.0) == 5000.0
    assert coerce_rate(module, 4000.0) == pytest.approx(50_000 / 12)
    assert rate_divider(module, 1 / 0.00062) == 31
    assert rate_divider(module, 1000.0) is None
    assert coerce_rate(get_module("NI 9215"), 1234.5) == 1234.5
    with pytest.raises(ValueError, match="at most"):
        coerce_rate(module, 60_000.0)


def test_profiles_know_the_rig_devices() -> None:
    wls = get_device("wls-9163")
    assert (wls.default_module, wls.wireless) == ("NI 9237", True)
    assert get_device("cDAQ 9172").default_module is None
    with pytest.raises(ChannelNotFoundError, match="Available: cDAQ-9172, WLS-9163"):
        get_device("PXIe-1071")


def test_rounded_increments_are_recognised_and_exact_ones_left_alone() -> None:
    assert exact_increment(1.04167e-05) == 1 / 96_000
    assert exact_increment(1.95313e-05) == 1 / 51_200
    assert exact_increment(0.000977, decimals=6) == 1 / 1024
    for exact in (0.00062, 1e-3, 2e-5, 1 / 3000, 9.999999999999999e-05):
        assert exact_increment(exact) is None


def test_timebase_with_a_gap_gives_times_segments_and_ranges() -> None:
    tb = TimeBase([Block(0, 5, 0.0, 0.1), Block(5, 3, 2.0, 0.1)])
    np.testing.assert_allclose(tb.times(), [0, 0.1, 0.2, 0.3, 0.4, 2.0, 2.1, 2.2])
    np.testing.assert_allclose(tb.times(3, 6), [0.3, 0.4, 2.0])
    np.testing.assert_array_equal(tb.segments(3, 7), [0, 0, 1, 1])
    assert tb.index_range(0.25, 2.05) == (3, 6)
    assert tb.index_range(None, 0.1) == (0, 2)
    assert tb.index_range(1.0, 1.5) == (0, 0)
