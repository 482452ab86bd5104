"""Text files of a virtual-rig run: the scene that validates it and the operator's note.

The scene follows ``docs/scene.md`` (schema ``rigval-scene/1``) and carries the calibration values
the generator used (certificate sensitivities, gauge-factor lots, shaft and rod data), the nominal
half-and-half torque split (the true split is a few percent off, as on the real machine) and the
model drive angles at the main reference pulse.
"""

from __future__ import annotations

import datetime
import logging
import zoneinfo
from pathlib import Path

import numpy as np

from rigval.sample_data.devices import Stream
from rigval.sample_data.rig import RigDraw, RigSettings, RunFiles

__all__ = ["LAB_TIMEZONE", "local_time", "note_text", "scene_text"]

logger = logging.getLogger(__name__)

#: Time zone of the lab: the operator's note and the WLS #2 laptop use local time.
LAB_TIMEZONE = "Europe/Berlin"


def local_time(utc: np.datetime64) -> datetime.datetime:
    """Return a UTC time as an aware local date-time of the lab."""
    stamp = datetime.datetime.fromtimestamp(
        int(np.datetime64(utc, "us").astype(np.int64)) / 1e6, tz=datetime.UTC)
    return stamp.astimezone(zoneinfo.ZoneInfo(LAB_TIMEZONE))


def _stated(draw: RigDraw, name: str, true_value: float) -> float:
    """Return the value the scene states for a sensor whose true value has a calibration error.

    The certificate and lot values are printed to two decimals, so the stated value is the true
    one without its drawn error, rounded back to the printed digits.
    """
    error = draw.calibration_error.get(name)
    return true_value if error is None else round(true_value / (1.0 + error), 2)


def _accelerometer(name: str, draw: RigDraw) -> str:
    sensor = draw.accelerometers[name]
    sensitivity = _stated(draw, name, sensor.charge_sensitivity)
    return f"""
[streams.cdaq.channels.{name}]
source = "{name}"
module = "NI 9215"
sensor = "charge_accelerometer"
charge_sensitivity = {sensitivity!r}   # pC/g, calibration certificate
amplifier_gain = {sensor.amplifier_gain * 1e-3!r}   # V/pC
highpass_hz = {sensor.highpass_hz!r}
correct_highpass = true
"""


def _wls_stream(stream: str, file: str, reader: str, torsions: tuple[str, ...], pulse: str,
                draw: RigDraw) -> str:
    """Return the scene text of one WLS-9163 stream: its file, torsion channels and pulse."""
    text = f"""[streams.{stream}]
file = "{file}"
device = "WLS-9163"
reader = {reader}
"""
    text += "".join(_torsion(stream, name, draw) for name in torsions)
    return text + f"""
[streams.{stream}.channels.{pulse}]
source = "{pulse}"
module = "NI 9237"                     # spare bridge channel: the sensor switches a shunt
sensor = "reference_pulse"
"""


def _torsion(stream: str, name: str, draw: RigDraw) -> str:
    sensor = draw.torsion[name]
    return f"""
[streams.{stream}.channels.{name}]
source = "{name}"
module = "NI 9237"
sensor = "torsion_bridge"
bridge = "full"
gauge_factor = {_stated(draw, name, sensor.gauge_factor)!r}
excitation = {sensor.excitation!r}
outer_diameter = {sensor.outer_diameter!r}
inner_diameter = {sensor.inner_diameter!r}
shear_modulus = {sensor.shear_modulus!r}
"""


def _face_gauges(draw: RigDraw) -> str:
    """Return the scene text of the gauge pair on rod B's faces (empty without one)."""
    text = ""
    for name, face in draw.bending.items():
        side = "+n, stretched by positive bending" if name == "str2" else "-n, opposite str2"
        text += f"""
[streams.cdaq.channels.{name}]
source = "{name}"
module = "NI 9237"
sensor = "strain_bridge"
bridge = "quarter_I"                   # one gauge on the face of rod B at {side}
gauge_factor = {_stated(draw, name, face.gauge_factor)!r}
excitation = {face.excitation!r}
gauge_resistance = {face.gauge_resistance!r}
lead_resistance = 0.0
poisson = {face.poisson!r}
youngs_modulus = {face.youngs_modulus!r}
null_offset = "none"
"""
    return text


def _encoder(name: str, draw: RigDraw) -> str:
    """Return an encoder channel's table, noting an index that reloads the counter (no key yet)."""
    encoder = draw.encoders[name]
    reload = (f"# the counter reloads 0 at every index (Z) pulse: counts run 0 ... "
              f"{encoder.counts_per_rev - 1}\n" if encoder.index_reset else "")
    return f"""[streams.cdaq.channels.{name}]
source = "{name}"
module = "NI 9411"
sensor = "encoder"
counts_per_rev = {encoder.counts_per_rev}
{reload}"""


