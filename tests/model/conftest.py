"""Fixtures for the model tests: built-in mechanisms and their parsed dictionaries."""

from __future__ import annotations

import tomllib
from typing import Any

import pytest

import rigval.model as rm


@pytest.fixture(scope="session")
def pendulum() -> rm.Mechanism:
    return rm.load_mechanism(rm.builtin_mechanism("pendulum"))


@pytest.fixture(scope="session")
def fourbar() -> rm.Mechanism:
    return rm.load_mechanism(rm.builtin_mechanism("fourbar"))


@pytest.fixture(scope="session")
def single() -> rm.Mechanism:
    return rm.load_mechanism(rm.builtin_mechanism("single_pendulum"))


def _table(name: str) -> dict[str, Any]:
    return tomllib.loads(rm.builtin_mechanism(name).read_text())


@pytest.fixture
def fourbar_dict() -> dict[str, Any]:
    """A fresh, mutable dictionary of fourbar.toml."""
    return _table("fourbar")


@pytest.fixture
def pendulum_dict() -> dict[str, Any]:
    """A fresh, mutable dictionary of pendulum.toml."""
    return _table("pendulum")
