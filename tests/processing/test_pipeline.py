"""Stream Datasets through the public Dataset-level API, checked against the synthetic truth."""

from __future__ import annotations

import numpy as np
import pytest

from rigval.acquisition.errors import ChannelNotFoundError, ConfigError, UnitError
from rigval.acquisition.schema import Channel, stream_dataset
from rigval.processing import (
    accelerometer,
    angle,
    bridge,
    clock_fit,
    conversions,
    cycles,
    excitation,
    pulses,
    stamps,
    timeline,
    torsion,
)

SHAFT = {"shear_modulus": 80e9, "outer_diameter": 0.1, "inner_diameter": 0.06}


def _stream(time, channels, device, start, fs, **kwargs):
    return stream_dataset(time, channels, device=device, start_time=start,
                          source_file=f"{device}.tdms", source_sha256="0" * 64, fs_nominal=fs,
                          **kwargs)


def test_streams_to_cycle_statistics_recover_the_true_torque(make_rig, synth) -> None:
    rig = make_rig(21, missing=0.1, spurious=2)
    cdaq = _stream(rig.t_ref, {
        "opt1": Channel(rig.opt1, "V", "optical reference", "/'ai'/'opt1'",
                        attrs={"module": "NI 9215"}),
        "enc1": Channel(rig.counts.astype(np.uint32), "1", "main shaft encoder", "/'ci'/'enc1'"),
    }, "cDAQ-9172", "2026-03-02T10:00:00Z", synth.FS_REF)
    physical = rig.offset + (1 + rig.drift) * (rig.t_dev - rig.delay)
    phi_true, _ = synth.shaft_angle(physical)

    def true_torque(phi):
        return 1000.0 + 300.0 * np.cos(2 * phi) + 50.0 * np.sin(5 * phi)

    gamma = torsion.shear_strain_from_torque(true_torque(phi_true), **SHAFT)
    ratio = torsion.rosette_bridge_ratio(gamma, "full", gauge_factor=2.05)
    # The device's software start time is 2 s off the truth (offset 2.0137 s).
    wls = _stream(rig.t_dev, {
        "opt2": Channel(rig.opt2, "V", "optical pulse on the shaft", "/'wls'/'opt2'",
                        attrs={"module": "NI 9237"}),
        "tor1": Channel(ratio * 1e3, "mV/V", "torsion bridge", "/'wls'/'tor1'",
                        attrs={"module": "NI 9237", "sensor_id": "XY21-a"}),
    }, "WLS-9163", "2026-03-02T10:00:00.000Z", synth.FS_DEV)

    ref_pulses = pulses.stream_pulses(cdaq, "opt1")
    phi = angle.phi_f(cdaq, "enc1", ref_pulses, counts_per_rev=8192)
    assert phi.attrs["reference_scatter_rad"] < 1e-4
    assert phi.attrs["suspect_cycles"].dtype == np.int64 and phi.attrs["suspect_cycles"].size == 0
    dev_pulses = pulses.stream_pulses(wls, "opt2")
    assert dev_pulses.delay_s == pytest.approx(clock_fit.ni9237_input_delay(synth.FS_DEV))
    clock = clock_fit.estimate_clock(ref_pulses.good, dev_pulses.good, dev_pulses.good_segment,
                                 coarse_offset_s=stamps.coarse_offset(cdaq, wls).offset_s,
                                 where={"stream": "wls"})
    torque = conversions.torque_channel(wls, "tor1", rosette="full", gauge_factor=2.05, **SHAFT)
    aligned = {"cdaq": clock_fit.align_stream(cdaq, clock_fit.identity_clock()),
               "wls": clock_fit.align_stream(torque, clock, name="wls")}
    assert aligned["wls"].attrs["clock_offset_s"] == pytest.approx(rig.offset, abs=10e-6)
    assert aligned["wls"].attrs["pulses_matched"] >= 15
    assert "align_stream" in aligned["wls"].attrs["history"]
    domain = angle.angle_domain(aligned, phi["time"].to_numpy(), phi["phi_F"].to_numpy(),
                                points_per_rev=360, channels={"wls": ["tor1_torque"]})
    assert domain["tor1_torque"].attrs["units"] == "N m"
    assert domain["tor1_torque"].attrs["sensor_id"] == "XY21-a"
    assert domain["cycle_valid"].sum() >= 17
    stats = cycles.cycle_statistics(domain)
    mean = stats["tor1_torque"].sel(statistic="mean").to_numpy()
    np.testing.assert_allclose(mean, true_torque(domain["angle"].to_numpy()), atol=0.5)
    assert float(stats["tor1_torque"].sel(statistic="std").max()) < 0.5
    assert stats.attrs["history"].count("\n") >= 2

    common = timeline.common_timeline(aligned, "cdaq", channels={"wls": ["tor1_torque"],
                                                                 "cdaq": ["enc1"]})
    grid = common["time"].to_numpy()
    on_grid = common["tor1_torque"].to_numpy()
    covered = np.isfinite(on_grid)
    assert covered.sum() > 0.8 * grid.size and not covered[:100].any()   # device starts at 2 s
    truth = true_torque(synth.shaft_angle(grid[covered])[0])
    assert np.max(np.abs(on_grid[covered] - truth)) < 0.5
    assert common["tor1_torque"].attrs["clock_offset_s"] == aligned["wls"].attrs["clock_offset_s"]
    assert common.attrs["reference_stream"] == "cdaq"


