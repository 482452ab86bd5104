"""A TDMS file's layout walked once within kept_layouts, again when the file changes."""

from __future__ import annotations

import os

import numpy as np
import pytest
from nptdms import ChannelObject, GroupObject, RootObject, TdmsFile, TdmsWriter

from rigval.acquisition import tdms_layout
from rigval.acquisition.reader import read_stream
from rigval.acquisition.tdms_layout import kept_layouts, scan_tdms


def _write(path, segments: int) -> None:
    with TdmsWriter(path) as writer:
        for k in range(segments):
            writer.write_segment([RootObject(), GroupObject("g"),
                                  ChannelObject("g", "x", np.arange(10.0) + k)])


def test_layout_scanned_once_within_and_again_after_a_change(tmp_path,
                                                             monkeypatch: pytest.MonkeyPatch
                                                             ) -> None:
    path = tmp_path / "a.tdms"
    _write(path, 3)
    walks = []
    original = tdms_layout._scan
    monkeypatch.setattr(tdms_layout, "_scan", lambda *a: walks.append(a[0]) or original(*a))
    outside = [scan_tdms(path), scan_tdms(path)]
    assert len(walks) == 2 and outside[0] is not outside[1]  # nothing kept outside
    with kept_layouts():
        first = scan_tdms(path)
        assert scan_tdms(path) is first and len(walks) == 3
        _write(path, 5)  # rewritten: another size
        os.utime(path, ns=(1, 1))
        changed = scan_tdms(path)
        assert changed is not first and len(walks) == 4
        assert list(changed.channels["/'g'/'x'"].counts) == [10] * 5
    assert list(first.channels["/'g'/'x'"].counts) == [10] * 3
    scan_tdms(path)
    assert len(walks) == 5  # the kept layouts went with the block


def test_segments_that_repeat_their_metadata_share_one_index(tmp_path) -> None:
    """nptdms writes every segment's raw-data index again: the layout holds one per change."""
    path = tmp_path / "repeat.tdms"
    with TdmsWriter(path) as writer:
        for k in range(40):
            n = 10 if k < 30 else 7  # the index changes at segment 30
            writer.write_segment([RootObject(), GroupObject("g"),
                                  ChannelObject("g", "x", np.arange(n) + k),
                                  ChannelObject("g", "y", np.arange(n) * 2.0)])
    layout = scan_tdms(path)
    assert layout.segments == 40
    assert list(layout.channels["/'g'/'x'"].counts) == [10] * 30 + [7] * 10
    objects = [segment.objects for segment in layout.data_segments]
    assert len({id(o) for o in objects}) == 2  # one object list before the change, one after
    assert objects[0] == objects[29] != objects[30] == objects[39]
    (_, before), (_, after) = objects[0][0], objects[30][0]
    assert (before.n_values, after.n_values) == (10, 7)
    stream = read_stream(path, fs=100.0)  # rigval's reader, where the layout says they lie
    nptdms_file = TdmsFile.read(path)
    for name in ("x", "y"):
        assert np.array_equal(stream[name].to_numpy(), nptdms_file["g"][name][:])
