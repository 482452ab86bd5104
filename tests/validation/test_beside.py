"""A call handed to a standby child gives the value it gives here, whatever befalls the child."""

from __future__ import annotations

import contextlib
import os
import signal
import threading
import time
from types import MappingProxyType

import numpy as np
import pytest

from rigval.validation.beside import Standby, can_fork
from tests.validation.fresh_process import no_fork_here, run_in_a_fresh_process

needs_fork = pytest.mark.usefixtures("forks_beside")


def _pid_and(value):
    return os.getpid(), value


def _fails_in_a_child(parent: int) -> str:
    if os.getpid() != parent:
        raise RuntimeError("fails in the child")
    return "done here"


def _lock_unless_here(parent: int):
    return threading.Lock() if os.getpid() != parent else "computed here"


def _broken() -> None:
    raise ValueError("bad input, with where and how to fix")


@needs_fork
def test_standby_calls_run_in_its_child_in_order_with_their_arguments():
    table = MappingProxyType({"a": MappingProxyType({"b": 1.5}), "c": np.arange(4.0)})
    with Standby(["json"]) as standby:
        calls = [standby.submit(_pid_and, (k, table)) for k in range(3)]
        values = [call.result() for call in reversed(calls)][::-1]
    pids = {pid for pid, _ in values}
    assert len(pids) == 1 and os.getpid() not in pids
    for k, (_, (number, copy)) in enumerate(values):
        assert number == k
        assert isinstance(copy, MappingProxyType) and copy["a"]["b"] == 1.5
        np.testing.assert_array_equal(copy["c"], table["c"])


@needs_fork
def test_standby_calls_that_fail_or_do_not_pickle_run_here():
    parent = os.getpid()
    with Standby() as standby:
        failing = standby.submit(_fails_in_a_child, parent)
        unpicklable_value = standby.submit(_lock_unless_here, parent)
        unpicklable_call = standby.submit(lambda: os.getpid())
        after = standby.submit(_pid_and, "after")
        assert failing.result() == "done here"
        assert unpicklable_value.result() == "computed here"
        assert unpicklable_call.result() == parent
        assert after.result()[0] != parent  # the child still serves


@needs_fork
def test_standby_calls_run_here_when_the_child_is_killed():
    with Standby() as standby:
        child = standby.submit(os.getpid).result()
        os.kill(child, signal.SIGKILL)
        assert standby.submit(_pid_and, 1).result() == (os.getpid(), 1)


def test_a_standby_error_shows_in_this_process():
    with Standby() as standby:
        pending = standby.submit(_broken)
        with pytest.raises(ValueError, match="bad input"):
            pending.result()


def _closing_ends_each_child() -> None:
    if no_fork_here():
        return
    first, second = Standby(), Standby()
    pids = [first.submit(os.getpid).result(), second.submit(os.getpid).result()]
    first.close()  # returns although the second child, forked after the first, still runs
    with pytest.raises(ProcessLookupError):
        os.kill(pids[0], 0)
    os.kill(pids[1], 0)
    second.close()
    with pytest.raises(ProcessLookupError):
        os.kill(pids[1], 0)


def test_closing_a_standby_ends_its_child_while_a_later_one_runs():
    run_in_a_fresh_process("test_beside", "_closing_ends_each_child", timeout_s=120)


@contextlib.contextmanager
def _another_thread():
    """Run a second thread in this process for the ``with`` block (no fork is safe then)."""
    stop = threading.Event()
    worker = threading.Thread(target=stop.wait)
    worker.start()
    try:
        yield
    finally:
        stop.set()
        worker.join()


def _assert_ended(pids) -> None:
    for pid in pids:
        with pytest.raises(ProcessLookupError):
            os.kill(pid, 0)


def test_a_second_thread_keeps_the_calls_in_this_process():
    with _another_thread():
        assert not can_fork()
        with Standby() as standby:
            assert standby.submit(os.getpid).result() == os.getpid()


#: How the process that makes the standbys left SIGTERM, the signal that stops a child: as
#: by default, or blocked or ignored as a test runner or job system may leave it (either stays
#: so in a forked child).
SIGTERM_HERE = ["default", "blocked", "ignored"]


def _leave_sigterm(how: str) -> None:
    if how == "blocked":
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGTERM})
    elif how == "ignored":
        signal.signal(signal.SIGTERM, signal.SIG_IGN)


def _an_error_ends_the_child_at_once(sigterm: str) -> None:
    if no_fork_here():
        return
    _leave_sigterm(sigterm)
    with pytest.raises(RuntimeError, match="stop"), Standby() as standby:
        pid = standby.submit(os.getpid).result()
        standby.submit(time.sleep, 600)  # never waited for: the error ends the child
        raise RuntimeError("stop")
    _assert_ended([pid])


@pytest.mark.parametrize("sigterm", SIGTERM_HERE)
def test_an_error_ends_the_child_without_waiting_for_its_calls(sigterm):
    run_in_a_fresh_process("test_beside", "_an_error_ends_the_child_at_once", timeout_s=120,
                           args=(sigterm,))


