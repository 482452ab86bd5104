"""Sensor conversions invert the exact forward circuit models (bridge, rosettes, charge chain)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rigval.acquisition.errors import ConfigError
from rigval.processing import accelerometer, bridge, stress, torsion

STRAINS = np.array([-3e-3, -1e-3, -2.5e-4, 1e-6, 2.5e-4, 1e-3, 3e-3])
EXACT = ["quarter_i", "quarter_ii", "half_i", "half_ii", "full_i", "full_ii", "full_iii"]


@pytest.mark.parametrize("bridge_type", EXACT)
@pytest.mark.parametrize("lead", [0.0, 1.0])
def test_ni_equations_invert_the_exact_bridge(bridge_type: str, lead: float) -> None:
    vr = bridge.bridge_ratio(STRAINS, bridge_type, gauge_factor=2.05, poisson=0.29,
                             lead_resistance=lead)
    back = bridge.strain_from_ratio(vr, bridge_type, gauge_factor=2.05, poisson=0.29,
                                    lead_resistance=lead)
    np.testing.assert_allclose(back, STRAINS, rtol=1e-12, atol=0)


def test_full_ii_arms_are_nis_and_nis_equation_is_exact() -> None:
    # NI Full Bridge II: R1 compressive Poisson (-nu eps), R2 tensile Poisson (+nu eps),
    # R3 compressive (-eps), R4 tensile (+eps); then Vr = -GF eps (1 + nu) / 2 exactly.
    gf, nu, rg, eps = 2.0, 0.3, 350.0, 1e-3
    r1, r2, r3, r4 = bridge.bridge_arms(eps, "full_ii", gauge_factor=gf, poisson=nu,
                                        gauge_resistance=rg)
    expected = rg * (1 + gf * np.array([-nu * eps, nu * eps, -eps, eps]))
    np.testing.assert_allclose([r1, r2, r3, r4], expected, rtol=1e-15)
    vr = bridge.bridge_ratio(STRAINS, "full_ii", gauge_factor=gf, poisson=nu)
    np.testing.assert_allclose(vr, -gf * STRAINS * (1 + nu) / 2, rtol=1e-12, atol=0)
    back = bridge.strain_from_ratio(vr, "full_ii", gauge_factor=gf, poisson=nu)
    np.testing.assert_allclose(back, STRAINS, rtol=1e-12, atol=0)


def test_quarter_bridge_leads_attenuate_as_vishay_says() -> None:
    # 2-wire quarter bridge: both leads in the gauge arm -> reading low by 2 RL / (Rg + 2 RL).
    r1, r2, r3, r4 = bridge.bridge_arms(1e-3, "quarter_i", gauge_factor=2.0)
    vr = bridge.wheatstone_ratio(r1, r2, r3, r4 + 2.0) - bridge.wheatstone_ratio(120, 120, 120,
                                                                                   122.0)
    uncorrected = bridge.strain_from_ratio(vr, "quarter_i", gauge_factor=2.0)
    assert uncorrected / 1e-3 - 1 == pytest.approx(-0.0165, abs=2e-4)
    corrected = bridge.strain_from_ratio(vr, "quarter_i", gauge_factor=2.0, lead_resistance=2.0)
    assert abs(corrected / 1e-3 - 1) < 1e-4                 # residual of offset nulling only


def test_offset_null_and_ni_vector() -> None:
    vr = bridge.voltage_ratio(-1.65e-3, 2.5, -0.40e-3)
    assert vr == pytest.approx(-0.5e-3)
    assert bridge.strain_from_ratio(vr, "full_i", gauge_factor=2.0) == pytest.approx(250e-6)


def test_shunt_calibration_matches_tn514_and_gives_unit_gain_on_exact_bridge() -> None:
    simulated = bridge.shunt_simulated_strain(350.0, 100e3, 2.0)
    assert simulated == pytest.approx(-1743.9e-6, rel=1e-4)
    r1, r2, r3, r4 = bridge.bridge_arms(0.0, "quarter_i", gauge_factor=2.0,
                                        gauge_resistance=350.0)
    shunted = r4 * 100e3 / (r4 + 100e3)
    measured = bridge.strain_from_ratio(bridge.wheatstone_ratio(r1, r2, r3, shunted),
                                        "quarter_i", gauge_factor=2.0, gauge_resistance=350.0)
    assert bridge.shunt_gain_adjust(simulated, float(measured)) == pytest.approx(1.0, rel=1e-12)
    with pytest.raises(ConfigError):
        bridge.shunt_gain_adjust(simulated, 0.0)


def test_unknown_bridge_type_is_a_config_error() -> None:
    with pytest.raises(ConfigError, match="full_i"):
        bridge.strain_from_ratio(0.0, "full_iv", gauge_factor=2.0)


@pytest.mark.parametrize(("rosette", "inner"), [("full", 0.06), ("half", 0.06), ("full", 0.0)])
def test_torque_round_trip_through_rosette_bridge(rosette: str, inner: float) -> None:
    torque = np.array([-13000.0, -1380.37, 0.0, 3450.9, 6901.8, 13803.7])
    gamma = torsion.shear_strain_from_torque(torque, shear_modulus=80e9, outer_diameter=0.1,
                                             inner_diameter=inner)
    vr = torsion.rosette_bridge_ratio(gamma, rosette, gauge_factor=2.05, lead_resistance=0.5)
    back = torsion.torque_from_ratio(vr, rosette, gauge_factor=2.05, shear_modulus=80e9,
                                     outer_diameter=0.1, inner_diameter=inner,
                                     lead_resistance=0.5)
    np.testing.assert_allclose(back, torque, rtol=1e-12, atol=1e-9)


def test_torsion_reference_table() -> None:
    g = 210e9 / (2 * 1.3)
    full = torsion.torque_from_ratio(-0.5e-3, "full", gauge_factor=2.0, shear_modulus=g,
                                     outer_diameter=0.1, inner_diameter=0.06)
    half = torsion.torque_from_ratio(-0.5e-3, "half", gauge_factor=2.0, shear_modulus=g,
                                     outer_diameter=0.1, inner_diameter=0.06)
    assert full == pytest.approx(6901.84, abs=0.01)
    assert half == pytest.approx(13803.67, abs=0.01)


def test_full_bridge_cancels_disturbances_half_bridge_does_not() -> None:
    kwargs = {"gauge_factor": 2.0, "axial_strain": 100e-6, "bending_strain": 300e-6,
              "transverse_shear": 50e-6}
    full = torsion.shear_strain_from_ratio(
        torsion.rosette_bridge_ratio(500e-6, "full", **kwargs), "full", gauge_factor=2.0)
    half = torsion.shear_strain_from_ratio(
        torsion.rosette_bridge_ratio(500e-6, "half", **kwargs), "half", gauge_factor=2.0)
    assert abs(full / 500e-6 - 1) < 2e-4
    assert half / 500e-6 - 1 == pytest.approx(0.10, abs=0.005)


def test_axial_stress_from_full_iii_and_axial_bending_split() -> None:
    eps = bridge.strain_from_ratio(-0.26e-3, "full_iii", gauge_factor=2.0, poisson=0.3)
    assert stress.axial_stress(eps, 210e9) == pytest.approx(42.01e6, rel=1e-3)
    top, bottom = 420e-6, -180e-6
    axial, bending = stress.axial_and_bending(top, bottom)
    assert (axial, bending) == (pytest.approx(120e-6), pytest.approx(300e-6))
    w = stress.tube_section_modulus(0.1, 0.06)
    assert stress.bending_moment(bending, 210e9, w) == pytest.approx(5383, rel=1e-3)
    # Forward: two gauges carrying axial +- bending through half bridges I and II.
    vr_axial = bridge.bridge_ratio(axial, "half_i", gauge_factor=2.0, poisson=0.3)
    vr_bend = bridge.bridge_ratio(bending, "half_ii", gauge_factor=2.0)
    assert bridge.strain_from_ratio(vr_axial, "half_i", gauge_factor=2.0) == pytest.approx(
        axial, rel=1e-12)
    assert bridge.strain_from_ratio(vr_bend, "half_ii", gauge_factor=2.0) == pytest.approx(
        bending, rel=1e-12)


def test_charge_chain_round_trip_with_highpass() -> None:
    fs = 5000.0
    t = np.arange(0, 4, 1 / fs)
    acc = 3 * np.sin(2 * np.pi * 1.0 * t) + 0.5 * np.cos(2 * np.pi * 7 * t)
    volts = accelerometer.charge_chain_voltage(acc, charge_sensitivity=10.2, amplifier_gain=9.98,
                                               fs=fs, highpass_hz=0.1, initial_state=0.0)
    back = accelerometer.acceleration_from_voltage(volts, charge_sensitivity=10.2,
                                                   amplifier_gain=9.98, fs=fs, highpass_hz=0.1)
    np.testing.assert_allclose(back, acc, rtol=0, atol=1e-12 * np.max(abs(acc)))


def test_highpass_matches_analog_response_in_steady_state() -> None:
    fs, f, fc = 5000.0, 1.0, 0.1
    t = np.arange(0, 200, 1 / fs)
    y = accelerometer.apply_highpass(np.sin(2 * np.pi * f * t), fs, fc)
    h = accelerometer.highpass_response(f, fc)
    tail = t > 150                                           # transient e^-t/1.6s has died
    expected = np.abs(h) * np.sin(2 * np.pi * f * t[tail] + np.angle(h))
    np.testing.assert_allclose(y[tail], expected, atol=2e-7)
    assert np.degrees(np.angle(h)) == pytest.approx(5.71, abs=0.01)   # phase lead at 1 Hz


def test_charge_chain_scale() -> None:
    volts = accelerometer.charge_chain_voltage(9.80665, charge_sensitivity=10.0,
                                               amplifier_gain=10.0)
    assert volts == pytest.approx(0.1)


@settings(max_examples=40)
@given(strain=st.floats(-5e-3, 5e-3).filter(lambda e: abs(e) > 1e-7),
       gauge_factor=st.floats(1.8, 2.2), poisson=st.floats(0.2, 0.45),
       lead=st.floats(0.0, 5.0), bridge_type=st.sampled_from(EXACT))
def test_exact_inverses_hold_for_any_physical_bridge(strain: float, gauge_factor: float,
                                                     poisson: float, lead: float,
                                                     bridge_type: str) -> None:
    kwargs = {"gauge_factor": gauge_factor, "poisson": poisson, "lead_resistance": lead,
              "gauge_resistance": 350.0}
    vr = bridge.bridge_ratio(strain, bridge_type, **kwargs)
    assert bridge.strain_from_ratio(vr, bridge_type, **kwargs) == pytest.approx(strain,
                                                                                rel=1e-11)
    arms = bridge.bridge_arms(strain, bridge_type, **kwargs)
    assert bridge.wheatstone_ratio(*arms) == pytest.approx(vr, rel=1e-9, abs=1e-15)
