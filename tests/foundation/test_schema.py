"""The stream builder derives gaps, counts invalid samples and refuses inconsistent input."""

from __future__ import annotations

import numpy as np
import pytest

from rigval.acquisition.errors import DataError
from rigval.acquisition.schema import (
    Channel,
    check_stream,
    invalid_counts,
    parse_start_time,
    stream_dataset,
    stream_gaps,
)


def _stream(time: np.ndarray, **kwargs: object) -> object:
    channel = Channel(np.zeros(time.size), "V", "test signal", "/'g'/'c'")
    defaults = {"device": "cDAQ-9172", "start_time": "2026-01-02T03:04:05.123456789Z",
                "source_file": "run.tdms", "source_sha256": "0" * 64, "fs_nominal": 100.0}
    return stream_dataset(time, {"c": channel}, **{**defaults, **kwargs})


def test_gap_is_found_and_its_missing_samples_counted() -> None:
    time = np.r_[np.arange(50), np.arange(80, 100)] / 100.0
    ds = _stream(time)
    check_stream(ds)
    assert ds.attrs["gap_count"] == 1
    assert ds.attrs["missing_samples"] == 30
    assert np.array_equal(np.unique(ds["segment"]), [0, 1])
    assert int((ds["segment"] == 1).sum()) == 20
    assert float(ds.attrs["gap_start_s"][0]) == pytest.approx(0.49)
    assert float(ds.attrs["gap_end_s"][0]) == pytest.approx(0.80)
    assert int(ds.attrs["gap_missing_samples"][0]) == 30
    gap = stream_gaps(ds)[0]
    assert gap["after_s"] == pytest.approx(0.49)
    assert gap["duration_s"] == pytest.approx(0.80 - 0.49 - 0.01)


def test_start_time_keeps_nanoseconds() -> None:
    ds = _stream(np.arange(3) / 100.0)
    expected = np.datetime64("2026-01-02T03:04:05.123456789")
    assert parse_start_time(ds.attrs["start_time"]) == expected
    assert parse_start_time("2026-01-02T05:04:05+02:00") == np.datetime64("2026-01-02T03:04:05")


def test_non_monotonic_time_is_refused() -> None:
    with pytest.raises(DataError, match="not strictly increasing"):
        _stream(np.array([0.0, 0.01, 0.01, 0.02]))


def test_invalid_counts_must_add_up() -> None:
    valid = np.array([True, False, True])
    ds = _stream(np.arange(3) / 100.0, valid=valid, invalid_counts={"overrange": 1})
    assert invalid_counts(ds) == {"overrange": 1}
    assert list(ds.attrs["invalid_reason"]) == ["overrange"]
    assert list(ds.attrs["invalid_count"]) == [1]
    with pytest.raises(DataError, match="valid mask"):
        _stream(np.arange(3) / 100.0, valid=valid)
