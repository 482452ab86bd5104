"""The direct TDMS path: values equal nptdms's, the one-pass SHA-256 equals hashlib's of the file.

Each file is read twice: as rigval reads it (the direct path for plain segments) and with the
direct path switched off (nptdms reads the values, ``source_checksum`` hashes the file); values,
time axes, attributes and warnings must agree, and the digest must equal ``hashlib.sha256`` of the
file's bytes (what ``sha256sum`` prints).
"""

from __future__ import annotations

import hashlib
import io
import struct
import tracemalloc
import warnings
from pathlib import Path

import numpy as np
import pytest
from nptdms import ChannelObject, GroupObject, RootObject, TdmsFile, TdmsWriter

import rigval.acquisition.tdms as tdms_module
import rigval.acquisition.tdms_direct as direct
from rigval.acquisition import read, read_stream
from rigval.acquisition.errors import DataFileError
from rigval.acquisition.hashing import BY_REFERENCE_BYTES, STAGING_BYTES, ThreadedSha256
from rigval.acquisition.tdms_layout import scan_tdms

T0 = np.datetime64("2026-11-21T05:00:00.123456", "ns")
PROPS = {"wf_start_time": T0, "wf_increment": 1e-3, "wf_start_offset": 0.0}


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _channels(k: int, n: int, props: dict | None = None) -> list[ChannelObject]:
    """Four channels of four types, values depending on the segment ``k``."""
    rng = np.random.default_rng(k)
    p = props or {}
    return [ChannelObject("task", "f64", rng.normal(size=n) + k, p),
            ChannelObject("task", "f32", rng.normal(size=n).astype(np.float32), p),
            ChannelObject("task", "i16", rng.integers(-3000, 3000, n).astype(np.int16), p),
            ChannelObject("task", "u32", rng.integers(0, 2**32 - 1, n).astype(np.uint32), p)]


def _read_both(path: Path, monkeypatch: pytest.MonkeyPatch, *,
               route: tuple[str, str] = ("read_plain", "plain_selection"),
               **options: object) -> tuple:
    """Return (direct result, nptdms result, direct warnings, nptdms warnings, route used).

    ``route`` names the direct reader and its selection in ``rigval.acquisition.tdms`` (the
    plain one by default); the nptdms result is read with that selection switched off.
    """
    used = []
    reader, selection = route
    original = getattr(tdms_module, reader)

    def spy(*args: object, **kw: object) -> object:
        used.append(True)
        return original(*args, **kw)

    with monkeypatch.context() as patch:
        patch.setattr(tdms_module, reader, spy)
        with warnings.catch_warnings(record=True) as fast_warnings:
            warnings.simplefilter("always")
            fast = read(path, **options)
    with monkeypatch.context() as patch:
        patch.setattr(tdms_module, selection, lambda *a, **k: None)
        patch.setattr("rigval.acquisition.detect._DIGESTS", {})
        with warnings.catch_warnings(record=True) as slow_warnings:
            warnings.simplefilter("always")
            slow = read(path, **options)
    return fast, slow, fast_warnings, slow_warnings, bool(used)


def _assert_same(fast: dict, slow: dict) -> None:
    assert list(fast) == list(slow)
    for name in fast:
        a, b = fast[name], slow[name]
        assert list(a.data_vars) == list(b.data_vars)
        for var in a.data_vars:
            assert a[var].dtype == b[var].dtype, var
            np.testing.assert_array_equal(a[var].values, b[var].values, err_msg=var)
            np.testing.assert_equal(dict(a[var].attrs), dict(b[var].attrs), err_msg=var)
        np.testing.assert_array_equal(a.time.values, b.time.values)
        np.testing.assert_equal(dict(a.attrs), dict(b.attrs))


@pytest.fixture(autouse=True)
def _fresh_digests(monkeypatch: pytest.MonkeyPatch) -> None:
    """Each test starts without digests remembered from other tests."""
    monkeypatch.setattr("rigval.acquisition.detect._DIGESTS", {})


