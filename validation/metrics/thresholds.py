"""Pass/fail thresholds on metric scores.

A threshold is a short string: an optional ``abs``, a comparison operator and a number::

    ">= 0.8"          score at least 0.8 (ISO rating "good" or better)
    "<= 0.1"          score at most 0.1
    "abs <= 0.1"      |score| at most 0.1 (signed scores: Sprague-Geers magnitude, lag, peak error)
    "< 5"  "> 0"      strict comparisons

Operators: ``<``, ``<=``, ``>``, ``>=``. The number is a plain decimal or exponent literal
(``1e-3``). Thresholds are keyed by score name as :func:`rigval.validation.metrics.compare.compare`
names them (``"iso18571_periodic.rating"``, ``"nrmse"``, ``"sprague_geers.magnitude"``). A NaN
score fails every threshold.
"""

from __future__ import annotations

import logging
import math
import numbers
import operator
import re
from collections.abc import Callable, Mapping
from typing import Any, NamedTuple

from rigval.acquisition.errors import ConfigError

__all__ = ["ThresholdCheck", "check_thresholds", "parse_threshold"]

logger = logging.getLogger(__name__)

_OPERATORS: dict[str, Callable[[float, float], bool]] = {
    "<=": operator.le, ">=": operator.ge, "<": operator.lt, ">": operator.gt}
_PATTERN = re.compile(
    r"^\s*(?P<abs>abs\s+)?(?P<op><=|>=|<|>)\s*"
    r"(?P<number>[-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?)\s*$")
_SYNTAX = "'[abs] OP NUMBER' with OP one of <, <=, >, >= (for example '>= 0.8' or 'abs <= 0.1')"


class ThresholdCheck(NamedTuple):
    """Outcome of one threshold.

    Attributes
    ----------
    metric : str
        Score name.
    value : float
        The score.
    threshold : str
        The threshold as written.
    passed : bool
        Whether the score meets it.
    """

    metric: str
    value: float
    threshold: str
    passed: bool


def parse_threshold(text: str, key: str = "threshold") -> Callable[[float], bool]:
    """Parse a threshold string into a test of a score.

    Parameters
    ----------
    text : str
        ``"[abs] OP NUMBER"`` (see the module docstring).
    key : str
        Key path of the threshold, for error messages.

    Returns
    -------
    callable
        ``test(score) -> bool``; False for a NaN score.

    Raises
    ------
    ConfigError
        If the text does not follow the syntax (the error names ``key``).
    """
    match = _PATTERN.match(text) if isinstance(text, str) else None
    if match is None:
        raise ConfigError(f"threshold {text!r} is not understood", where={"key": key},
                          hint=f"write {_SYNTAX}")
    compare = _OPERATORS[match["op"]]
    limit = float(match["number"])
    use_abs = match["abs"] is not None

    def test(score: float) -> bool:
        if math.isnan(score):
            return False
        return bool(compare(abs(score) if use_abs else score, limit))

    return test


def check_thresholds(scores: Mapping[str, Any], thresholds: Mapping[str, str], *,
                     key_path: str = "thresholds") -> list[ThresholdCheck]:
    """Check scores against thresholds.

    Parameters
    ----------
    scores : mapping
        Score name to value, as returned by :func:`rigval.validation.metrics.compare.compare`.
    thresholds : mapping
        Score name to threshold string, for example ``{"iso18571_periodic.rating": ">= 0.8",
        "nrmse": "<= 0.1"}``.
    key_path : str
        Where the thresholds come from (a scene key path such as
        ``"comparisons.torque_F.thresholds"``); error messages name ``key_path.<score>``.

    Returns
    -------
    list of ThresholdCheck
        One ``(metric, value, threshold, passed)`` per threshold, in the thresholds' order.

    Raises
    ------
    ConfigError
        For bad threshold syntax, a score name that is not among the scores (the error lists the
        available ones) or a score that is not a number.
    """
    results = []
    for metric, text in thresholds.items():
        key = f"{key_path}.{metric}"
        test = parse_threshold(text, key)
        if metric not in scores:
            numeric = sorted(name for name, value in scores.items() if _is_number(value))
            raise ConfigError(f"threshold names the score {metric!r}, which was not computed",
                              where={"key": key},
                              hint=f"use one of: {', '.join(numeric)}; or add its metric to the "
                                   f"comparison's metrics")
        value = scores[metric]
        if not _is_number(value):
            raise ConfigError(f"score {metric!r} is {value!r}, not a number",
                              where={"key": key}, hint="set thresholds on numeric scores only")
        passed = test(float(value))
        logger.debug("threshold %s %s on %g: %s", metric, text, value, passed)
        results.append(ThresholdCheck(metric, float(value), text, passed))
    return results


def _is_number(value: Any) -> bool:
    """Tell whether a score is a real number (numpy scalars and bools included)."""
    return isinstance(value, numbers.Real)
