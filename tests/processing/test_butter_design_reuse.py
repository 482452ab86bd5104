"""Butterworth designs made once per process: each call gets scipy's SOS, to the bit, as its own."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import butter

from rigval.acquisition.errors import ConfigError
from rigval.processing.filters import butter_sos

DESIGNS = [(20.0, 5000.0, 4, "lowpass"), (np.float64(33.3), 2500.0, 2, "lowpass"),
           (0.5, np.float64(1000.0), 4, "highpass"), ((5.0, 40.0), 5000.0, 4, "bandpass"),
           ([1.0, 10.0], 51200.0, 2, "bandstop")]


@pytest.mark.parametrize(("cutoff", "fs", "order", "btype"), DESIGNS)
def test_each_design_is_scipys_on_every_call(cutoff, fs, order, btype):
    expected = np.asarray(butter(order, cutoff, btype=btype, fs=fs, output="sos"))
    for _ in range(3):
        sos = butter_sos(cutoff, fs, order=order, btype=btype)
        assert sos.shape == expected.shape
        assert sos.tobytes() == expected.tobytes()


def test_a_callers_changes_do_not_reach_the_next_call():
    first = butter_sos(20.0, 5000.0)
    first[:] = 0.0
    again = butter_sos(20.0, 5000.0)
    assert again.flags.writeable
    assert again.tobytes() == np.asarray(butter(4, 20.0, fs=5000.0, output="sos")).tobytes()


def test_a_corner_outside_the_band_is_refused_every_time():
    for _ in range(2):
        with pytest.raises(ConfigError):
            butter_sos(2600.0, 5000.0)