def _comparison(name: str, measured: str, model: str, scale: float, thresholds: str,
                extra: str = "") -> str:
    return f"""
[[comparisons]]
name = "{name}"
measured = "{measured}"
model = {model}
scale = {scale!r}
{extra}thresholds = {thresholds}
"""


def scene_text(settings: RigSettings, draw: RigDraw, files: RunFiles,
               references: dict[str, float]) -> str:
    """Return the scene (TOML) that validates a run.

    Parameters
    ----------
    settings : RigSettings
        The run's settings.
    draw : RigDraw
        The run's draws (sensor parameters).
    files : RunFiles
        The run's paths (file names are written relative to the scene).
    references : dict of str to float
        ``theta_F``, ``theta_H``: model drive angles (rad, in [0, 2 pi)) when the main reference
        pulse fires; ``opt3_phi_F``: main-shaft angle phi_F (rad) when the lifting-shaft pulse
        fires.

    Returns
    -------
    str
        The scene text.
    """
    # A scene resolves relative paths against its own folder: write the mechanism's absolute path.
    mechanism = (f'"{Path(settings.mechanism).resolve().as_posix()}"' if settings.mechanism
                 else '"builtin:pendulum"')
    bridge = draw.str1
    area = bridge.area
    # WLS #2 is stamped by a second laptop whose clock is off by up to host_clock_s: its stamps'
    # bound is that plus both devices' profile bounds (WLS-9163 0.1 s, cDAQ-9172 0.016 s).
    host = settings.imperfections.host_clock_s
    wls2_window = f", start_time_uncertainty_s = {host + 0.116:.3f}" if host > 0 else ""
    text = f"""# Scene written by the rigval virtual rig (rigval simulate-rig
# --speed {settings.speed} --duration {settings.duration} --seed {settings.seed});
# calibration values as the rig used them.
schema = "rigval-scene/1"
title = "Folding pendulum, virtual rig, {settings.speed} rev/s, seed {settings.seed}"
mechanism = {mechanism}
note = "{files.path('note.txt').name}"

[streams.cdaq]
file = "{files.path('cdaq.tdms').name}"
device = "cDAQ-9172"
reader = {{ group = "cDAQ1 task" }}
"""
    text += "".join(_accelerometer(name, draw) for name in ("acc1", "acc2", "acc3"))
    text += f"""
[streams.cdaq.channels.str1]
source = "str1"
module = "NI 9237"                     # 24-bit bridge module: input delay 8.0 ms at 5 kS/s
sensor = "strain_bridge"
bridge = "half_I"                      # axial + Poisson gauge on the neutral axis of rod B
gauge_factor = {_stated(draw, "str1", bridge.gauge_factor)!r}
excitation = {bridge.excitation!r}
gauge_resistance = {bridge.gauge_resistance!r}
lead_resistance = 0.0
poisson = {bridge.poisson!r}
youngs_modulus = {bridge.youngs_modulus!r}
null_offset = "none"                   # bridge nulled with the machine at rest before the run
{_face_gauges(draw)}
{_encoder("enc1", draw)}
{_encoder("enc2", draw)}
[streams.cdaq.channels.opt1]
source = "opt1"
module = "NI 9215"
sensor = "reference_pulse"

"""
    text += _wls_stream("wls1", files.path("wls1.tdms").name, '{ group = "WLS1 task" }',
                        ("tor1", "tor2"), "opt2", draw)
    text += "\n" + _wls_stream(
        "wls2", files.path("wls2.csv").name,
        f'{{ decimal = ",", delimiter = ";", timezone = "{LAB_TIMEZONE}" }}', ("tor3", "tor4"),
        "opt3", draw)
    text += f"""
[alignment]
reference = "cdaq"
main_encoder = "cdaq.enc1"
main_reference_pulse = "cdaq.opt1"

[alignment.pulses]
wls1 = {{ channel = "opt2", per_revolution = 1 }}
wls2 = {{ channel = "opt3", per_revolution = 2, angle = {references['opt3_phi_F']!r}{wls2_window} }}

[angle]
points_per_revolution = 360
interpolation = "cubic"
min_cycles = 3

[model]
drives = "measured"

[model.drivers.theta_F]
encoder = "cdaq.enc1"
angle_at_reference = {references['theta_F']!r}
direction = 1

[model.drivers.theta_H]
encoder = "cdaq.enc2"
angle_at_reference = {references['theta_H']!r}
direction = 1
"""
    verdict = '"vv20.curve.normalised_error" = "<= 2"'
    acc_thresholds = ('{ "iso18571_periodic.rating" = ">= 0.8", "nrmse" = "<= 0.15", '
                      f'{verdict} }}')
    torque_thresholds = f'{{ "iso18571_periodic.rating" = ">= 0.8", {verdict} }}'
    zero = "remove_offset = true   # bridge zero after the pre-run null: a few N m, unknown"
    for name, point in (("acc1", "P1"), ("acc2", "P2")):
        text += _comparison(name, f"cdaq.{name}",
                            f'{{ quantity = "point_acceleration", item = "{point}", axis = "x" }}',
                            1.0, acc_thresholds, "lowpass_hz = 20.0\nremove_offset = true\n"
                            "uncertainty = { u_measurement_rel = 0.02 }   # sensitivity and "
                            "amplifier gain, 2 %\n")
    for name in ("str1", *draw.bending):
        text += _comparison(name, f"cdaq.{name}",
                            '{ quantity = "joint_force", item = "P5", axis = "x" }', -1.0 / area,
                            f'{{ "iso18571_periodic.rating" = ">= 0.58", {verdict} }}',
                            'scale_units = "m-2"                     # -1/A, A = '
                            f'{area!r} m2 (paper eq. 24)\nlowpass_hz = 20.0\n'
                            "uncertainty = { u_measurement_rel = 0.02 }   # gauge factor, "
                            "modulus, area: 2 %\n")
    for name, driver, stream in (("tor1", "theta_F", "wls1"), ("tor2", "theta_F", "wls1"),
                                 ("tor3", "theta_H", "wls2"), ("tor4", "theta_H", "wls2")):
        text += _comparison(name, f"{stream}.{name}",
                            f'{{ quantity = "driver_torque", item = "{driver}" }}', 0.5,
                            torque_thresholds, f"{zero}\n"
                            "uncertainty = { u_measurement_rel = 0.036 }  # calibration 1 %; "
                            "the shafts' split of the torque, 50 +- 3 %: 3.5 %\n")
    for name, driver, stream, pair in (("torque_F", "theta_F", "wls1", ("tor1", "tor2")),
                                       ("torque_H", "theta_H", "wls2", ("tor3", "tor4"))):
        text += f"""
[[comparisons]]
name = "{name}"
measured = ["{stream}.{pair[0]}", "{stream}.{pair[1]}"]   # both shafts: the whole drive torque
model = {{ quantity = "driver_torque", item = "{driver}" }}
scale = 1.0
{zero}
# torsion bridge calibration (G, diameters, k), 1 %; common to the four shafts (one gauge lot,
# one steel, one drawing) 0.98 %, each sum's own (gauge to gauge, module gain) 0.2 %
uncertainty = {{ u_measurement_rel = 0.01, u_measurement_rel_common = 0.0098 }}
thresholds = {torque_thresholds}
"""
    text += """
[predictions]
points = ["P1", "P2"]
supports = ["P3", "P4", "P10", "P11"]
"""
    return text


