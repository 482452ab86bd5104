"""The residual spectra's order fit, summed block by block, against the whole design matrix."""

from __future__ import annotations

import numpy as np
import pytest

from rigval.validation.diagnosis import spectra


def _whole_fit(phi: np.ndarray, values: np.ndarray, max_order: int) -> np.ndarray:
    """The order fit with the whole record's design matrix built at once (the expectation)."""
    k = np.arange(max_order + 1)
    u = (phi - phi.mean()) / np.ptp(phi)
    design = np.concatenate([np.cos(np.outer(phi, k)), np.sin(np.outer(phi, k[1:])),
                             np.column_stack([u, u**2])], axis=1)
    coef = np.linalg.lstsq(design, values, rcond=None)[0][:2 * max_order + 1]
    return np.concatenate([[coef[0]], coef[1:max_order + 1] - 1j * coef[max_order + 1:]])


@pytest.fixture
def record() -> tuple[np.ndarray, np.ndarray]:
    """Three blocks and a part of phi_F (rad) with orders, a drift and noise."""
    rng = np.random.default_rng(7)
    n = 3 * spectra.ORDER_FIT_BLOCK + 1234
    phi = np.cumsum(rng.uniform(0.9, 1.1, n)) * 2 * np.pi / 200
    values = (3.0 + 2.0 * np.cos(phi - 0.3) + 0.5 * np.sin(7 * phi) + 1e-3 * phi
              + 0.1 * rng.standard_normal(n))
    return phi, values


def test_blocked_fit_equals_whole_design(record: tuple[np.ndarray, np.ndarray]) -> None:
    phi, values = record
    coef = spectra._order_fit(phi, [values], 12)[0]
    np.testing.assert_allclose(coef, _whole_fit(phi, values, 12), rtol=0, atol=1e-10)
    assert abs(coef[1] - 2.0 * np.exp(-0.3j)) < 0.01  # the orders put in come out
    assert abs(coef[7] - (-0.5j)) < 0.01


def test_blocked_orders_equal_whole_series(record: tuple[np.ndarray, np.ndarray]) -> None:
    phi, _ = record
    coef = np.array([1.0, 0.5 - 0.2j, 0.0, 0.1j])
    whole = np.real(np.exp(1j * np.outer(phi, np.arange(coef.size))) @ coef)
    np.testing.assert_array_equal(spectra._orders_at([coef], phi)[0], whole)


def test_design_rows_made_in_place_equal_the_formula(record: tuple[np.ndarray, np.ndarray]
                                                     ) -> None:
    """cos and sin of every order and the trend, the bits of the plain expressions."""
    phi = record[0][:5000]
    k = np.arange(41)
    centre, span = phi.mean(), np.ptp(phi)
    u = (phi - centre) / span
    expected = np.concatenate([np.cos(np.outer(phi, k)), np.sin(np.outer(phi, k[1:])),
                               np.column_stack([u, u**2])], axis=1)
    assert np.array_equal(spectra._design(phi, k, centre, span), expected)


def test_order_series_of_an_in_place_basis_equal_the_formula(record: tuple[np.ndarray, np.ndarray]
                                                            ) -> None:
    """Re(sum c_k exp(i k phi)), phi of either sign: the bits of the plain expression."""
    phi = record[0][:3000] - 20.0  # negative angles too: signed zeros in the k = 0 column
    coefs = [np.array([1.5, 0.3 - 0.2j, -0.1j, 0.05 + 0.01j]), np.array([0.0, 1j, 0.0, 2.0])]
    k = np.arange(4)
    expected = [np.real(np.exp(1j * np.outer(phi, k)) @ c) for c in coefs]
    for got, want in zip(spectra._orders_at(coefs, phi), expected, strict=True):
        assert np.array_equal(got.view(np.uint64), want.view(np.uint64))
