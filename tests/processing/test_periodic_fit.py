"""The one periodic Fourier fit (rigval.processing.periodic_fit) against closed forms."""

from __future__ import annotations

import math

import numpy as np

from rigval.processing import periodic_fit
from rigval.processing.periodic_fit import (
    fit_periodic,
    fourier_basis,
    fourier_normal_equations,
    refine_period,
)

PERIOD = 0.8


def _angle(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """theta = 2 pi t / P + 0.3 + 0.05 sin(w t + 0.4) + 0.01 cos(3 w t), its speed and accel."""
    w = 2 * math.pi / PERIOD
    theta = w * t + 0.3 + 0.05 * np.sin(w * t + 0.4) + 0.01 * np.cos(3 * w * t)
    speed = w + 0.05 * w * np.cos(w * t + 0.4) - 0.03 * w * np.sin(3 * w * t)
    accel = -0.05 * w**2 * np.sin(w * t + 0.4) - 0.09 * w**2 * np.cos(3 * w * t)
    return theta, speed, accel


def test_fit_recovers_an_exact_series_and_its_derivatives() -> None:
    t = np.linspace(0.0, 5 * PERIOD, 4001)
    theta, speed, accel = _angle(t)
    fit = fit_periodic(t, theta, PERIOD, 4)
    assert fit.ratio == 1.0
    for got, expected, tol in zip(fit(t), (theta, speed, accel), (1e-12, 1e-10, 1e-8),
                                  strict=True):
        np.testing.assert_allclose(got, expected, rtol=0, atol=tol)
    # the coefficients of the harmonics the law does not have vanish
    np.testing.assert_allclose(fit.coef[[3, 4, 7, 8]], 0.0, atol=1e-12)


def test_refine_period_finds_the_period_from_a_rough_start() -> None:
    t = np.linspace(0.0, 12.0, 24001)
    theta, _, _ = _angle(t)
    assert abs(refine_period(t, theta, PERIOD * (1 + 2e-3), 4) - PERIOD) < 1e-11


def test_basis_derivatives_are_finite_differences() -> None:
    tau, h = np.linspace(0.0, 7.0, 50), 1e-6
    for derivative in (1, 2):
        numeric = (fourier_basis(tau + h, 5, derivative - 1)
                   - fourier_basis(tau - h, 5, derivative - 1)) / (2 * h)
        np.testing.assert_allclose(fourier_basis(tau, 5, derivative), numeric, atol=2e-7)


def test_period_sensitivity_equals_the_fit_and_normal_equations_it_replaces() -> None:
    # several blocks of rows, a last one short; harmonic orders beyond the law's
    rng = np.random.default_rng(7)
    t = np.sort(rng.uniform(0.0, 30.0, 2 * periodic_fit._CHUNK_ROWS + 1234))
    theta, _, _ = _angle(t)
    theta += rng.normal(0.0, 1e-3, t.size)
    for order in (1, 2, 4, 8):
        fit = fit_periodic(t, theta, PERIOD * (1 + 1e-4), order, t0=0.1)
        angle, sensitivity, gram, projection = periodic_fit._period_sensitivity(fit, t)
        expected_angle, speed, _ = fit(t)
        expected_sensitivity = -(t - 0.1) / fit.period * speed
        expected_gram, expected_projection = fourier_normal_equations(
            fit.phase(t), expected_sensitivity, order)
        for got, expected in ((angle, expected_angle), (sensitivity, expected_sensitivity),
                              (gram, expected_gram), (projection, expected_projection)):
            assert got.tobytes() == expected.tobytes()


def test_harmonics_equal_the_cumulative_product_of_the_phasor_to_the_bit() -> None:
    # the direct computation: exp(j tau) multiplied along each row
    rng = np.random.default_rng(11)
    for tau in (rng.uniform(-50.0, 400.0, periodic_fit._CHUNK_ROWS),
                rng.normal(0.0, 1e4, 1001), np.linspace(0.0, 2 * math.pi, 7), np.zeros(0)):
        for order in range(13):
            phasor = np.cumprod(np.broadcast_to(np.exp(1j * tau)[:, None], (tau.size, order)),
                                axis=1)
            cos, sin = periodic_fit._harmonics(tau, order)
            assert cos.tobytes() == phasor.real.tobytes()
            assert sin.tobytes() == phasor.imag.tobytes()
