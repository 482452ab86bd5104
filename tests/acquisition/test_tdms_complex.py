"""Complex-valued TDMS channels (an NI RF capture's "Polar Graph", an FFT written as complex).

Such a channel is read as two real variables ``<name>.real`` and ``<name>.imag`` on the
channel's time base, with its units; the files are written here with nptdms's writer
(complex64 and complex128 numpy arrays), in two segments, beside a real channel, and every value
read is compared with the value written. Channels of other non-numeric types (text) are still
left out with a DataWarning naming them, and an error when asked for by name.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from nptdms import ChannelObject, GroupObject, RootObject, TdmsWriter

from rigval.acquisition import read
from rigval.acquisition.errors import ChannelNotFoundError, DataFileError, DataWarning
from rigval.acquisition.schema import check_stream
from rigval.acquisition.summary import describe
from rigval.acquisition.tdms import iter_tdms

N = 1000


def _write(path: Path, dtype: type) -> tuple[np.ndarray, np.ndarray]:
    """Write a complex and a real channel in two segments; return the values written."""
    rng = np.random.default_rng(21)
    polar = (rng.normal(size=N) + 1j * rng.normal(size=N)).astype(dtype)
    amplitude = np.abs(polar).astype(float) * 2.5
    props = {"wf_increment": 1e-6, "unit_string": "V"}
    with TdmsWriter(path) as writer:
        writer.write_segment([RootObject(), GroupObject("RF"),
                              ChannelObject("RF", "Polar Graph", polar[:600], properties=props),
                              ChannelObject("RF", "amplitude", amplitude[:600],
                                            properties=props)])
        writer.write_segment([ChannelObject("RF", "Polar Graph", polar[600:]),
                              ChannelObject("RF", "amplitude", amplitude[600:])])
    return polar, amplitude


def _read(path: Path, **options: object) -> tuple[xr.Dataset, list[str]]:
    """Read a one-stream file; return the stream and the DataWarning texts."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        (stream,) = read(path, checksum=False, **options).values()
    check_stream(stream)
    return stream, [str(w.message) for w in caught if issubclass(w.category, DataWarning)]


@pytest.mark.parametrize("dtype", [np.complex64, np.complex128])
def test_complex_channel_is_read_as_its_parts(tmp_path: Path, dtype: type) -> None:
    path = tmp_path / "rf_capture.tdms"
    polar, amplitude = _write(path, dtype)
    stream, texts = _read(path)
    assert not [t for t in texts if "are not read" in t], texts
    assert list(stream.data_vars)[:3] == ["Polar Graph.real", "Polar Graph.imag", "amplitude"]
    np.testing.assert_array_equal(stream["Polar Graph.real"].values, polar.real)
    np.testing.assert_array_equal(stream["Polar Graph.imag"].values, polar.imag)
    np.testing.assert_array_equal(stream["amplitude"].values, amplitude)
    assert stream["Polar Graph.real"].dtype == polar.real.dtype  # float32 for complex64
    np.testing.assert_allclose(stream["time"].values, np.arange(N) * 1e-6, rtol=0, atol=1e-15)
    imag = stream["Polar Graph.imag"].attrs
    assert (imag["units"], imag["complex_part"], imag["complex_type"]) == (
        "V", "imag", np.dtype(dtype).name)
    assert imag["source_channel"] == "/'RF'/'Polar Graph'"


def test_parts_asked_for_by_name(tmp_path: Path) -> None:
    path = tmp_path / "rf.tdms"
    polar, _ = _write(path, np.complex128)
    stream, _ = _read(path, channels=["Polar Graph.imag"])
    assert [v for v in stream.data_vars if v not in ("valid", "segment")] == ["Polar Graph.imag"]
    np.testing.assert_array_equal(stream["Polar Graph.imag"].values, polar.imag)
    stream, _ = _read(path, channels=["RF/Polar Graph"])
    assert {"Polar Graph.real", "Polar Graph.imag"} <= set(stream.data_vars)
    with pytest.raises(ChannelNotFoundError, match=r"'Polar Graph\.phase' not in the file") as info:
        read(path, channels=["Polar Graph.phase"], checksum=False)
    assert "'C.real' and 'C.imag'" in str(info.value)
    with pytest.raises(ChannelNotFoundError, match=r"'amplitude\.real' not in the file"):
        read(path, channels=["amplitude.real"], checksum=False)  # a real channel has no parts


def test_parts_survive_netcdf_and_windows(tmp_path: Path) -> None:
    path = tmp_path / "rf.tdms"
    polar, _ = _write(path, np.complex128)
    stream, _ = _read(path)
    stream.to_netcdf(tmp_path / "rf.nc", engine="netcdf4")
    with xr.open_dataset(tmp_path / "rf.nc", engine="netcdf4", decode_times=False) as back:
        np.testing.assert_array_equal(back["Polar Graph.real"].values, polar.real)
        np.testing.assert_array_equal(back["Polar Graph.imag"].values, polar.imag)
        assert back["Polar Graph.imag"].attrs["complex_part"] == "imag"
    windows = list(iter_tdms(path, chunk_samples=256, checksum=False))
    assert [w.sizes["time"] for w in windows] == [256, 256, 256, 232]
    got = np.concatenate([w["Polar Graph.real"].values + 1j * w["Polar Graph.imag"].values
                          for w in windows])
    np.testing.assert_array_equal(got, polar)
    names = [c["name"] for s in describe(path)["streams"] for c in s["channels"]]
    assert names == ["Polar Graph.real", "Polar Graph.imag", "amplitude"]


def test_text_channel_is_still_named_and_left_out(tmp_path: Path) -> None:
    path = tmp_path / "notes.tdms"
    with TdmsWriter(path) as writer:
        writer.write_segment([GroupObject("g"),
                              ChannelObject("g", "a", np.arange(5.0),
                                            properties={"wf_increment": 0.1}),
                              ChannelObject("g", "notes", np.array(["x", "yy", "zzz"]))])
    stream, texts = _read(path)
    assert "notes" not in stream
    assert any("1 channel(s) hold values that are not numbers and are not read: g/notes "
               "(text, 3 values)" in t for t in texts), texts
    with pytest.raises(DataFileError, match=r"holds text values \(3\), not numeric samples"):
        read(path, channels=["notes"], checksum=False)