def note_text(settings: RigSettings, draw: RigDraw, streams: dict[str, Stream],
              files: RunFiles) -> str:
    """Return the operator's short note of the run, as users keep one next to the files."""
    local = local_time(draw.start_time)
    restarts = {name: len(streams[name].clock.segments) - 1 for name in ("wls1", "wls2")}
    link = "; ".join(f"{name.upper()}: {n} Wi-Fi dropout(s), task restarted"
                     for name, n in restarts.items() if n) or "no Wi-Fi dropouts noticed"
    rpm = settings.speed * 60.0
    return (f"Folding pendulum test rig - measurement run\r\n"
            f"Date: {local:%d.%m.%Y}, start about {local:%H:%M} (local time)\r\n"
            f"Main drive setting: {settings.speed} rev/s ({rpm:.0f} rpm), lifting drive 2:1\r\n"
            f"Recording: about {settings.duration:.0f} s on each device, started by hand\r\n"
            f"  cDAQ-9172 (USB) -> {files.path('cdaq.tdms').name}\r\n"
            f"  WLS-9163 #1 main shafts (Wi-Fi) -> {files.path('wls1.tdms').name}\r\n"
            f"  WLS-9163 #2 lifting shafts (Wi-Fi, laptop 2) -> {files.path('wls2.csv').name}\r\n"
            f"Bridges nulled with the machine at rest before start.\r\n"
            f"Link: {link}.\r\n"
            f"(virtual rig: rigval simulate-rig --speed {settings.speed} "
            f"--duration {settings.duration} --seed {settings.seed})\r\n")
