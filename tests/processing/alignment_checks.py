"""Shared checks of the alignment tests: two stream records equal field by field."""

from __future__ import annotations

import dataclasses

import numpy as np

from rigval.processing.alignment_summary import StreamAlignment


def assert_same_alignment(a: StreamAlignment, b: StreamAlignment) -> None:
    """Assert that every field of two stream records is equal (arrays: dtype and values)."""
    for field in dataclasses.fields(StreamAlignment):
        x, y = getattr(a, field.name), getattr(b, field.name)
        if isinstance(x, np.ndarray):
            assert x.dtype == y.dtype and np.array_equal(x, y), field.name
        else:
            assert x == y, field.name
