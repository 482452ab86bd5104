"""Errors of the processing layer, rooted at :class:`~rigval.acquisition.errors.RigvalError`.

See docs/errors.md for every rigval error and what carries the location and the fix.
"""

from __future__ import annotations

from rigval.acquisition.errors import ConfigError, RigvalError

__all__ = ["AlignmentError", "DriveRateError"]


class AlignmentError(RigvalError, ValueError):
    """Clocks cannot be aligned with confidence (too few events, no overlap, bad periods)."""


class DriveRateError(ConfigError):
    """A drive-angle filter corner chosen from the drive's speed lies at or above fs/2.

    The corner is a number of harmonics of the revolution rate the encoder angle gives, so a
    corner the sampling rate cannot carry means the angle turns implausibly fast: the encoder's
    counts per revolution (or the rate) are wrong. The fields say what was found.

    Attributes
    ----------
    corner_hz : float
        The corner the speed gave, Hz.
    fs : float
        The stream's sampling rate, Hz.
    rate_rad_s : float
        The mean drive speed the encoder angle gave, rad/s.
    """

    corner_hz: float
    fs: float
    rate_rad_s: float
