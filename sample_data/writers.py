"""File writers of the virtual rig other than TDMS: the European LabVIEW CSV and the truth files.

Every writer is deterministic (no wall-clock time stamps, fixed zip entry dates, sorted JSON
keys), so a run regenerated from the same seed is byte-identical, and writes through a temporary
name (:mod:`rigval.acquisition.outputs`), so a killed run never leaves a truncated file.
"""

from __future__ import annotations

import contextlib
import io
import json
import logging
import zipfile
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigval.acquisition.outputs import atomic_output, write_text_atomic

__all__ = ["NpyAppender", "european_csv_head", "european_csv_rows", "write_european_csv",
           "write_json", "write_npz", "write_npz_from_files"]

logger = logging.getLogger(__name__)

#: Fixed date of every zip entry (the earliest a zip file can hold).
_ZIP_DATE = (1980, 1, 1, 0, 0, 0)


def write_european_csv(path: str | Path, header: Sequence[tuple[str, str]],
                       time: NDArray[np.float64],
                       columns: Sequence[tuple[str, str, NDArray[np.float64], str]]) -> Path:
    """Write a CSV as a LabVIEW application on a European PC writes it.

    ``;`` separates fields, ``,`` is the decimal mark, lines end in CRLF. A few ``key;value``
    lines (device, start time) come first, then one row names each column with its unit in
    brackets (``tor3 [V/V]``). The first column is the time in s on the device's clock
    (``Time [s]``).

    Parameters
    ----------
    path : str or Path
        Output file (overwritten).
    header : sequence of (str, str)
        ``key;value`` lines written first, as given (no decimal conversion).
    time : numpy.ndarray
        Time column in s.
    columns : sequence of (name, unit, values, format)
        Data columns: name, unit, values (same length as ``time``) and a printf format such as
        ``"%.6E"``.

    Returns
    -------
    Path
        The file written.
    """
    path = Path(path)
    text = european_csv_head(header, [(name, unit) for name, unit, _, _ in columns])
    text += european_csv_rows(time, [(values, fmt) for _, _, values, fmt in columns])
    with atomic_output(path) as partial:
        partial.write_bytes(text.encode("utf-8"))
    return path


def european_csv_head(header: Sequence[tuple[str, str]], names: Sequence[tuple[str, str]]) -> str:
    """Return the ``key;value`` lines and the column-name row of :func:`write_european_csv`.

    ``names`` are the data columns' (name, unit); the time column comes first.
    """
    row = ";".join(["Time [s]"] + [f"{name} [{unit}]" for name, unit in names])
    return "".join(f"{key};{value}\r\n" for key, value in header) + row + "\r\n"


def european_csv_rows(time: NDArray[np.float64],
                      columns: Sequence[tuple[NDArray[np.float64], str]]) -> str:
    """Return data rows of :func:`write_european_csv`: time, then each (values, format) column.

    Rows written piece by piece after :func:`european_csv_head` give the same text as all at
    once.
    """
    table = np.column_stack([time] + [values for values, _ in columns])
    buffer = io.StringIO()
    np.savetxt(buffer, table, fmt=["%.6f"] + [fmt for _, fmt in columns], delimiter=";",
               newline="\r\n")
    return buffer.getvalue().replace(".", ",")


@contextlib.contextmanager
def _npz_archive(path: Path) -> Iterator[zipfile.ZipFile]:
    """Yield ``path`` opened as a zip (deflate level 6), published whole when the block ends."""
    with atomic_output(path) as partial, zipfile.ZipFile(
            partial, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=6) as archive:
        yield archive


def _npy_entry(name: str) -> zipfile.ZipInfo:
    """Return the zip entry of array ``name``: fixed date, deflated, mode 0644."""
    info = zipfile.ZipInfo(f"{name}.npy", date_time=_ZIP_DATE)
    info.compress_type = zipfile.ZIP_DEFLATED
    info.external_attr = 0o644 << 16
    return info


def write_npz(path: str | Path, arrays: Mapping[str, NDArray]) -> Path:
    """Write arrays to a compressed ``.npz`` (readable with :func:`numpy.load`) with fixed dates.

    Parameters
    ----------
    path : str or Path
        Output file (overwritten).
    arrays : mapping of str to numpy.ndarray
        Arrays by name, written in sorted name order.

    Returns
    -------
    Path
        The file written.
    """
    with _npz_archive(Path(path)) as archive:
        for name in sorted(arrays):
            buffer = io.BytesIO()
            np.lib.format.write_array(buffer, np.ascontiguousarray(arrays[name]),
                                      allow_pickle=False)
            archive.writestr(_npy_entry(name), buffer.getvalue())
    return Path(path)


class NpyAppender:
    """A 1-D ``.npy`` file of known length, written front to back piece by piece.

    Equal byte for byte to filling :func:`numpy.lib.format.open_memmap` in order, but the
    written pages are never mapped into this process: a memory map's dirty pages count in its
    resident memory until it is closed, so a long record's truth grew it by the file's size.

    Parameters
    ----------
    path : Path
        The file (overwritten).
    length : int
        Values the file will hold.
    dtype : numpy.dtype
        Their type (little-endian as written).
    """

    def __init__(self, path: Path, length: int, dtype: np.dtype[Any]) -> None:
        self.length, self.dtype, self.filled = length, np.dtype(dtype).newbyteorder("<"), 0
        self._file = path.open("wb")
        np.lib.format.write_array_header_1_0(self._file, {
            "descr": np.lib.format.dtype_to_descr(self.dtype), "fortran_order": False,
            "shape": (length,)})

    def append(self, values: NDArray[Any]) -> None:
        """Write the next ``values`` (converted to the file's type).

        Raises
        ------
        ValueError
            If they would run past the declared length.
        """
        if self.filled + values.size > self.length:
            raise ValueError(f"{self._file.name}: {self.filled + values.size} values written "
                             f"into a file declared for {self.length}")
        np.ascontiguousarray(values, dtype=self.dtype).tofile(self._file)
        self.filled += values.size

    def close(self) -> None:
        """Close the file; values never written are zeros (as in a fresh memory map)."""
        if self.filled < self.length:
            logger.debug("%s: %d of %d values written, the rest zeros", self._file.name,
                         self.filled, self.length)
            np.zeros(self.length - self.filled, dtype=self.dtype).tofile(self._file)
        self._file.close()


def write_npz_from_files(path: str | Path, files: Mapping[str, Path],
                         chunk_bytes: int = 1 << 24) -> Path:
    """Write ``.npy`` files into a compressed ``.npz`` as :func:`write_npz` does, in bounded memory.

    Parameters
    ----------
    path : str or Path
        Output file (overwritten).
    files : mapping of str to Path
        ``.npy`` files by array name, written in sorted name order and copied in pieces of
        ``chunk_bytes``.
    chunk_bytes : int, default 16 MiB
        Bytes read at a time.

    Returns
    -------
    Path
        The file written.
    """
    path = Path(path)
    with _npz_archive(path) as archive:
        for name in sorted(files):
            info = _npy_entry(name)
            info.file_size = files[name].stat().st_size
            with files[name].open("rb") as source, archive.open(info, "w") as target:
                while piece := source.read(chunk_bytes):
                    target.write(piece)
    return path


def write_json(path: str | Path, content: Mapping[str, Any]) -> Path:
    """Write JSON with sorted keys and two-space indentation (deterministic bytes)."""
    return write_text_atomic(path, json.dumps(content, indent=2, sort_keys=True) + "\n")
