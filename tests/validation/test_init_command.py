"""``rigval init``: a skeleton from the sample files passes once its TODOs are filled from the
rig's calibration; a skeleton from real NI-DAQmx files parses once filled."""

from __future__ import annotations

import json
import re
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from rigval.acquisition.errors import ConfigError
from rigval.acquisition.survey import classify_channel
from rigval.sample_data import runs_dir
from rigval.validation.cli import EXIT_OK, EXIT_USAGE, main
from rigval.validation.errors import SceneError
from rigval.validation.scene import load_scene, todo_keys, todo_label
from rigval.validation.scene_init import fill_todos

SAMPLE = ("run_0p8_cdaq.tdms", "run_0p8_wls1.tdms", "run_0p8_wls2.csv")


def _sheet_value(sheet: Any, path: str) -> Any:
    """The value at a dotted key path of a table of the calibration sheet, or None."""
    for part in path.split("."):
        if not isinstance(sheet, dict) or part not in sheet:
            return None
        sheet = sheet[part]
    return sheet


def _fill_sample(text: str) -> str:
    """Fill the skeleton as a newcomer would from the rig's calibration sheet.

    The sheet is the shipped scene: the calibration values of every channel, which shaft or
    point each sensor sits on, the angle of each driver at the reference pulse. A comparison
    the sheet has no entry for (acc3: no model point given) is deleted, as the newcomer would;
    a summed comparison is found on the sheet by its channels.
    """
    shipped = tomllib.loads((runs_dir() / "run_0p8_scene.toml").read_text())
    doc = tomllib.loads(text)
    values: dict[str, Any] = {}
    by_name = {c["name"]: c for c in shipped["comparisons"]}
    by_channels = {tuple(c["measured"]): c for c in shipped["comparisons"]
                   if isinstance(c["measured"], list)}
    unlisted = set()
    for key in todo_keys(doc):
        match = re.match(r"comparisons\[(\d+)\]\.(.+)", key)
        if match:
            index = int(match.group(1))
            table = doc["comparisons"][index]
            sheet = by_name.get(table["name"]) or by_channels.get(tuple(table["measured"]))
            if sheet is None:
                unlisted.add(index)
                continue
            values[key] = _sheet_value(sheet, match.group(2))
        else:  # a pulse sensor the sheet gives no angle for sits with the main one
            values[key] = _sheet_value(shipped, key)
            if values[key] is None and key.endswith(".angle"):
                values[key] = 0.0
    assert all(v is not None for v in values.values()), values
    filled = fill_todos(text, values)
    assert [doc["comparisons"][i]["name"] for i in unlisted] == ["acc3"]
    tables = filled.split("[[comparisons]]")
    kept = [table for i, table in enumerate(tables[1:]) if i not in unlisted]
    return "[[comparisons]]".join([tables[0], *kept])


