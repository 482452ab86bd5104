"""The per-segment table from run starts and first/last samples, against whole-record masks."""

from __future__ import annotations

import numpy as np
import xarray as xr

from rigval.processing.alignment_summary import segment_table
from rigval.processing.clock_fit import ClockModel


def test_segment_table_equals_whole_record_selection() -> None:
    segment = np.repeat(np.array([0, 1, 2, 1, 3], np.int32), [300, 200, 150, 100, 250])
    time = np.arange(segment.size) / 100.0 + 5.0 * segment
    stream = xr.Dataset({"segment": ("time", segment)}, coords={"time": ("time", time)})
    clock = ClockModel((0, 1, 3), (0.25, 0.5, 0.75), 0.0, 0.0, 3, 3)
    rows = segment_table(stream, clock, None, np.zeros(0))
    assert [r["segment"] for r in rows] == np.unique(segment).tolist()
    for row in rows:
        mine = segment == row["segment"]
        assert row["device_time_s"] == [float(time[mine][0]), float(time[mine][-1])]
        assert row["samples"] == int(mine.sum())
        assert row["samples_dropped"] == (0 if row["segment"] in (0, 1, 3) else int(mine.sum()))
