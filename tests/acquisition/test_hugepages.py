"""The huge-page switch around large reads is scoped and leaves a user's explicit choice alone."""

from __future__ import annotations

import pytest

from rigval.acquisition.hugepages import _switch, plain_pages

switch = _switch()
pytestmark = pytest.mark.skipif(switch is None, reason="this NumPy has no huge-page switch")


def test_switch_is_off_inside_and_restored_after() -> None:
    assert switch is not None
    before = switch(True)
    try:
        with plain_pages():
            assert switch(False) is False  # plain_pages had switched the request off
        assert switch(True) is True  # and put back what was there
    finally:
        switch(before)


def test_an_explicit_numpy_setting_is_kept(monkeypatch: pytest.MonkeyPatch) -> None:
    assert switch is not None
    monkeypatch.setenv("NUMPY_MADVISE_HUGEPAGE", "1")
    before = switch(True)
    try:
        with plain_pages():
            assert switch(True) is True
    finally:
        switch(before)