def test_strain_conversion_from_volts_with_offset_window() -> None:
    t = np.arange(0, 2, 1e-3)
    eps = np.where(t < 0.5, 0.0, 400e-6 * np.sin(2 * np.pi * 3 * t))
    volts = 2.5 * (bridge.bridge_ratio(eps, "half_i", gauge_factor=2.1, poisson=0.29,
                                       lead_resistance=0.4) + 1.2e-4)  # bridge offset
    ds = _stream(t, {"str1": Channel(volts, "V", "rod B strain", "/'ai'/'str1'")}, "cDAQ-9172",
                 "2026-03-02T10:00:00Z", 1000.0)
    out = conversions.strain_channel(ds, "str1", bridge_type="half_i", gauge_factor=2.1,
                                 poisson=0.29, lead_resistance=0.4, excitation_voltage=2.5,
                                 unstrained=(0.0, 0.4))
    np.testing.assert_allclose(out["str1_strain"], eps, atol=5e-9)
    assert out["str1_strain"].attrs["units"] == "1"
    assert out["str1_strain"].attrs["source_channel"] == "/'ai'/'str1'"
    assert "half_i" in out.attrs["history"]
    stress = conversions.axial_stress_channel(out, "str1_strain", youngs_modulus=210e9)
    np.testing.assert_allclose(stress["str1_strain_stress"], eps * 210e9, atol=2e-3)
    with pytest.raises(ConfigError, match="excitation"):
        conversions.strain_channel(ds, "str1", bridge_type="half_i", gauge_factor=2.1)
    with pytest.raises(UnitError):
        conversions.axial_stress_channel(ds, "str1", youngs_modulus=210e9)
    with pytest.raises(ChannelNotFoundError, match="str1"):
        conversions.strain_channel(ds, "str9", bridge_type="half_i", gauge_factor=2.1)


def test_axial_and_bending_parts_of_two_opposite_gauges() -> None:
    t = np.arange(0, 1, 1e-3)
    axial = 120e-6 * np.cos(2 * np.pi * t)
    bending = 300e-6 * np.sin(4 * np.pi * t)
    ds = _stream(t, {"top": Channel(axial + bending, "1", "top gauge", "/'s'/'top'"),
                     "bottom": Channel(axial - bending, "1", "bottom gauge", "/'s'/'bot'")},
                 "cDAQ-9172", "2026-03-02T10:00:00Z", 1000.0)
    w = 1e-5
    out = conversions.axial_bending_channels(ds, "top", "bottom", name="rod", youngs_modulus=210e9,
                                         section_modulus=w)
    np.testing.assert_allclose(out["rod_axial_strain"], axial, rtol=1e-12, atol=1e-20)
    np.testing.assert_allclose(out["rod_bending_moment"], 210e9 * w * bending, rtol=1e-12,
                               atol=1e-9)
    assert out["rod_axial_stress"].attrs["units"] == "Pa"
    with pytest.raises(UnitError):
        conversions.axial_bending_channels(out, "top", "rod_axial_stress", name="x")


