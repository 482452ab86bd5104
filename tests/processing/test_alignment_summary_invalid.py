"""alignment.json records each stream's invalid samples by reason (nothing lost silently)."""

from __future__ import annotations

import numpy as np

from rigval.acquisition.schema import Channel, stream_dataset
from rigval.processing import clock_fit
from rigval.processing.alignment_summary import stream_summary


def test_summary_counts_invalid_samples_by_reason() -> None:
    time = np.arange(200) / 100.0
    valid = np.ones(200, dtype=bool)
    valid[[3, 4, 5]] = False
    stream = stream_dataset(time, {"x": Channel(np.zeros(200), "V", "x", "x", "none", {})},
                            device="dev", start_time="2026-11-21T06:00:00Z",
                            source_file="x.csv", source_sha256="0" * 64, fs_nominal=100.0,
                            valid=valid, invalid_counts={"empty cells": 3})
    aligned = clock_fit.align_stream(stream, clock_fit.identity_clock())
    summary = stream_summary("dev", aligned, clock_fit.identity_clock(), is_reference=True,
                             residual_time=np.zeros(0), residual=np.zeros(0), matched=0,
                             missing=0, spurious=0).summary()
    assert summary["invalid_samples"] == {"empty cells": int((~valid).sum())}
