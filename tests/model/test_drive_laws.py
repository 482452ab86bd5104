"""Drive laws: the file's law, TOML/command-line laws, tabulated profiles, measured excitation."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from rigval.acquisition.errors import ChannelNotFoundError, ConfigError, DataError, DataFileError
from rigval.model.drive_laws import (
    apply_drive_options,
    excitation_from_measured,
    fit_periodic_profile,
    read_profile_csv,
)
from rigval.model.laws import DriveLaw, Excitation, Harmonic, excitation_from_drivers

TWO_PI = 2.0 * math.pi

# The reference pendulum's drivers as written in its mechanism file.
PENDULUM_DRIVERS = [
    ("theta_F", 1.461333994409296, TWO_PI, [(0.05, TWO_PI, 0.0)]),
    ("theta_H", 4.589467988818592, 2 * TWO_PI, [(0.1, TWO_PI, 0.0)]),
]


def file_law(t, theta0, omega, harmonics):
    """The mechanism file's law evaluated directly (docs/mechanism.md, *`[[drivers]]`*)."""
    theta = theta0 + omega * t
    speed = np.full_like(t, omega)
    accel = np.zeros_like(t)
    for a, w, p in harmonics:
        theta = theta + a * np.sin(w * t + p)
        speed = speed + a * w * np.cos(w * t + p)
        accel = accel - a * w * w * np.sin(w * t + p)
    return theta, speed, accel


def analytic_profile(t, omega):
    """A smooth drive profile with known derivatives: one turn per cycle plus two harmonics."""
    tau = omega * t
    theta = 0.3 + tau + 0.2 * np.sin(tau + 0.4) + 0.05 * np.sin(3 * tau - 1.0)
    speed = omega * (1 + 0.2 * np.cos(tau + 0.4) + 0.15 * np.cos(3 * tau - 1.0))
    accel = -omega**2 * (0.2 * np.sin(tau + 0.4) + 0.45 * np.sin(3 * tau - 1.0))
    return theta, speed, accel


def test_file_law_is_reproduced_exactly() -> None:
    excitation = excitation_from_drivers(PENDULUM_DRIVERS)
    assert excitation.main == "theta_F"
    assert excitation.frequency == pytest.approx(1.0)
    assert excitation.law("theta_H").ratio == pytest.approx(2.0)
    t = np.linspace(0.0, 3.0, 301)
    values = excitation.evaluate(t)
    for name, theta0, omega, harmonics in PENDULUM_DRIVERS:
        for got, expected in zip(values[name], file_law(t, theta0, omega, harmonics), strict=True):
            np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)


def test_frequency_change_scales_speed_and_acceleration_at_equal_phase() -> None:
    base = excitation_from_drivers(PENDULUM_DRIVERS)
    fast = base.with_frequency(1.5)
    t = np.linspace(0.0, 1.0, 50)
    slow_values, fast_values = base.evaluate(t), fast.evaluate(t / 1.5)
    for name in base.names:
        np.testing.assert_allclose(fast_values[name][0], slow_values[name][0], atol=1e-12)
        np.testing.assert_allclose(fast_values[name][1], 1.5 * slow_values[name][1], rtol=1e-12)
        np.testing.assert_allclose(fast_values[name][2], 2.25 * slow_values[name][2],
                                   rtol=1e-12, atol=1e-9)


def test_cycle_times_put_the_main_drive_on_a_uniform_angle_grid() -> None:
    excitation = excitation_from_drivers(PENDULUM_DRIVERS)
    angle, t = excitation.cycle_times(360)
    theta = excitation.evaluate(t)["theta_F"][0]
    np.testing.assert_allclose(theta - theta[0], angle, atol=1e-12)
    assert np.all(np.diff(t) > 0) and t[-1] < excitation.period


def test_cycle_times_refuse_a_main_drive_that_reverses() -> None:
    excitation = excitation_from_drivers([("a", 0.0, 1.0, [(2.0, 1.0, 0.0)])])
    with pytest.raises(ConfigError, match="without stopping"):
        excitation.cycle_times(90)


