"""A TDMS file's layout walked once within kept_layouts, again when the file changes."""

from __future__ import annotations

import os

import numpy as np
import pytest
from nptdms import ChannelObject, GroupObject, RootObject, TdmsWriter

from rigval.acquisition import tdms_layout
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
        assert changed.channels["/'g'/'x'"].counts == [10] * 5
    assert first.channels["/'g'/'x'"].counts == [10] * 3
    scan_tdms(path)
    assert len(walks) == 5  # the kept layouts went with the block