def _an_error_ends_the_child_while_it_imports(sigterm: str) -> None:
    import sys
    import tempfile
    from pathlib import Path

    if no_fork_here():
        return
    _leave_sigterm(sigterm)
    folder = Path(tempfile.mkdtemp())
    started = folder / "slow_import.py.pid"
    (folder / "slow_import.py").write_text(
        "import os, time\nwith open(__file__ + '.pid', 'w') as f:\n    f.write(str(os.getpid()))\n"
        "time.sleep(600)\n")
    sys.path.insert(0, str(folder))
    with pytest.raises(RuntimeError, match="stop"), Standby(["slow_import"]) as standby:
        standby.submit(os.getpid)  # never answered: the child is still importing
        deadline = time.monotonic() + 60.0
        while not started.exists() or not started.read_text():
            assert time.monotonic() < deadline, "the child never began its import"
            time.sleep(0.01)
        raise RuntimeError("stop")
    _assert_ended([int(started.read_text())])


@pytest.mark.parametrize("sigterm", SIGTERM_HERE)
def test_an_error_ends_the_child_while_it_imports_its_modules(sigterm):
    run_in_a_fresh_process("test_beside", "_an_error_ends_the_child_while_it_imports",
                           timeout_s=120, args=(sigterm,))


def _pid_and_imported(name: str) -> tuple[int, bool]:
    import sys

    return os.getpid(), name in sys.modules


def _group_imports_once() -> None:
    """A group of three: three children, the module imported by the first alone, all end."""
    import sys
    import tempfile
    from pathlib import Path

    if no_fork_here():
        return
    folder = Path(tempfile.mkdtemp())
    (folder / "counted_import.py").write_text(
        "import os\nwith open(__file__ + '.pids', 'a') as f:\n    f.write(f'{os.getpid()}\\n')\n")
    sys.path.insert(0, str(folder))
    standbys = Standby.group(3, ["counted_import"])
    with standbys[0]:
        seen = [s.submit(_pid_and_imported, "counted_import").result() for s in standbys]
    pids = [pid for pid, _ in seen]
    assert len(set(pids)) == 3 and os.getpid() not in pids
    assert all(imported for _, imported in seen)
    importers = (folder / "counted_import.py.pids").read_text().split()
    assert importers == [str(pids[0])]  # the others were forked from it, the module imported
    assert "counted_import" not in sys.modules  # never here
    _assert_ended(pids)  # closing the first ended every child


def test_a_group_imports_its_modules_once_and_ends_together():
    run_in_a_fresh_process("test_beside", "_group_imports_once", timeout_s=120)


def _group_error_ends_all_at_once(sigterm: str) -> None:
    if no_fork_here():
        return
    _leave_sigterm(sigterm)
    standbys = Standby.group(2)
    with pytest.raises(RuntimeError, match="stop"), standbys[0]:
        pids = [s.submit(os.getpid).result() for s in standbys]
        standbys[1].submit(time.sleep, 600)  # never waited for: the error ends both children
        raise RuntimeError("stop")
    _assert_ended(pids)


@pytest.mark.parametrize("sigterm", SIGTERM_HERE)
def test_an_error_ends_every_child_of_a_group_without_waiting_for_its_calls(sigterm):
    run_in_a_fresh_process("test_beside", "_group_error_ends_all_at_once", timeout_s=120,
                           args=(sigterm,))


def test_a_group_without_fork_runs_its_calls_here():
    with _another_thread():
        standbys = Standby.group(2)
        with standbys[0]:
            assert [s.submit(os.getpid).result() for s in standbys] == [os.getpid()] * 2


def _sigterm_blocked_by_thread() -> tuple[int, dict[str, bool]]:
    """In the child: its pid, and whether each of its threads blocks SIGTERM (the kernel's view)."""
    from pathlib import Path

    main = os.getpid()
    blocked = {}
    for task in Path(f"/proc/{main}/task").iterdir():
        mask = next(line for line in (task / "status").read_text().splitlines()
                    if line.startswith("SigBlk:"))
        bit = 1 << (signal.SIGTERM - 1)
        blocked["main" if int(task.name) == main else task.name] = bool(
            int(mask.split()[1], 16) & bit)
    return main, blocked


def _stop_goes_to_the_main_thread() -> None:
    if no_fork_here():
        return
    standbys = Standby.group(2)
    with standbys[0]:
        seen = [standby.submit(_sigterm_blocked_by_thread).result() for standby in standbys]
    assert len({pid for pid, _ in seen} - {os.getpid()}) == 2  # both ran in a child
    for _, blocked in seen:
        assert blocked.pop("main") is False
        assert len(blocked) == 2 and all(blocked.values())  # the reader and the sender


@pytest.mark.skipif(not os.path.isdir("/proc/self/task"), reason="needs Linux's /proc")
def test_only_the_childs_main_thread_takes_the_stop():
    """SIGTERM taken by another thread would leave a main thread waiting for others unstopped."""
    run_in_a_fresh_process("test_beside", "_stop_goes_to_the_main_thread", timeout_s=120)
