"""Errors of the processing layer, rooted at :class:`~rigval.acquisition.errors.RigvalError`.

See docs/errors.md for every rigval error and what carries the location and the fix.
"""

from __future__ import annotations

from rigval.acquisition.errors import RigvalError

__all__ = ["AlignmentError"]


class AlignmentError(RigvalError, ValueError):
    """Clocks cannot be aligned with confidence (too few events, no overlap, bad periods)."""
