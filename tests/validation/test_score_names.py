"""Score names come from the score dataclasses; they match what compare() actually reports."""

from __future__ import annotations

import numpy as np
import pytest

from rigval.acquisition.errors import ConfigError
from rigval.validation.metrics.compare import METRICS, compare, score_names


def _numeric_keys(scores: dict) -> list[str]:
    return [k for k, v in scores.items() if isinstance(v, int | float) and not isinstance(v, bool)]


@pytest.mark.parametrize("metric", METRICS)
def test_declared_names_equal_the_computed_ones(metric: str) -> None:
    angle = np.arange(64) * (2.0 * np.pi / 64)
    measured, model = np.sin(angle) + 0.3 * np.cos(2 * angle), 1.1 * np.sin(angle + 0.1)
    cycles = measured + 0.01 * np.array([[1.0], [-1.0], [0.5]])
    options = {"uncertainty": {"u_measurement": 0.01}} if metric == "vv20" else {}
    computed = compare(measured, model, angle, metrics=[metric], cycles=cycles, **options)
    assert list(score_names([metric])) == _numeric_keys(computed)


def test_unknown_metric_is_refused() -> None:
    with pytest.raises(ConfigError, match="unknown metric 'iso'"):
        score_names(["iso"])
