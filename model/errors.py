"""Errors of the model layer, rooted at :class:`~rigval.acquisition.errors.RigvalError`.

See docs/errors.md for every rigval error and what carries the location and the fix.
"""

from __future__ import annotations

from rigval.acquisition.errors import ConfigError, RigvalError

__all__ = ["AssemblyError", "MechanismError", "ModelError", "SingularityError"]


class MechanismError(ConfigError):
    """A mechanism file is invalid: unknown bodies or points, wrong constraint count, bad values."""


class ModelError(RigvalError, RuntimeError):
    """A mechanism cannot be solved at some time or angle."""


class AssemblyError(ModelError):
    """Newton-Raphson did not assemble the mechanism; ``where`` names the open joints."""


class SingularityError(ModelError):
    """The constraint Jacobian lost rank (a toggle or lock-up position); names time and joints."""
