"""Values made ready for JSON: what json.dumps writes, and standard JSON only."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np

from rigval.acquisition.json_values import json_ready


@dataclasses.dataclass(frozen=True)
class _Record:
    name: str
    values: tuple[float, ...]
    where: Path


def test_nested_values_become_standard_json_with_the_same_content() -> None:
    value = {"a": np.float32(0.5), 3: [np.int64(7), (np.bool_(True), None)],
             "bad": [math.nan, -math.inf, np.float64(math.inf)],
             "record": _Record("r", (1.0, np.float64(2.5)), Path("/tmp/x.json"))}
    ready = json_ready(value)
    text = json.dumps(ready, allow_nan=False)  # raises on NaN or infinity
    assert json.loads(text) == {"a": 0.5, "3": [7, [True, None]], "bad": [None, None, None],
                                "record": {"name": "r", "values": [1.0, 2.5],
                                           "where": "/tmp/x.json"}}
    assert type(ready["a"]) is float and type(ready["3"][0]) is int
    assert json_ready("text") == "text" and json_ready(_Record) is _Record  # a class stays


def test_plain_values_keep_their_type_and_only_non_finite_floats_change() -> None:
    """The plain types are passed through by a check of their type alone (the fast path)."""
    plain = [True, 1, 2.5, None, "s", -0.0]
    ready = json_ready([*plain, math.inf, np.float64(3.0), np.bool_(False)])
    assert ready == [*plain, None, 3.0, False]
    assert [type(v) for v in ready] == [bool, int, float, type(None), str, float, type(None),
                                        float, bool]
