"""The mode fit's shortcuts against the plain computations they stand for, to the bit.

The window's likelihood is evaluated thousands of times by the optimisers and the candidates'
running medians hundreds of times per run; both are computed here the plain way (numpy's
median over a boolean band, the model and likelihood as written in the module docstring) and
compared bit for bit, so the fits and the resonances they give cannot have moved.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigval.validation.diagnosis import modes
from rigval.validation.diagnosis.modes import _median, _resonance_shape, _Window, find_resonances
from rigval.validation.diagnosis.spectra import Spectrum

RNG = np.random.default_rng(7)


def _spectrum(mode_hz: float = 14.0, damping: float = 0.02, height: float = 80.0) -> Spectrum:
    """A Welch-like spectrum: a sloping floor, one resonance, chi-square scatter of 40 dof."""
    f = np.fft.rfftfreq(800, 1.0 / 100.0)
    floor = 1e-3 * np.exp(-0.02 * f)
    r = f / mode_hz
    peak = (2 * damping) ** 2 / ((1 - r**2) ** 2 + (2 * damping * r) ** 2)
    psd = floor * (1.0 + height * peak) * RNG.chisquare(40, f.size) / 40.0
    return Spectrum(f, psd, 40.0, float(f[1] - f[0]), 8.0)


@pytest.mark.parametrize("n", [1, 2, 3, 10, 11, 64])
def test_median_is_numpys_to_the_bit(n):
    for _ in range(50):
        values = RNG.lognormal(size=n)
        if n > 2:
            values[RNG.integers(n)] = values[RNG.integers(n)]  # ties
        assert float(np.median(values)).hex() == _median(values).hex()


def test_median_with_a_nan_is_nan_as_numpys():
    values = RNG.lognormal(size=9)
    values[4] = np.nan
    assert math.isnan(np.median(values)) and math.isnan(_median(values))


def test_window_likelihood_is_the_plain_formula_to_the_bit():
    spectrum = _spectrum()
    known = ((9.0, 0.03, 2e-3),)
    window = _Window(spectrum, 10.0, 18.0, 14.0, known)
    offsets = (np.arange(-12, 12) + 0.5) / 4.0 / spectrum.segment_s
    x = (np.arange(-12, 12) + 0.5) / 4.0
    weights = (np.sinc(x) / (1.0 - x**2)) ** 2
    weights = weights / weights.sum()
    grid = window.f[:, None] + offsets[None, :]
    tails = sum((peak * _resonance_shape(grid, fn, zeta) @ weights for fn, zeta, peak in known),
                np.zeros(window.f.size))
    for theta in (np.array([0.1, -0.02]), np.array([-0.3, 0.05, np.log(14.2), np.log(0.02),
                                                    np.log(60.0)])):
        floor = np.exp(theta[0] + theta[1] * (window.f - 14.0)) * window.scale + tails
        model = floor
        if theta.size == 5:
            fn, zeta, height = np.exp(theta[2:5])
            model = floor + height * window.scale * (_resonance_shape(grid, fn, zeta) @ weights)
        plain = float(0.5 * spectrum.dof * np.sum(np.log(model) + window.p / model))
        assert window.model(theta).tobytes() == model.tobytes()
        assert window.nll(theta).hex() == plain.hex()


def test_candidates_are_the_plain_running_medians_choice(monkeypatch):
    spectrum = _spectrum()
    band = (4.8, 36.0)
    f, p = spectrum.frequency, spectrum.psd
    smooth = np.convolve(p, np.ones(3) / 3.0, mode="same")
    inside = np.flatnonzero((f >= band[0]) & (f <= band[1]))
    ratio = {}
    for i in inside[1:-1]:
        if smooth[i] >= smooth[i - 1] and smooth[i] >= smooth[i + 1]:
            half = 0.5 * max(4.0, 0.5 * f[i])
            ratio[i] = smooth[i] / np.median(p[(f >= f[i] - half) & (f <= f[i] + half)])
    expected = sorted((i for i in ratio if ratio[i] >= modes.CANDIDATE_RATIO),
                      key=lambda i: -ratio[i])[:modes.MAX_CANDIDATES]
    guesses = []
    monkeypatch.setattr(modes, "fit_resonance",
                        lambda spectrum, guess_hz, *args: guesses.append(guess_hz))
    find_resonances(spectrum, 0.8, band)
    assert guesses == [float(f[i]) for i in expected]
    assert guesses  # the resonance stands out


def test_the_resonance_is_found():
    found = find_resonances(_spectrum(), 0.8, (4.8, 36.0))
    assert any(abs(r.frequency_hz - 14.0) < 0.5 for r in found)
