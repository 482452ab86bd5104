"""The truth's sequential ``.npy`` writer equals a memory map filled in order, byte for byte."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from rigval.sample_data.writers import NpyAppender


@pytest.mark.parametrize("dtype", [np.float32, np.float64, np.dtype(">f4")])
def test_pieces_appended_equal_a_filled_memory_map(tmp_path: Path, dtype: np.dtype) -> None:
    values = np.random.default_rng(3).normal(size=1000)
    pieces = np.split(values, [1, 250, 251, 999])
    mapped = np.lib.format.open_memmap(tmp_path / "map.npy", mode="w+",
                                       dtype=np.dtype(dtype).newbyteorder("<"),
                                       shape=(values.size,))
    mapped[:] = values
    mapped.flush()
    del mapped
    appender = NpyAppender(tmp_path / "appended.npy", values.size, np.dtype(dtype))
    for piece in pieces:
        appender.append(piece)
    appender.close()
    assert (tmp_path / "appended.npy").read_bytes() == (tmp_path / "map.npy").read_bytes()
    np.testing.assert_array_equal(np.load(tmp_path / "appended.npy"),
                                  values.astype(np.float32 if dtype != np.float64 else dtype))


def test_values_never_written_are_zeros_as_in_a_fresh_map(tmp_path: Path) -> None:
    appender = NpyAppender(tmp_path / "short.npy", 5, np.dtype(np.float32))
    appender.append(np.array([1.0, 2.0]))
    appender.close()
    np.testing.assert_array_equal(np.load(tmp_path / "short.npy"), [1.0, 2.0, 0.0, 0.0, 0.0])


def test_writing_past_the_declared_length_is_refused(tmp_path: Path) -> None:
    appender = NpyAppender(tmp_path / "full.npy", 2, np.dtype(np.float32))
    appender.append(np.array([1.0, 2.0]))
    with pytest.raises(ValueError, match="3 values written into a file declared for 2"):
        appender.append(np.array([3.0]))
    appender.close()
