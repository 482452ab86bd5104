"""What a campaign shows on the terminal: one line for Ctrl-C, warnings as whole lines.

``rigval campaign`` runs in a subprocess of its own session with a stand-in validation (a short
sleep, one DataWarning, a marker file when a run starts). SIGINT goes to the whole process group,
as a terminal's Ctrl-C does, at several moments: while the embedded cluster's worker processes
start, while runs execute on them, and during a run in the campaign's own process. Each time
stderr must be exactly ``rigval: interrupted``, the exit code 130 and no process left behind.
Warnings raised in worker processes must reach the terminal in the campaign's process, one line
each naming the run, never inside the progress line (checked on a pseudo-terminal).
"""

from __future__ import annotations

import os
import pty
import re
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

psutil = pytest.importorskip("psutil", reason="the parallel extra is not installed")
pytest.importorskip("distributed", reason="the parallel extra is not installed")

STANDIN = '''
import sys, time, tomllib, warnings
from pathlib import Path
from rigval.acquisition.errors import DataWarning
from rigval.validation.campaign import runs as campaign
from rigval.validation.cli import main

def standin(scene, run_dir):
    spec = tomllib.loads(Path(scene).read_text())
    (Path(scene).parent / (Path(scene).stem + ".started")).write_text("")
    warnings.warn(f"stream wls1: {spec['gap']} samples missing (channel: tor1)", DataWarning)
    time.sleep(spec["sleep"])
    report = Path(run_dir) / "report.html"
    report.write_text("<html>report</html>")
    return campaign.RunReport(passed=True, metrics=(), outputs=(report,), inputs=(),
                              speed_rev_s=1.0)

campaign._validate_with_pipeline = standin
if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
'''


def _setup(tmp_path: Path, sleep: float, runs: int = 3) -> tuple[Path, list[Path]]:
    script = tmp_path / "standin.py"
    script.write_text(STANDIN)
    scenes = []
    for i in range(runs):
        scene = tmp_path / f"run{i}.toml"
        scene.write_text(f"sleep = {sleep}\ngap = {100 + i}\n")
        scenes.append(scene)
    return script, scenes


def _start(script: Path, scenes: list[Path], out: Path, *options: str, **kwargs: object
           ) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, str(script), "campaign", *map(str, scenes),
                             "--out", str(out), *options], cwd=script.parent,
                            start_new_session=True, preexec_fn=_default_sigint,
                            **kwargs)  # type: ignore[call-overload]


def _default_sigint() -> None:
    """Give the child the SIGINT disposition of a terminal's foreground process.

    A shell's background job (``cmd &`` without job control) starts with SIGINT ignored, and
    children inherit that; Python then installs no KeyboardInterrupt handler; a runner may also
    block it (a blocked signal stays blocked across fork and exec). Either way the test would
    depend on how its own runner was started.
    """
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _wait_for(condition, timeout: float = 120.0) -> None:
    end = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < end, "the moment to interrupt never came"
        time.sleep(0.02)


def _workers_starting(process: subprocess.Popen) -> bool:
    try:
        children = psutil.Process(process.pid).children(recursive=True)
        return any("multiprocessing.spawn" in " ".join(c.cmdline()) for c in children)
    except psutil.Error:
        return False


def _interrupt(process: subprocess.Popen) -> tuple[int, str, list[int]]:
    family = [c.pid for c in psutil.Process(process.pid).children(recursive=True)]
    os.killpg(process.pid, signal.SIGINT)  # like Ctrl-C: the whole foreground group
    _, err = process.communicate(timeout=120)
    return process.returncode, err, family


def _assert_one_line(code: int, err: str, family: list[int]) -> None:
    assert code == 130, err
    assert err.splitlines() == ["rigval: interrupted"], err
    time.sleep(0.5)  # killed children are reaped by their parent's exit
    left = [pid for pid in family if psutil.pid_exists(pid)
            and psutil.Process(pid).status() != psutil.STATUS_ZOMBIE]
    assert left == [], "worker processes outlived the campaign"


