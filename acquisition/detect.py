"""Recognise a data file's format from its first bytes, and the file checks every reader shares.

Formats: ``"tdms"`` (starts with the segment tag ``TDSm``), ``"lvm"`` (``LabVIEW Measurement`` or
a header-less LVM starting with ``X_Value``), ``"csv"`` (other text). A Git-LFS pointer, a
``.tdms_index`` file, an empty file or binary data of another kind is refused with a
:class:`~rigval.acquisition.errors.DataFileError` that says what the file is.
"""

from __future__ import annotations

import logging
import os
import threading
from pathlib import Path

from rigval.acquisition.errors import DataFileError

__all__ = ["FORMATS", "NOT_COMPUTED", "checked_path", "detect_format", "source_checksum"]

logger = logging.getLogger(__name__)

FORMATS = ("tdms", "csv", "lvm")
#: ``source_sha256`` of streams read with ``checksum=False``.
NOT_COMPUTED = "not computed"
_SNIFF_BYTES = 4096


def checked_path(path: str | os.PathLike[str]) -> Path:
    """Return ``path`` as a Path after checking that it is a readable, non-empty regular file.

    Raises
    ------
    DataFileError
        If the file is missing, a directory, empty or a Git-LFS pointer.
    """
    path = Path(path)
    if not path.exists():
        raise DataFileError("file not found", where={"file": str(path)},
                            hint="check the path (a path in a scene is relative to its folder)")
    if not path.is_file():
        raise DataFileError("not a regular file", where={"file": str(path)})
    if path.stat().st_size == 0:
        raise DataFileError("file is empty", where={"file": str(path)},
                            hint="the acquisition may have failed before writing any data")
    with open(path, "rb") as handle:
        head = handle.read(200)
    if head.startswith(b"version https://git-lfs"):
        raise DataFileError("file is a Git-LFS pointer, not the data it stands for",
                            where={"file": str(path)},
                            hint="run 'git lfs pull' in the repository that holds it")
    return path


def detect_format(path: str | os.PathLike[str]) -> str:
    """Return ``"tdms"``, ``"lvm"`` or ``"csv"`` from the file's content (not its name).

    Raises
    ------
    DataFileError
        For LFS pointers, ``.tdms_index`` files, empty files and binary files of other kinds.
    """
    path = checked_path(path)
    with open(path, "rb") as handle:
        head = handle.read(_SNIFF_BYTES)
    if head.startswith(b"TDSm"):
        return "tdms"
    if head.startswith(b"TDSh"):
        raise DataFileError("this is a TDMS index file (metadata only)", where={"file": str(path)},
                            hint="read the .tdms file next to it")
    if head[:2] in (b"\xff\xfe", b"\xfe\xff"):  # UTF-16 text with its byte-order mark
        head = head[:len(head) // 2 * 2].decode("utf-16", errors="replace").encode()
    text = head.lstrip(b"\xef\xbb\xbf")
    if b"\x00" in text:
        raise DataFileError(
            f"not a TDMS, LVM or CSV file: binary content starting with {head[:8]!r}",
            where={"file": str(path)}, hint="rigval reads NI TDMS, LVM and delimited text files")
    first = text.split(b"\n", 1)[0].strip()
    if first.startswith(b"LabVIEW Measurement") or first.startswith(b"X_Value"):
        return "lvm"
    return "csv"


#: Digests kept per process: (resolved path, size, modification time in ns) -> SHA-256.
_DIGESTS: dict[tuple[str, int, int], str] = {}
_DIGESTS_KEPT = 64
_DIGESTS_LOCK = threading.Lock()  # readers may run in several threads (campaign workers)


def checksum_key(path: Path) -> tuple[str, int, int]:
    """Return what identifies a file's content for the digest cache: (path, size, mtime)."""
    stat = path.stat()
    return str(path.resolve()), stat.st_size, stat.st_mtime_ns


def cached_checksum(key: tuple[str, int, int]) -> str | None:
    """Return the SHA-256 known for :func:`checksum_key` ``key``, or None."""
    return _DIGESTS.get(key)


def remember_checksum(key: tuple[str, int, int], digest: str) -> None:
    """Keep a digest computed elsewhere (a reader hashing while it reads) for ``key``."""
    with _DIGESTS_LOCK:
        _DIGESTS.pop(key, None)
        _DIGESTS[key] = digest
        while len(_DIGESTS) > _DIGESTS_KEPT:
            del _DIGESTS[next(iter(_DIGESTS))]


def source_checksum(path: Path, enabled: bool = True) -> str:
    """Return the file's SHA-256 (cached while the file is unchanged), or :data:`NOT_COMPUTED`.

    Parameters
    ----------
    path : pathlib.Path
        The data file.
    enabled : bool
        False skips hashing (its cost per GiB: docs/performance.md) and returns
        :data:`NOT_COMPUTED`.
    """
    if not enabled:
        return NOT_COMPUTED
    key = checksum_key(path)
    digest = cached_checksum(key)
    if digest is None:
        from rigval.acquisition.schema import file_sha256  # numpy, pandas, xarray: when hashing

        digest = file_sha256(path)
        remember_checksum(key, digest)
    return digest
