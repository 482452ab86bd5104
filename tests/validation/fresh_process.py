"""Run a check of a test module in a new interpreter, where no other thread stops a fork.

A test process may run threads left by an earlier test (a Dask cluster), and with them a
:class:`rigval.validation.beside.Standby` rightly does not fork. A check that needs forked
children runs in a new interpreter instead; it prints "no fork" where forking cannot help
(no ``fork`` start method, one CPU), and the test then skips.
"""

from __future__ import annotations

import contextlib
import subprocess
import sys
from pathlib import Path

import psutil
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

    A check that hangs (a child that never ends) fails after ``timeout_s`` seconds, saying what
    each process of its tree was waiting in and its signal masks (:func:`_tree_state`).
    """
    code = f"from tests.validation import {module} as t; t.{check}(*{args!r})"
    process = subprocess.Popen([sys.executable, "-c", code], cwd=REPO, text=True,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        out, err = process.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        state = _tree_state(process.pid)
        for pid in [*(c.pid for c in _children(process.pid)), process.pid]:
            with contextlib.suppress(psutil.Error):
                psutil.Process(pid).kill()
        _, err = process.communicate()
        pytest.fail(f"{check}{args} did not end in {timeout_s} s; its processes then:\n{state}"
                    f"\nstderr:\n{err}")
    assert process.returncode == 0, err
    if NO_FORK in out:
        pytest.skip("no fork here: no fork start method or one CPU")


def _children(pid: int) -> list[psutil.Process]:
    with contextlib.suppress(psutil.Error):
        return psutil.Process(pid).children(recursive=True)
    return []


def _tree_state(pid: int) -> str:
    """Each process of ``pid``'s tree: its status, what it waits in, its signal masks (Linux)."""
    lines = []
    for process in [psutil.Process(pid), *_children(pid)]:
        with contextlib.suppress(psutil.Error, OSError):
            status = Path(f"/proc/{process.pid}/status").read_text().splitlines()
            masks = " ".join(line for line in status
                             if line.startswith(("Threads", "SigBlk", "SigIgn", "SigCgt")))
            wchan = Path(f"/proc/{process.pid}/wchan").read_text()
            lines.append(f"{process.pid} (parent {process.ppid()}) {process.status()} "
                         f"in {wchan or '-'}: {masks}")
    return "\n".join(lines)