@pytest.mark.parametrize("moment", ["workers starting", "runs on workers"])
def test_ctrl_c_on_a_cluster_prints_one_line(tmp_path: Path, moment: str) -> None:
    script, scenes = _setup(tmp_path, sleep=60.0)
    process = _start(script, scenes, tmp_path / "out", "--workers", "2",
                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if moment == "workers starting":
        _wait_for(lambda: _workers_starting(process))
    else:
        _wait_for(lambda: any(tmp_path.glob("*.started")))
    _assert_one_line(*_interrupt(process))


def test_ctrl_c_during_a_run_in_this_process_prints_one_line(tmp_path: Path) -> None:
    script, scenes = _setup(tmp_path, sleep=60.0)
    process = _start(script, scenes, tmp_path / "out", "--scheduler", "none",
                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    _wait_for(lambda: any(tmp_path.glob("*.started")))
    _assert_one_line(*_interrupt(process))


def test_ctrl_c_during_runs_in_child_processes_prints_one_line(tmp_path: Path) -> None:
    script, scenes = _setup(tmp_path, sleep=60.0)
    process = _start(script, scenes, tmp_path / "out", "--scheduler", "processes", "--workers",
                     "2", stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    _wait_for(lambda: len(list(tmp_path.glob("*.started"))) == 2)
    _assert_one_line(*_interrupt(process))


def test_ctrl_c_while_the_command_line_loads_prints_one_line(tmp_path: Path) -> None:
    """Right when main() starts: its subcommands and the campaign engine are still importing.

    (Before main() runs, the interpreter's start-up and the standard-library imports of
    ``rigval.validation.cli`` are Python's own.)
    """
    script = tmp_path / "bare.py"
    marker = tmp_path / "main.started"
    script.write_text("import pathlib, sys\nfrom rigval.validation.cli import main\n"
                      "if __name__ == '__main__':  # not again in a spawned worker\n"
                      f"    pathlib.Path({str(marker)!r}).write_text('')\n"
                      "    sys.exit(main(sys.argv[1:]))\n")
    _, scenes = _setup(tmp_path, sleep=60.0)
    process = _start(script, scenes, tmp_path / "out", stdout=subprocess.PIPE,
                     stderr=subprocess.PIPE, text=True)
    _wait_for(marker.exists, timeout=60)
    _assert_one_line(*_interrupt(process))


@pytest.mark.parametrize("scheduler", ["local", "processes"])
def test_worker_warnings_are_whole_lines_naming_their_run(tmp_path: Path, scheduler: str) -> None:
    script, scenes = _setup(tmp_path, sleep=0.2)
    out = tmp_path / "out"
    leader, follower = pty.openpty()  # a terminal, so the progress line is drawn
    process = _start(script, scenes, out, "--workers", "2", "--scheduler", scheduler,
                     stdout=subprocess.PIPE, stderr=follower)
    os.close(follower)
    chunks = []
    while True:
        ready, _, _ = select.select([leader], [], [], 120)
        assert ready, "no output for 120 s"
        try:
            chunk = os.read(leader, 4096)
        except OSError:  # the campaign ended and closed the terminal
            break
        if not chunk:
            break
        chunks.append(chunk)
    os.close(leader)
    assert process.wait(timeout=60) == 0
    process.stdout.close()
    text = b"".join(chunks).decode()
    lines = [line.rsplit("\r\x1b[K", 1)[-1] for line in text.replace("\r\n", "\n").split("\n")]
    warned = [line for line in lines if "DataWarning" in line]
    assert sorted(warned) == [
        f"rigval: warning: [run run{i}] DataWarning: stream wls1: {100 + i} samples missing "
        "(channel: tor1)" for i in range(3)]
    assert any(line.startswith("\rcampaign [") or line.startswith("campaign [")
               for line in text.split("\n")), "no progress line was drawn"
    assert not re.search(r"\.py:\d+: DataWarning", text)
    assert not (out / "dask-workers.log").exists()  # nothing went there