def test_acceleration_channel_corrects_the_highpass_per_run() -> None:
    fs = 5000.0
    lead_in = np.arange(-40, 8, 1 / fs)                   # amplifier in steady state
    acc_all = 4.0 * np.sin(2 * np.pi * 1.0 * lead_in + 0.2)
    volts = accelerometer.charge_chain_voltage(acc_all, charge_sensitivity=10.0,
                                               amplifier_gain=10.0, fs=fs, highpass_hz=0.1)
    t, acc, volts = lead_in[lead_in >= 0], acc_all[lead_in >= 0], volts[lead_in >= 0]
    ds = _stream(t, {"acc1": Channel(volts * 1e3, "mV", "tip", "/'ai'/'acc1'")}, "cDAQ-9172",
                 "2026-03-02T10:00:00Z", fs)
    kept = conversions.acceleration_channel(ds, "acc1", charge_sensitivity=10.0,
                                            amplifier_gain=10.0)
    fixed = conversions.acceleration_channel(ds, "acc1", charge_sensitivity=10.0,
                                             amplifier_gain=10.0, highpass_hz=0.1)
    whole = t < 8.0 - 1 / fs                               # 8 whole periods: mean of truth is 0
    err_fixed = fixed["acc1_acceleration"].to_numpy() - acc
    err_fixed -= err_fixed[whole].mean()                   # a charge amplifier carries no DC
    assert np.max(np.abs(err_fixed)) < 0.02
    assert np.max(np.abs(kept["acc1_acceleration"].to_numpy() - acc)) > 0.3


def test_drive_excitation_dataset_has_units_and_noise_estimates(make_rig, synth) -> None:
    rig = make_rig(3)
    ds = _stream(rig.t_ref, {"enc2": Channel(rig.counts.astype(np.uint32), "1", "lifting shaft",
                                             "/'ci'/'enc2'")}, "cDAQ-9172",
                 "2026-03-02T10:00:00Z", synth.FS_REF)
    exc = excitation.drive_excitation(ds, "enc2", counts_per_rev=8192, name="theta_H")
    assert exc["theta_H_ddot"].attrs["units"] == "rad s-2"
    assert exc["theta_H_ddot"].attrs["noise_rms"] > 0
    _, rate = synth.shaft_angle(rig.t_ref)
    error = np.abs(exc["theta_H_dot"].to_numpy() - rate)
    inner = (rig.t_ref > 0.2) & (rig.t_ref < rig.t_ref[-1] - 0.2)
    assert np.max(error[inner]) < 0.002                  # 0.03 % of the speed
    assert np.max(error) < 0.05                          # record ends: filter edge effects
    assert "drive_excitation" in exc.attrs["history"]
    reloading = ds.assign(enc2=ds["enc2"] % 8192)        # the counter reloads at the Z index
    same = excitation.drive_excitation(reloading, "enc2", counts_per_rev=8192, name="theta_H",
                                       index_reset=True)
    np.testing.assert_allclose(same["theta_H_ddot"], exc["theta_H_ddot"], atol=1e-9)


def test_phi_f_flags_encoder_glitches_but_not_missing_pulses(make_rig, synth) -> None:
    rig = make_rig(4)
    counts = rig.counts.astype(np.int64)
    counts[rig.t_ref > 5.5] += 3                                  # three spurious counts
    opt1 = rig.opt1.copy()
    opt1[np.abs(rig.t_ref - rig.opt1_true[12] - 0.015) < 0.05] = 0.0   # one pulse missing
    ds = _stream(rig.t_ref, {
        "opt1": Channel(opt1, "V", "optical reference", "/'ai'/'opt1'"),
        "enc1": Channel((counts % 2**32).astype(np.uint32), "1", "encoder", "/'ci'/'enc1'"),
    }, "cDAQ-9172", "2026-03-02T10:00:00Z", synth.FS_REF)
    reference = pulses.stream_pulses(ds, "opt1")
    assert reference.missing_times.size == 1
    phi = angle.phi_f(ds, "enc1", reference, counts_per_rev=8192)
    glitch_cycle = int(synth.shaft_angle(np.array([5.5]))[0][0] // (2 * np.pi))
    assert phi.attrs["suspect_cycles"].tolist() == [glitch_cycle]
