"""The scene's channel map: the documented example parses; errors name their key path."""

from __future__ import annotations

import dataclasses
import math
import re
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from nptdms import ChannelObject, GroupObject, TdmsWriter

from rigval.acquisition.channel_map import load_stream, parse_stream, parse_streams
from rigval.acquisition.errors import ChannelMapError, ChannelNotFoundError

REPO = Path(__file__).resolve().parents[2]


def _scene_example() -> dict[str, Any]:
    text = (REPO / "docs" / "scene.md").read_text()
    block = re.search(r"```toml\n(.*?)```", text, re.DOTALL)
    assert block is not None
    return tomllib.loads(block.group(1))


def test_documented_scene_example_parses(tmp_path: Path) -> None:
    streams = parse_streams(_scene_example()["streams"], base_dir=tmp_path)
    assert list(streams) == ["cdaq", "wls1", "wls2"]
    cdaq = streams["cdaq"]
    assert cdaq.file == tmp_path / "run_1p0_cdaq.tdms"
    assert cdaq.device == "cDAQ-9172"
    assert dict(cdaq.reader) == {"group": "cDAQ1 task"}
    acc1 = cdaq.channel("acc1")
    assert (acc1.sensor, acc1.key) == ("charge_accelerometer", "streams.cdaq.channels.acc1")
    assert acc1.params["charge_sensitivity"] == 10.2
    assert acc1.params["correct_highpass"] is True
    str1 = cdaq.channel("str1")
    assert str1.params["bridge"] == "half_II"
    assert str1.params["youngs_modulus"] == 210e9
    tor1 = streams["wls1"].channel("tor1")
    assert tor1.params["inner_diameter"] == 0.060
    assert tor1.params["null_offset"] == "none"  # default filled in
    assert cdaq.channel("enc1").params["counts_per_rev"] == 8192
    assert dict(streams["wls2"].reader) == {"decimal": ",", "delimiter": ";"}
    with pytest.raises(ChannelNotFoundError, match="Available: acc1, str1"):
        cdaq.channel("acc9")


@pytest.mark.parametrize(("change", "key"), [
    ({"channels": {"a": {"sensor": "laser"}}}, "streams.s.channels.a.sensor"),
    ({"channels": {"a": {"sensor": "encoder"}}}, "streams.s.channels.a.counts_per_rev"),
    ({"channels": {"a": {"sensor": "encoder", "counts_per_rev": 2.5}}},
     "streams.s.channels.a.counts_per_rev"),
    ({"channels": {"a": {"sensor": "charge_accelerometer", "charge_sensitivity": -1,
                         "amplifier_gain": 0.01}}}, "streams.s.channels.a.charge_sensitivity"),
    ({"channels": {"a": {"sensor": "voltage", "gain": 2}}}, "streams.s.channels.a.gain"),
    ({"channels": {"a": {"sensor": "torsion_bridge", "bridge": "full", "gauge_factor": 2.1,
                         "outer_diameter": 0.1, "inner_diameter": 0.1,
                         "shear_modulus": 80e9}}}, "streams.s.channels.a.inner_diameter"),
    ({"channels": {"a": {"sensor": "voltage", "module": "NI 1234"}}},
     "streams.s.channels.a.module"),
    ({"channels": {"a": {"sensor": "voltage"}, "b": {"sensor": "voltage", "source": "a"}}},
     "streams.s.channels"),
    ({"device": "PXI-1000"}, "streams.s.device"),
    ({"reader": {"channels": ["x"]}}, "streams.s.reader.channels"),
    ({"reader": {"sep": ";"}}, "streams.s.reader.sep"),
    ({"files": "x"}, "streams.s.files"),
    ({"file": None}, "streams.s.file"),
])
def test_bad_channel_maps_name_the_key_path(change: dict[str, Any], key: str) -> None:
    table = {"file": "run.tdms", **change}
    table = {k: v for k, v in table.items() if v is not None}
    with pytest.raises(ChannelMapError) as error:
        parse_stream(table, "streams.s")
    assert error.value.where["key"] == key