def test_inline_options_change_only_what_they_name(tmp_path: Path) -> None:
    base = excitation_from_drivers(PENDULUM_DRIVERS)
    changed = apply_drive_options(base, [
        "theta_F={frequency = 0.75}",
        "theta_H={phase = 0.5, harmonics = [{amplitude = 0.02, order = 2, phase = 1.0}]}",
    ])
    assert changed.frequency == 0.75
    assert changed.law("theta_F") == base.law("theta_F")
    lifting = changed.law("theta_H")
    assert (lifting.theta0, lifting.ratio, lifting.phase) == (base.law("theta_H").theta0, 2.0, 0.5)
    assert lifting.harmonics == (Harmonic(0.02, 2.0, 1.0),)
    law_file = tmp_path / "lift.toml"
    law_file.write_text("ratio = 2.0\nphase = 0.5\n"
                        "harmonics = [{amplitude = 0.02, order = 2, phase = 1.0}]\n")
    from_file = apply_drive_options(base, [f"theta_H={law_file}"])
    assert from_file.law("theta_H").harmonics == lifting.harmonics
    assert from_file.law("theta_H").phase == 0.5
    assert apply_drive_options(base, ["theta_H=file"]) == base


@pytest.mark.parametrize("option, error, text", [
    ("theta_X={phase = 1}", ChannelNotFoundError, "theta_H"),
    ("theta_H={phase = 1", ConfigError, "not a TOML table"),
    ("theta_H={speed = 1}", ConfigError, "unknown key 'speed' in a drive law"),
    ("theta_H={frequency = 2}", ConfigError, "only the main drive"),
    ("theta_F={frequency = -1}", ConfigError, "positive number of Hz"),
    ("theta_H={harmonics = [{amplitude = 1}]}", ConfigError, "missing key 'order'"),
    ("theta_H", ConfigError, "NAME=LAW"),
    ("theta_H=fast", ConfigError, "cannot tell"),
    ("theta_H=/nonexistent/law.toml", DataFileError, "cannot read"),
])
def test_bad_options_say_what_is_wrong(option: str, error: type[Exception], text: str) -> None:
    with pytest.raises(error, match=text):
        apply_drive_options(excitation_from_drivers(PENDULUM_DRIVERS), [option])


def test_tabulated_profile_derivatives_within_stated_error(tmp_path: Path) -> None:
    """A noisy, non-uniformly sampled table of an analytic profile: errors stay in the bound."""
    period = 1.25
    omega = TWO_PI / period
    rng = np.random.default_rng(7)
    t = np.sort(np.concatenate([[0.0, period], rng.uniform(0.0, period, 400)]))
    theta = analytic_profile(t, omega)[0] + 2e-4 * rng.standard_normal(t.size)
    csv = tmp_path / "profile.csv"
    csv.write_text("time_s,angle_rad\n" + "".join(f"{a:.17g},{b:.17g}\n"
                                                  for a, b in zip(t, theta, strict=True)))
    excitation = apply_drive_options(excitation_from_drivers(PENDULUM_DRIVERS),
                                     [f"theta_F={csv}"])
    assert excitation.frequency == pytest.approx(1.0 / period)
    law = excitation.law("theta_F")
    assert law.error is not None and law.error.order == 3
    dense = np.linspace(0.0, period, 2001)
    got = law.evaluate(dense, excitation.omega)
    expected = analytic_profile(dense, omega)
    for g, e, bound in zip(got, expected, law.error.at(omega), strict=True):
        worst = float(np.max(np.abs(g - e)))
        assert worst <= bound
        assert bound <= 20 * worst  # the stated error is an estimate, not a blanket


def test_truncation_of_a_profile_with_infinitely_many_harmonics_is_covered() -> None:
    """A Poisson-kernel profile (all harmonics, geometric decay) sampled without noise."""
    r, n = 0.5, 64
    tau = np.linspace(0.0, TWO_PI, n + 1)
    wobble = 0.3 * r * np.sin(tau) / (1 - 2 * r * np.cos(tau) + r * r)  # sum 0.3 r^k sin(k tau)
    fit = fit_periodic_profile(tau / TWO_PI, tau + wobble, max_order=8)
    dense = np.linspace(0.0, 1.0, 999)
    k = np.arange(1, 60)[:, None]
    exact_speed = 1 + 0.3 * np.sum(r**k * k * np.cos(k * TWO_PI * dense), axis=0)
    speed = fit.law.evaluate(dense, TWO_PI)[1] / TWO_PI
    assert np.max(np.abs(speed - exact_speed)) <= fit.law.error.speed


@pytest.mark.parametrize(("content", "error", "match"), [
    ("time_s,angle_rad\n0,0\n0.2,1\n0.1,2\n", DataError, "increase strictly"),
    ("time_s,angle_rad\n0,0\n0.1,abc\n", DataError, "not finite"),
    ("a,b,c\n0,0,0\n", DataFileError, "time_s and angle_rad"),
])
def test_profile_table_errors(tmp_path: Path, content: str, error: type[Exception],
                              match: str) -> None:
    profile = tmp_path / "profile.csv"
    profile.write_text(content)
    with pytest.raises(error, match=match):
        read_profile_csv(profile)


