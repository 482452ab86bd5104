"""The installed rigval version, looked up in one place.

The command line (``rigval --version``, the traceback file), the run report, the prediction
report and the campaign manifests all record it, through :func:`rigval_version`.
"""

from __future__ import annotations

from functools import cache
from importlib.metadata import PackageNotFoundError, version

__all__ = ["rigval_version"]


@cache
def rigval_version() -> str:
    """Return the installed rigval version.

    Returns
    -------
    str
        The version of the installed distribution, or ``"unknown"`` when rigval runs from a
        source tree that was never installed (no distribution metadata to read).
    """
    try:
        return version("rigval")
    except PackageNotFoundError:
        return "unknown"