def test_several_segments_read_directly_equal_nptdms_and_hash_the_whole_file(
        write_tdms, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = write_tdms(tmp_path / "multi.tdms",
                      [_channels(k, 1000 + 37 * k, PROPS if k == 0 else None) for k in range(5)])
    fast, slow, fw, sw, used = _read_both(path, monkeypatch)
    assert used
    _assert_same(fast, slow)
    ds = fast["task"]
    assert ds.attrs["source_sha256"] == _sha(path)
    reference = TdmsFile.read(path)["task"]
    for name in ("f64", "f32", "i16", "u32"):
        np.testing.assert_array_equal(ds[name].values, reference[name][:])
        assert ds[name].dtype == reference[name][:].dtype
    assert [str(w.message) for w in fw] == [str(w.message) for w in sw]


def test_selection_and_time_range_read_only_what_is_asked(
        write_tdms, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = write_tdms(tmp_path / "sel.tdms",
                      [_channels(k, 500, PROPS if k == 0 else None) for k in range(4)])
    fast, slow, *_, used = _read_both(path, monkeypatch, channels=["i16", "f64"],
                                      time_range=(0.7317, 1.2))
    assert used
    _assert_same(fast, slow)
    ds = fast["task"]
    assert {"i16", "f64"} <= set(ds.data_vars) and "f32" not in ds and "u32" not in ds
    full = TdmsFile.read(path)["task"]["i16"][:]
    first = ds.attrs["first_sample"]
    np.testing.assert_array_equal(ds["i16"].values, full[first:first + ds.sizes["time"]])
    assert ds.attrs["source_sha256"] == _sha(path)  # every byte hashed, not just those kept
    no_hash = read_stream(path, channels=["i16"], checksum=False)
    assert no_hash.attrs["source_sha256"] == "not computed"
    np.testing.assert_array_equal(no_hash["i16"].values, full)


def test_channels_joining_and_leaving_and_two_groups(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(3)
    with TdmsWriter(tmp_path / "groups.tdms") as writer:
        writer.write_segment([RootObject({}), GroupObject("a"), GroupObject("b"),
                              ChannelObject("a", "x", rng.normal(size=300), PROPS),
                              ChannelObject("b", "y", rng.normal(size=100),
                                            {**PROPS, "wf_increment": 3e-3})])
        writer.write_segment([ChannelObject("a", "x", rng.normal(size=300))])
        writer.write_segment([ChannelObject("b", "y", rng.normal(size=100)),
                              ChannelObject("a", "x", rng.normal(size=300))])
        writer.write_segment([ChannelObject("a", "s", ["text", "values"], {})])
        writer.write_segment([ChannelObject("b", "y", rng.normal(size=100))])
    path = tmp_path / "groups.tdms"
    fast, slow, *_, used = _read_both(path, monkeypatch)
    assert used  # a string channel nobody reads does not stop the direct path
    _assert_same(fast, slow)
    assert fast["a"].sizes["time"] == 900 and fast["b"].sizes["time"] == 300
    assert fast["a"].attrs["source_sha256"] == _sha(path) == fast["b"].attrs["source_sha256"]


def _with_chunks(segment: bytes, chunks: list[bytes]) -> bytes:
    """Append raw-data chunks to a one-segment TDMS byte string and fix its lead-in."""
    (raw_offset,) = struct.unpack_from("<Q", segment, 20)
    head = bytearray(segment[:28 + raw_offset])
    struct.pack_into("<Q", head, 12, raw_offset + sum(len(c) for c in chunks))
    return bytes(head) + b"".join(chunks)


def test_segments_of_several_chunks_and_a_cut_last_chunk(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(4)
    n = 64
    chunks = []
    for _ in range(5):
        a, b = rng.normal(size=n), rng.integers(-9, 9, n).astype(np.int16)
        chunks.append(a.tobytes() + b.tobytes())
    buffer = io.BytesIO()
    with TdmsWriter(buffer) as writer:
        writer.write_segment([RootObject({}), GroupObject("task"),
                              ChannelObject("task", "a", np.zeros(n), PROPS),
                              ChannelObject("task", "b", np.zeros(n, np.int16), PROPS)])
    whole = _with_chunks(buffer.getvalue(), chunks)
    path = tmp_path / "chunks.tdms"
    path.write_bytes(whole)
    fast, slow, *_, used = _read_both(path, monkeypatch)
    assert used
    _assert_same(fast, slow)
    expected_a = np.concatenate([np.frombuffer(c[:8 * n]) for c in chunks])
    np.testing.assert_array_equal(fast["task"]["a"].values, expected_a)
    assert fast["task"].attrs["source_sha256"] == _sha(path)
    # cut inside the last chunk: 'a' complete there, 'b' half; 'b' decides the stream length
    cut = tmp_path / "cut.tdms"
    cut.write_bytes(whole[:len(whole) - n])
    fast, slow, fw, sw, used = _read_both(cut, monkeypatch)
    assert used
    _assert_same(fast, slow)
    assert fast["task"].sizes["time"] == 4 * n + n // 2
    assert fast["task"].attrs["source_sha256"] == _sha(cut)
    assert any("recovered" in str(w.message) for w in fw)
    assert sorted(str(w.message) for w in fw) == sorted(str(w.message) for w in sw)


def test_damaged_tail_is_hashed_but_not_read(write_tdms, tmp_path: Path,
                                             monkeypatch: pytest.MonkeyPatch) -> None:
    path = write_tdms(tmp_path / "tail.tdms",
                      [_channels(k, 700, PROPS if k == 0 else None) for k in range(3)])
    path.write_bytes(path.read_bytes() + b"TDSx" + bytes(range(200)))
    fast, slow, fw, _, used = _read_both(path, monkeypatch)
    assert used
    _assert_same(fast, slow)
    assert fast["task"].sizes["time"] == 2100
    assert fast["task"].attrs["source_sha256"] == _sha(path)
    assert any("damaged" in str(w.message) for w in fw)


def test_scaled_channels_and_real_daqmx_and_big_endian_files_go_to_nptdms(
        write_tdms, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, realdata_dir: Path) -> None:
    props = {**PROPS, "NI_Number_Of_Scales": 1, "NI_Scale[0]_Scale_Type": "Linear",
             "NI_Scale[0]_Linear_Slope": 2.0, "NI_Scale[0]_Linear_Y_Intercept": 1.0}
    raw = np.arange(100, dtype=np.int16)
    path = write_tdms(tmp_path / "scaled.tdms", [[ChannelObject("task", "v", raw, props)]])
    fast, _, _, _, used = _read_both(path, monkeypatch)
    assert not used
    np.testing.assert_array_equal(fast["task"]["v"].values, 2.0 * raw + 1.0)
    for name in ("npTDMS/raw1.tdms", "npTDMS/big_endian.tdms", "nidaqmx-python/data_ai.tdms"):
        fast, _, _, _, used = _read_both(realdata_dir / name, monkeypatch)
        assert not used, name
        assert next(iter(fast.values())).attrs["source_sha256"] == _sha(realdata_dir / name)


@pytest.mark.parametrize("name", ["npTDMS/Digital_Input.tdms", "npTDMS/raw_timestamps.tdms"])
def test_real_plain_files_read_directly_equal_nptdms(
        name: str, monkeypatch: pytest.MonkeyPatch, realdata_dir: Path) -> None:
    path = realdata_dir / name
    fast, slow, fw, sw, used = _read_both(path, monkeypatch, include_decimated=True)
    assert used
    _assert_same(fast, slow)
    assert next(iter(fast.values())).attrs["source_sha256"] == _sha(path)
    assert [str(w.message) for w in fw] == [str(w.message) for w in sw]


def test_file_cut_after_the_scan_is_a_data_file_error(write_tdms, tmp_path: Path) -> None:
    path = write_tdms(tmp_path / "shrinks.tdms",
                      [_channels(k, 400, PROPS if k == 0 else None) for k in range(3)])
    layout = scan_tdms(path)
    ranges = {p: (0, c.length) for p, c in layout.channels.items()}
    plain = direct.plain_selection(layout, ranges)
    assert plain is not None
    path.write_bytes(path.read_bytes()[:layout.file_size // 2])
    for checksum in (True, False):
        with pytest.raises(DataFileError, match=r"ends at byte \d+, before data"):
            direct.read_plain(path, layout, plain, checksum)


def test_the_digest_is_remembered_and_renewed_when_the_file_changes(
        write_tdms, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = write_tdms(tmp_path / "cache.tdms", [_channels(0, 300, PROPS)])
    first = read_stream(path).attrs["source_sha256"]
    made = []
    monkeypatch.setattr(direct, "ThreadedSha256",
                        lambda size: made.append(size) or ThreadedSha256(size))
    assert read_stream(path).attrs["source_sha256"] == first == _sha(path)
    assert made == []  # known: not hashed again
    write_tdms(path, [_channels(1, 301, PROPS)])
    assert read_stream(path).attrs["source_sha256"] == _sha(path) != first
    assert len(made) == 1


@pytest.mark.parametrize("sizes", [[1, 2, 3], [BY_REFERENCE_BYTES, 5, BY_REFERENCE_BYTES * 3],
                                   [STAGING_BYTES - 1, 2, STAGING_BYTES + 7, 100] * 3])
def test_threaded_sha256_equals_hashlib_in_any_mix_of_pieces(sizes: list[int]) -> None:
    rng = np.random.default_rng(len(sizes))
    data = rng.integers(0, 256, sum(sizes) * 2, dtype=np.uint8).tobytes()
    expected = hashlib.sha256(data).hexdigest()
    source = io.BytesIO(data)
    with ThreadedSha256(len(data)) as hasher:
        for size in sizes:  # alternately handed over and read through the staging buffers
            hasher.feed(memoryview(source.read(size)))
            assert hasher.read_from(source, size) == size
        assert hasher.read_from(source, None) == 0
        assert hasher.hexdigest() == expected
        assert hasher.fed == len(data)


def test_memory_of_a_direct_read_stays_near_the_channel_data(write_tdms, tmp_path: Path) -> None:
    path = write_tdms(tmp_path / "big.tdms",
                      [[ChannelObject("task", f"c{c}", np.full(1 << 17, float(k + c)),
                                      PROPS if k == 0 else {}) for c in range(4)]
                       for k in range(16)])  # 64 MiB of float64 in 16 segments
    data_bytes = 16 * 4 * (1 << 17) * 8
    tracemalloc.start()
    try:
        ds = read_stream(path)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert ds.attrs["source_sha256"] == _sha(path)
    np.testing.assert_array_equal(ds["c3"].values[-3:], 18.0)
    # the arrays themselves, the staging buffers (<= 16 MiB) and xarray's small objects
    assert peak <= 1.15 * data_bytes + (17 << 20), peak / data_bytes


def test_cut_anywhere_both_routes_agree_and_the_digest_is_the_files(
        write_tdms, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    source = write_tdms(tmp_path / "whole.tdms",
                        [_channels(k, 50 + 13 * k, PROPS if k == 0 else None) for k in range(4)])
    whole = source.read_bytes()
    rng = np.random.default_rng(7)
    first_data = scan_tdms(source).data_segments[0].data_start  # before it: not a TDMS file
    cuts = sorted({int(c) for c in rng.integers(first_data + 1, len(whole), 25)}
                  | {first_data + 1, len(whole) - 1})
    path = tmp_path / "cut.tdms"
    for cut in cuts:
        path.write_bytes(whole[:cut])
        fast, slow, fw, sw, used = _read_both(path, monkeypatch)
        assert used, cut
        _assert_same(fast, slow)
        assert fast["task"].attrs["source_sha256"] == _sha(path), cut
        assert sorted(map(str, (w.message for w in fw))) == \
            sorted(map(str, (w.message for w in sw))), cut


def test_huge_and_plain_pages_read_identical_arrays(write_tdms, tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(7)
    n = 1 << 19  # 4 MiB of float64 per channel per segment: mapped arrays
    segments = [[ChannelObject("task", "a", rng.normal(size=n), PROPS),
                 ChannelObject("task", "b", rng.integers(-9, 9, n).astype(np.int32), PROPS)]
                for _ in range(3)]
    path = write_tdms(tmp_path / "big.tdms", segments)
    results = []
    for huge in (True, False):
        monkeypatch.setattr(direct, "use_huge_pages", lambda nbytes, huge=huge: huge)
        results.append(read_stream(path))
    on, off = results
    assert on.attrs["source_sha256"] == off.attrs["source_sha256"] == _sha(path)
    for name in ("a", "b"):
        expected = np.concatenate([s[0 if name == "a" else 1].data for s in segments])
        np.testing.assert_array_equal(on[name].values, expected)
        np.testing.assert_array_equal(off[name].values, expected)
