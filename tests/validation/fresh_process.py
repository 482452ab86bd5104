"""Run a check of a test module in a new interpreter, where no other thread stops a fork.

A test process may run threads left by an earlier test (a Dask cluster), and with them a
:class:`rigval.validation.beside.Standby` rightly does not fork. A check that needs forked
children runs in a new interpreter instead; it prints "no fork" where forking cannot help
(no ``fork`` start method, one CPU), and the test then skips.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from rigval.validation.beside import can_fork

__all__ = ["no_fork_here", "run_in_a_fresh_process"]

REPO = Path(__file__).resolve().parents[2]
#: What a check prints where no child may be forked: :func:`run_in_a_fresh_process` skips.
NO_FORK = "no fork"


def no_fork_here() -> bool:
    """Return whether this process may not fork standby children, and then say so.

    A check returns at once when it is true; :func:`run_in_a_fresh_process` sees what it
    printed and skips the test.
    """
    if can_fork():
        return False
    print(NO_FORK)
    return True


def run_in_a_fresh_process(module: str, check: str, timeout_s: float = 300.0,
                           args: tuple[str, ...] = ()) -> None:
    """Run ``check(*args)`` of ``tests.validation.<module>`` in a new interpreter; skip on no fork.

    A check that hangs (a child that never ends) fails after ``timeout_s`` seconds.
    """
    code = f"from tests.validation import {module} as t; t.{check}(*{args!r})"
    done = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True,
                          text=True, timeout=timeout_s, check=False)
    assert done.returncode == 0, done.stderr
    if NO_FORK in done.stdout:
        pytest.skip("no fork here: no fork start method or one CPU")