def test_load_stream_renames_sources_and_attaches_sensors(tmp_path: Path) -> None:
    props = {"wf_increment": 1 / 1612.9032258064517, "wf_start_time":
             np.datetime64("2026-11-21T05:00:00"), "wf_start_offset": 0.0, "unit_string": "V/V"}
    with TdmsWriter(tmp_path / "wls1.tdms") as writer:
        writer.write_segment([GroupObject("WLS task"),
                              ChannelObject("WLS task", "ai0", np.arange(10.0), props),
                              ChannelObject("WLS task", "ai1", -np.arange(10.0), props)])
    scene = tomllib.loads("""
        [streams.wls1]
        file = "wls1.tdms"
        device = "WLS-9163"
        [streams.wls1.channels.tor1]
        source = "ai1"
        sensor = "torsion_bridge"
        bridge = "full"
        gauge_factor = 2.1
        outer_diameter = 0.1
        inner_diameter = 0.06
        shear_modulus = 80e9
    """)
    spec = parse_streams(scene["streams"], base_dir=tmp_path)["wls1"]
    ds = load_stream(spec)
    assert [v for v in ds.data_vars if v not in ("valid", "segment")] == ["tor1"]
    np.testing.assert_array_equal(ds["tor1"].values, -np.arange(10.0))
    attrs = ds["tor1"].attrs
    assert attrs["sensor"] == "torsion_bridge"
    assert attrs["sensor_shear_modulus"] == 80e9 and attrs["sensor_bridge"] == "full"
    assert attrs["sensor_inner_diameter"] == 0.06 and "sensor_excitation" not in attrs
    assert set(attrs["sensor_params"]) == {"bridge", "gauge_factor", "outer_diameter",
                                           "inner_diameter", "shear_modulus", "null_offset"}
    assert attrs["source_channel"] == "/'WLS task'/'ai1'"
    assert attrs["input_delay_s"] == pytest.approx((40 + 5 / 512) * 0.00062 + 4.5e-6)
    assert ds.attrs["stream"] == "wls1"
    with pytest.raises(ChannelMapError, match="channels in the file: ai0, ai1") as error:
        # refused when parsed, from the file's metadata, before any sample is read
        parse_stream({"file": "wls1.tdms", "channels": {"x": {"sensor": "voltage"}}},
                     "streams.wls1", base_dir=tmp_path)
    assert error.value.where["key"] == "streams.wls1.channels.x.source"
    late = dataclasses.replace(spec, channels={"x": dataclasses.replace(
        spec.channels["tor1"], name="x", source="x", key="streams.wls1.channels.x")})
    with pytest.raises(ChannelMapError, match="channels in the file: ai0, ai1") as error:
        load_stream(late)  # and when read (a spec built in code)
    assert error.value.where["key"] == "streams.wls1.channels.x.source"
    with pytest.raises(ChannelMapError, match="the tdms reader has no such option") as error:
        parse_stream({"file": "wls1.tdms", "reader": {"grop": "x"}}, "streams.wls1",
                     base_dir=tmp_path)  # an option no reader has (a typo of group)
    assert error.value.where["key"] == "streams.wls1.reader.grop"
    assert "has this option" not in str(error.value)
    with pytest.raises(ChannelMapError, match=r"wls1.tdms is a TDMS file, but the reader "
                       r"options decimal are those of the csv or lvm reader") as error:
        parse_stream({"file": "wls1.tdms", "reader": {"decimal": ","}}, "streams.wls1",
                     base_dir=tmp_path)  # CSV options for a file that is TDMS: the wrong file
    assert error.value.where["key"] == "streams.wls1.file"


def _inside(rule: Any) -> float | int:
    """A value well inside a parameter's plausible range."""
    if rule.kind == "int":
        return 8192
    return math.sqrt(rule.low * rule.high) if rule.low > 0 else min(1.0, rule.high)


def test_every_sensor_range_is_in_the_scene_docs() -> None:
    """Each calibration value with a plausible range is in docs/scene.md's range table, and a
    value just outside its range is refused naming its key (just inside is accepted)."""
    from rigval.acquisition.channel_map import SENSORS

    docs = (REPO / "docs" / "scene.md").read_text(encoding="utf-8")
    table = docs[docs.index("| key | plausible magnitude |"):]
    table = table[:table.index("\n\n")]
    for sensor, rules in SENSORS.items():
        for param, rule in rules.items():
            if rule.kind not in ("positive", "nonnegative", "number") or \
                    (rule.low, rule.high) == (0.0, 1e15):
                continue
            assert f"`{param}`" in table, param
            if param == "inner_diameter":
                continue  # bounded by the outer diameter first (its own test above)
            base = {"sensor": sensor, **{p: r.choices[0] if r.kind == "choice" else
                                         ("V" if r.kind == "text" else _inside(r))
                                         for p, r in rules.items() if r.required}}
            key = f"streams.s.channels.c.{param}"
            for value, accepted in ((rule.high, True), (rule.high * 1.01, False),
                                    (rule.low * 0.99, rule.low == 0.0)):
                if value == 0.0:
                    continue
                table_ = {"file": "absent.tdms", "channels": {"c": {**base, param: value}}}
                if accepted:
                    parse_stream(table_, "streams.s")
                else:
                    with pytest.raises(ChannelMapError, match="plausible range") as error:
                        parse_stream(table_, "streams.s")
                    assert error.value.where["key"] == key
