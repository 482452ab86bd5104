"""A function run beside this process gives the value it gives here, whatever befalls the child."""

from __future__ import annotations

import os
import threading

import pytest

from rigval.validation.beside import beside, can_fork

needs_fork = pytest.mark.usefixtures("forks_beside")


@needs_fork
def test_the_value_comes_from_a_child_process():
    assert beside(os.getpid).result() != os.getpid()


def test_the_value_equals_the_call_here():
    def work():
        return {"sum": sum(range(10_000)), "text": "é" * 3}

    assert beside(work).result() == work()


@needs_fork
def test_a_function_failing_in_the_child_runs_again_here():
    parent = os.getpid()

    def only_here():
        if os.getpid() != parent:
            raise RuntimeError("fails in the child")
        return "done here"

    assert beside(only_here).result() == "done here"


@needs_fork
def test_a_value_that_does_not_pickle_is_computed_here():
    def lock():
        return threading.Lock() if os.getpid() != parent else "computed here"

    parent = os.getpid()
    assert beside(lock).result() == "computed here"


def test_an_error_shows_in_this_process():
    def broken():
        raise ValueError("bad input, with where and how to fix")

    pending = beside(broken)
    with pytest.raises(ValueError, match="bad input"):
        pending.result()


def test_a_second_thread_keeps_the_work_in_this_process():
    stop = threading.Event()
    worker = threading.Thread(target=stop.wait)
    worker.start()
    try:
        assert not can_fork()
        assert beside(os.getpid).result() == os.getpid()
    finally:
        stop.set()
        worker.join()