def test_sample_skeleton_validates_once_filled(tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    scene = tmp_path / "scene.toml"
    code = main(["init", *(str(runs_dir() / f) for f in SAMPLE), "--out", str(scene),
                 "--mechanism", "builtin:pendulum"])
    out = capsys.readouterr().out
    assert code == EXIT_OK
    assert "angle_at_reference of theta_F: 1.46133 rad" in out
    text = scene.read_text()
    doc = tomllib.loads(text)
    # what the files tell
    assert doc["streams"]["cdaq"]["device"] == "cDAQ-9172"
    assert doc["streams"]["wls1"]["device"] == doc["streams"]["wls2"]["device"] == "WLS-9163"
    channels = doc["streams"]["cdaq"]["channels"]
    assert {n for n, c in channels.items() if c["sensor"] == "encoder"} == {"enc1", "enc2"}
    assert channels["opt1"]["sensor"] == "reference_pulse"
    assert channels["str1"]["module"] == "NI 9237"
    assert doc["alignment"]["main_encoder"] == "cdaq.enc1"
    assert doc["alignment"]["main_reference_pulse"] == "cdaq.opt1"
    assert doc["alignment"]["pulses"]["wls2"]["per_revolution"] == 2
    assert "8192 counts per main-shaft revolution" in text
    assert "16384 counts per main-shaft revolution" in text  # the lifting shaft turns twice
    # the value wanted is per turn of enc2's own shaft: the rig's 8192, which the hint names
    shipped = tomllib.loads((runs_dir() / "run_0p8_scene.toml").read_text())
    enc2 = shipped["streams"]["cdaq"]["channels"]["enc2"]["counts_per_rev"]
    hint = next(line for line in text.split("[streams.cdaq.channels.enc2]")[1].splitlines()
                if line.startswith("counts_per_rev"))
    assert "per turn of this encoder's own shaft" in hint and f"{enc2} if two" in hint
    # refused while TODOs remain, each named
    todo = todo_keys(doc)
    assert "streams.cdaq.channels.str1.gauge_factor" in todo
    assert "model.drivers.theta_H.angle_at_reference" in todo
    assert main(["validate", str(scene), "--out", str(tmp_path / "refused")]) == EXIT_USAGE
    err = capsys.readouterr().err
    # one key a line, a comparison's key with the comparison's name
    listed = [line.strip() for line in err.splitlines() if line.startswith("  ")]
    assert listed == [todo_label(doc, key) for key in todo]
    assert "comparisons[3] (str1).scale" in listed
    # every stated uncertainty is the newcomer's to state; the sums of both shafts proposed
    comparisons = {c["name"]: c for c in doc["comparisons"]}
    assert all(c["uncertainty"]["u_measurement_rel"] == "TODO" for c in comparisons.values())
    assert comparisons["tor1_tor2_sum"]["measured"] == ["wls1.tor1", "wls1.tor2"]
    assert comparisons["tor3_tor4_sum"]["measured"] == ["wls2.tor3", "wls2.tor4"]
    assert all(comparisons[n]["remove_offset"] for n in ("str1", "tor1", "tor1_tor2_sum"))
    assert "nulled with the machine at rest" in text
    # filled from the calibration sheet: passes, as the shipped scene does
    scene.write_text(_fill_sample(text))
    code = main(["validate", str(scene), "--out", str(tmp_path / "report")])
    out = capsys.readouterr()
    assert code == EXIT_OK, out.out + out.err
    html = (tmp_path / "report" / "report.html").read_text()
    # the report shows each driver's angle at the reference pulse next to the drive law's
    truth = json.loads((runs_dir() / "run_0p8_truth.json").read_text())
    angle = truth["angle_at_reference"]["theta_H"]
    assert (f"theta_H &lt;- cdaq.enc2 (angle at the reference pulse {angle:.5g} rad; the drive "
            "law gives 4.5895 rad)") in html


def test_init_refuses_to_overwrite(tmp_path: Path) -> None:
    scene = tmp_path / "scene.toml"
    scene.write_text("keep")
    assert main(["init", str(runs_dir() / SAMPLE[0]), "--out", str(scene)]) == EXIT_USAGE
    assert scene.read_text() == "keep"


def test_fill_todos_names_a_key_that_is_no_todo() -> None:
    text = '[a]\nx = "TODO"  # what\ny = 1\n[[c]]\nz = "TODO"\n[[c]]\nz = "TODO"\n'
    filled = fill_todos(text, {"a.x": 2.5, "c[1].z": "P1"})
    assert tomllib.loads(filled) == {"a": {"x": 2.5, "y": 1}, "c": [{"z": "TODO"}, {"z": "P1"}]}
    assert "# what" in filled
    with pytest.raises(ConfigError, match=r"a\.y: not a TODO"):
        fill_todos(text, {"a.y": 2})


# the example files' counters never counted: init warns that they cannot validate
@pytest.mark.filterwarnings("default::rigval.acquisition.errors.DataWarning")
def test_real_daqmx_skeleton_parses_once_filled(realdata_dir: Path, tmp_path: Path) -> None:
    files = []
    for n in ("ai", "ci1", "ci2"):  # copies: the lab's pulse channel is added to ci1 below
        files.append(tmp_path / f"data_{n}.tdms")
        files[-1].write_bytes((realdata_dir / "nidaqmx-python" / f"data_{n}.tdms").read_bytes())
    scene = tmp_path / "scene.toml"
    assert main(["init", *map(str, files), "--out", str(scene),
                 "--mechanism", "builtin:pendulum"]) == EXIT_OK
    text = scene.read_text()
    doc = tomllib.loads(text)
    streams = doc["streams"]
    assert set(streams) == {"ai", "ci1", "ci2"}
    assert streams["ci1"]["channels"]["Rotations01"]["sensor"] == "encoder"
    assert streams["ai"]["channels"]["Torque01"]["sensor"] == "linear"
    assert streams["ai"]["channels"]["Torque01"]["units"] == "N m"  # from the name
    assert doc["alignment"]["reference"] == "ci1"
    # no pulse recorded: the other tasks of the chassis by their start stamps, the reference
    # stream's pulse channel left to name
    assert doc["alignment"]["pulses"]["ai"] == {"method": "stamps"}
    assert doc["alignment"]["pulses"]["ci2"] == {"method": "stamps"}
    assert streams["ci1"]["channels"]["reference_pulse"]["source"] == "TODO"
    with pytest.raises(SceneError) as info:
        load_scene(scene)
    keys = info.value.extra["keys"]
    assert keys == todo_keys(doc)
    # what a lab would fill in: transducer scales, pulse channels, sensor positions, items
    values: dict[str, Any] = {}
    for key in keys:
        leaf = key.rsplit(".", 1)[-1]
        values[key] = {
            "slope": 20.0, "units": "N m", "counts_per_rev": 4096, "per_revolution": 1,
            "angle": 0.0, "item": "theta_F", "scale": 0.5, "u_measurement_rel": 0.02,
            "source": "PFI0"}[leaf]
    scene.write_text(fill_todos(text, values))
    with pytest.raises(SceneError, match="channels in the file: Rotations01") as info:
        load_scene(scene)  # PFI0 is not in data_ci1.tdms: refused when loaded, from its metadata
    assert info.value.where["key"] == "streams.ci1.channels.reference_pulse.source"
    _add_channel(files[1], "PFI0")  # the lab's pulse channel, recorded beside the counter
    parsed = load_scene(scene)
    assert parsed.streams["ai"].channels["Torque01"].params["slope"] == 20.0
    assert parsed.alignment.reference == "ci1"
    assert parsed.alignment.pulses["ai"].method == "stamps"
    assert parsed.units(parsed.comparisons[0].measured) == "N m"


def _add_channel(path: Path, name: str) -> None:
    """Append a channel on the time base of the file's first channel (a new segment)."""
    from nptdms import ChannelObject, TdmsFile, TdmsWriter

    first = next(c for g in TdmsFile.read(path).groups() for c in g.channels())
    marks = {k: v for k, v in first.properties.items() if k.startswith("wf_")}
    with TdmsWriter(path, mode="a") as writer:
        writer.write_segment([ChannelObject(first.group_name, name, np.zeros(len(first)),
                                            properties=marks)])


def _classify(name: str, values: np.ndarray, units: str):
    return classify_channel(name, values, units, np.arange(values.size) / 1000.0)[0]


def test_channel_roles_from_values_units_and_names() -> None:
    t = np.arange(5000) / 1000.0
    counts = np.floor(8192 * 0.8 * t)
    assert _classify("Rotations", counts, "1").role == "encoder"
    pulse = np.where(np.mod(t, 1.25) < 0.03, 4.7, 0.3)  # 0.8 rev/s, 3 % duty, analog levels
    guess, edges = classify_channel("opt1", pulse, "V", t)
    assert (guess.role, guess.sensor) == ("pulse", "reference_pulse")
    np.testing.assert_allclose(edges, np.arange(1, 4) * 1.25, atol=1.5e-3)
    low_pulses = 1.0 - (np.mod(t, 0.5) < 0.02)  # a digital line with short low pulses
    assert _classify("line", low_pulses.astype(np.uint8), "1").role == "pulse"
    square = (np.mod(t, 0.002) < 0.001).astype(np.uint8)  # a digital line toggling: no pulses
    assert _classify("line", square, "1").role == "line"
    sine = np.sin(2 * np.pi * 0.8 * t)
    assert _classify("acc1", sine, "V").sensor == "charge_accelerometer"
    assert _classify("tor1", sine * 1e-4, "V/V").sensor == "torsion_bridge"
    assert _classify("load", sine * 1e-4, "mV/V").sensor == "load_cell"
    assert _classify("str1", sine * 1e-4, "V/V").sensor == "strain_bridge"
    flange = _classify("Torque01", sine, "V")
    assert (flange.sensor, flange.output_units) == ("linear", "N m")
    assert _classify("p", sine, "Pa").sensor == "physical"
    scaled = _classify("ax", sine, "9.80665 m s-2")
    assert (scaled.sensor, scaled.output_units) == ("linear", "m s-2")


def test_lvm_in_g_becomes_a_linear_scale_to_m_s2(realdata_dir: Path, tmp_path: Path) -> None:
    path = realdata_dir / "lvm_read/no_decimal_separator.lvm"
    scene = tmp_path / "scene.toml"
    assert main(["init", str(path), "--out", str(scene), "--mechanism",
                 "builtin:pendulum"]) == EXIT_OK
    text = scene.read_text()
    doc = tomllib.loads(text)
    (stream,) = doc["streams"].values()
    assert stream["channels"]["ax"]["slope"] == 9.80665
    from rigval.acquisition.channel_map import load_stream, parse_stream
    from rigval.validation.stage_settings import convert_stream

    assert stream["reader"]["timezone"] == "TODO"  # LVM header times carry no zone
    table = {**stream, "reader": {"timezone": "UTC"}, "channels": {"ay": stream["channels"]["ay"]}}
    spec = parse_stream(table, "streams.no_decimal_separator", base_dir=tmp_path)
    raw = load_stream(spec)
    out = convert_stream(raw, spec)
    np.testing.assert_allclose(out["ay"].to_numpy(), raw["ay"].to_numpy() * 9.80665,
                               rtol=1e-12)
    assert out["ay"].attrs["units"] == "m s-2"


def test_index_reset_encoder_gives_the_pulse_angle_past_the_index(tmp_path: Path,
                                                                  capsys) -> None:
    from rigval.sample_data import RigSettings, simulate_rig

    files = simulate_rig(tmp_path / "rig", RigSettings(speed=0.8, duration=8.0, seed=4,
                                                       index_reset=True))
    truth = json.loads(files.path("truth.json").read_text())
    scene = tmp_path / "scene.toml"
    assert main(["init", str(files.path("cdaq.tdms")), "--out", str(scene),
                 "--mechanism", "builtin:pendulum"]) == EXIT_OK
    out = capsys.readouterr().out
    doc = tomllib.loads(scene.read_text())
    (stream,) = doc["streams"].values()  # one file: named after it
    assert stream["channels"]["enc1"]["index_reset"] is True
    assert "index_reset" not in stream["channels"]["enc2"]
    assert "8192 counts per main-shaft revolution" in scene.read_text()
    match = re.search(r"its angle at the index of enc1 \+ direction x ([0-9.e-]+) rad", out)
    assert match, out
    index_angle = truth["streams"]["cdaq"]["channels"]["enc1"]["sensor"]["index_angle"]
    expected = np.mod(truth["angle_at_reference"]["theta_F"] - index_angle, 2 * np.pi)
    # the pulse edge is known to a sample: 8192 x 0.8 / 5000 = 1.3 counts, 1.0e-3 rad
    error = np.angle(np.exp(1j * (float(match.group(1)) - expected)))
    assert abs(error) < 2e-3


def test_channel_names_that_read_alike_stay_distinct(tmp_path: Path) -> None:
    from rigval.acquisition.survey import guess_streams
    from rigval.validation.scene_init import skeleton_text

    csv = tmp_path / "run.csv"
    rows = ["Time;Dev1/ai0 [V];Dev1 ai0 [V]"]
    rows += [f"{k / 1000:.3f};{np.sin(k / 50):.6f};{np.cos(k / 50):.6f}" for k in range(2000)]
    csv.write_text("\n".join(rows) + "\n")
    (stream,) = guess_streams([csv])
    assert [c.name for c in stream.channels] == ["Dev1_ai0", "Dev1_ai0_2"]
    text, _ = skeleton_text([stream], tmp_path / "scene.toml")
    doc = tomllib.loads(text)  # valid TOML: no table declared twice
    assert [c["source"] for c in doc["streams"]["run"]["channels"].values()][:2] == [
        "Dev1/ai0", "Dev1 ai0"]