def test_profile_fit_errors() -> None:
    with pytest.raises(DataError, match="at least 8"):
        fit_periodic_profile([0.0, 1.0], [0.0, 1.0])
    with pytest.raises(DataError, match="at most the profile's span"):
        fit_periodic_profile(np.arange(10.0), np.arange(10.0), period=20.0)


def test_measured_excitation_recovers_the_law_over_many_cycles() -> None:
    truth = excitation_from_drivers(PENDULUM_DRIVERS).with_frequency(0.8)
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 6.0, 1e-3)
    data = truth.to_dataset(t)
    for name in truth.names:  # encoder-like quantisation noise on the angles
        data[name] = data[name] + rng.uniform(-1, 1, t.size) * TWO_PI / 4096 / 2
    measured = excitation_from_measured(data, truth.names)
    assert measured.frequency == pytest.approx(0.8, rel=1e-5)
    dense = np.linspace(0.0, 2.0, 777)
    got, expected = measured.evaluate(dense), truth.evaluate(dense)
    for name in truth.names:
        law = measured.law(name)
        assert law.ratio == truth.law(name).ratio
        for g, e, bound in zip(got[name], expected[name], law.error.at(measured.omega),
                               strict=True):
            assert np.max(np.abs(g - e)) <= bound


def test_measured_excitation_names_missing_drives() -> None:
    data = excitation_from_drivers(PENDULUM_DRIVERS).to_dataset(np.linspace(0, 2, 100))
    with pytest.raises(ChannelNotFoundError, match="theta_X"):
        excitation_from_measured(data.drop_vars("theta_H"), ["theta_F", "theta_X"])


def test_law_dataclass_round_trip_through_evaluate() -> None:
    law = DriveLaw(theta0=0.1, ratio=-1.0, phase=0.2, harmonics=(Harmonic(0.1, 2.0, 0.3),))
    excitation = Excitation(frequency=2.0, laws=(("m", law),), main="m")
    angle, t = excitation.cycle_times(64)
    theta = law.evaluate(t, excitation.omega)[0]
    np.testing.assert_allclose(-(theta - theta[0]), angle, atol=1e-12)


def test_measured_excitation_with_a_gap_and_encoder_offsets() -> None:
    """Encoders count from zero and the record has a gap: offsets and the gap are handled."""
    truth = excitation_from_drivers(PENDULUM_DRIVERS).with_frequency(1.1)
    t = np.arange(0.0, 4.0, 1e-3)
    data = truth.to_dataset(t)
    starts = {name: float(data[name][0]) for name in truth.names}
    for name in truth.names:
        values = data[name].values - starts[name]  # encoder angle from its start
        values[500:900] = np.nan  # a wireless dropout
        data[name] = ("time", values)
    measured = excitation_from_measured(data, truth.names, offsets=starts)
    assert measured.frequency == pytest.approx(1.1, rel=1e-12)
    dense = np.linspace(0.0, 3.0, 501)
    got, expected = measured.evaluate(dense), truth.evaluate(dense)
    for name in truth.names:
        law = measured.law(name)
        assert law.error.samples == t.size - 400
        for g, e, bound in zip(got[name], expected[name], law.error.at(measured.omega),
                               strict=True):
            assert np.max(np.abs(g - e)) <= bound


@given(ratio=st.sampled_from([0.0, 1.0, 2.0, -1.0]),
       terms=st.lists(st.tuples(st.floats(0.0, 0.3), st.integers(1, 6), st.floats(-3.0, 3.0)),
                      max_size=4),
       theta0=st.floats(-10.0, 10.0), samples=st.integers(60, 200))
def test_fit_round_trip_of_band_limited_laws(ratio, terms, theta0, samples) -> None:
    """Any law with up to 6 harmonics, tabulated without noise, is recovered within its bound."""
    law = DriveLaw(theta0=theta0, ratio=ratio,
                   harmonics=tuple(Harmonic(a, float(k), p) for a, k, p in terms))
    t = np.linspace(0.0, 2.0, samples + 1)
    fit = fit_periodic_profile(t, law.evaluate(t, math.pi)[0])
    assert fit.frequency == pytest.approx(0.5)
    dense = np.linspace(0.0, 2.0, 301)
    for got, expected, bound in zip(fit.law.evaluate(dense, math.pi), law.evaluate(dense, math.pi),
                                    fit.law.error.at(math.pi), strict=True):
        assert np.max(np.abs(got - expected)) <= bound
