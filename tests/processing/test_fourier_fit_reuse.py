"""A drive record fitted lately gets the Fourier fit it got then (excitation._fourier_fit)."""

from __future__ import annotations

import numpy as np
import pytest

from rigval.processing import excitation


def _record(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A 0.8 s-period drive angle, quantised to 8192 counts per turn, 5 s at 2 kHz."""
    t = np.arange(10_000) / 2000.0
    w = 2 * np.pi / 0.8
    theta = w * t + 0.05 * np.sin(w * t + 0.1 * seed) + 0.01 * np.cos(3 * w * t)
    return t, np.round(theta / (2 * np.pi / 8192)) * (2 * np.pi / 8192)


@pytest.fixture(autouse=True)
def _no_fits_kept():
    excitation._RECENT_FITS.clear()
    yield
    excitation._RECENT_FITS.clear()


def test_an_equal_record_gets_the_fit_of_its_first_call():
    t, theta = _record(0)
    first = excitation._fourier_fit(t, theta, 4)
    again = excitation._fourier_fit(t.copy(), theta.copy(), 4)
    assert again is first
    excitation._RECENT_FITS.clear()
    fresh = excitation._fourier_fit(t.copy(), theta.copy(), 4)
    assert fresh is not first
    assert (fresh.t0, fresh.period, fresh.ratio) == (first.t0, first.period, first.ratio)
    assert fresh.coef.tobytes() == first.coef.tobytes()
    assert not first.coef.flags.writeable


def test_another_record_or_order_is_fitted_anew():
    t, theta = _record(0)
    first = excitation._fourier_fit(t, theta, 4)
    changed = theta.copy()
    changed[5000] += 2 * np.pi / 8192
    assert excitation._fourier_fit(t, changed, 4) is not first
    assert excitation._fourier_fit(t, theta, 5) is not first
    assert excitation._fourier_fit(t[:-1], theta[:-1], 4) is not first
    assert excitation._fourier_fit(t, theta, 4) is first


def test_only_the_latest_fits_are_kept():
    records = [_record(seed) for seed in range(excitation._FITS_KEPT + 1)]
    fits = [excitation._fourier_fit(t, theta, 4) for t, theta in records]
    assert len(excitation._RECENT_FITS) == excitation._FITS_KEPT
    assert excitation._fourier_fit(*records[-1], 4) is fits[-1]
    assert excitation._fourier_fit(*records[0], 4) is not fits[0]
