"""The operator's note of a scene: a regular UTF-8 text file of bounded size.

The scene's ``note`` key names any file the user likes, and the report copies its text. To keep
that from copying something that is not a note (``/proc/self/environ``, a device, a FIFO that
would block, a binary or a huge file), :func:`read_note` accepts only

* a regular file (after following symlinks) whose size as stored equals what is read (kernel
  pseudo-files report 0 bytes),
* of at most :data:`MAX_NOTE_BYTES` (64 KiB: several pages of text, far below what a report
  page should carry),
* that decodes as UTF-8 and holds no control characters other than tab, line feed, carriage
  return and form feed.

Anything else is a :class:`~rigval.validation.errors.SceneError` with key ``note`` and the file.
"""

from __future__ import annotations

import logging
import os
import re
import stat
from pathlib import Path

from rigval.validation.errors import SceneError

__all__ = ["MAX_NOTE_BYTES", "read_note"]

logger = logging.getLogger(__name__)

#: Largest note accepted, bytes (64 KiB).
MAX_NOTE_BYTES = 64 * 1024

_CONTROL = re.compile(r"[\x00-\x08\x0b\x0e-\x1f\x7f]")


def _refuse(path: Path, message: str) -> SceneError:
    return SceneError(f"note: {path}: {message}", where={"key": "note", "file": path},
                      hint="name a plain UTF-8 text file of at most 64 KiB written for this run "
                           "(or remove the key)")


def read_note(path: str | Path) -> str:
    """Return the text of a scene's note file after checking that it is a note.

    Parameters
    ----------
    path : str or pathlib.Path
        The note file.

    Returns
    -------
    str
        Its text.

    Raises
    ------
    SceneError
        Not a regular file, larger than 64 KiB, not UTF-8, or holding control characters.
    """
    path = Path(path)
    try:
        info = os.stat(path)
    except OSError as error:
        raise _refuse(path, f"cannot be read ({error.strerror})") from None
    if not stat.S_ISREG(info.st_mode):
        raise _refuse(path, "not a regular file")
    if info.st_size > MAX_NOTE_BYTES:
        raise _refuse(path, f"{info.st_size} bytes, more than the 64 KiB a note may have")
    try:
        with open(path, "rb") as handle:
            data = handle.read(MAX_NOTE_BYTES + 1)
    except OSError as error:
        raise _refuse(path, f"cannot be read ({error.strerror})") from None
    if len(data) != info.st_size:
        raise _refuse(path, f"not a regular file: it reports {info.st_size} bytes but "
                            f"{len(data)}{'+' if len(data) > MAX_NOTE_BYTES else ''} were read "
                            "(a system pseudo-file?)")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as error:
        raise _refuse(path, f"not UTF-8 text (byte {error.start})") from None
    bad = _CONTROL.search(text)
    if bad is not None:
        raise _refuse(path, f"not text: control character {bad.group()!r} at character "
                            f"{bad.start()}")
    return text
