"""The standard-library scheduler: each run in a child process of its own (no Dask needed).

A tiny stand-in validation (a TOML "scene" naming what to do) gives runs that pass, fail, raise
a rigval error, warn, wait for another run, or kill their own process. The process scheduler
must give the outcomes the in-process one gives (the independent expectation), in the order of
the scenes, each run in its own child process with one BLAS thread; a killed child becomes an
error outcome of its run while the other runs complete.
"""

from __future__ import annotations

import json
import os
import signal
import threading
import time
import tomllib
import warnings
from pathlib import Path

import pytest

import rigval.validation.campaign.engine as campaign
from rigval.acquisition.errors import DataFileError, DataWarning
from rigval.validation.campaign.engine import RunReport, run_campaign
from rigval.validation.campaign.processes import WORKER_DIED, start_method


def standin(scene: Path, run_dir: Path) -> RunReport:
    """Do what the scene says; note the process id and the BLAS threads it ran with."""
    from threadpoolctl import threadpool_info

    spec = tomllib.loads(scene.read_text())
    if "wait_for" in spec:  # until the parent has been told of another run's end
        end = time.monotonic() + 60
        while not (scene.parent / spec["wait_for"]).exists() and time.monotonic() < end:
            time.sleep(0.01)
    if spec.get("warn"):
        warnings.warn(f"{spec['warn']} samples missing (channel: tor1)", DataWarning,
                      stacklevel=1)
    if spec.get("kill"):
        os.kill(os.getpid(), signal.SIGKILL)
    if "exit" in spec:  # a crash that skips Python's clean-up
        os._exit(spec["exit"])
    if spec.get("broken"):
        raise DataFileError("not a column of numbers", where={"file": scene, "line": 3},
                            hint="write one number per line")
    threads = [lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"]
    (run_dir / "process.txt").write_text(f"{os.getpid()} {max(threads, default=1)}")
    report = run_dir / "report.html"
    report.write_text("<html>report</html>")
    value = float(spec["value"])
    rows = ({"comparison": "acc1", "metric": "mean", "value": value, "threshold": "<= 1",
             "passed": value <= 1},)
    return RunReport(passed=value <= 1, metrics=rows, outputs=(report,), inputs=(),
                     speed_rev_s=spec.get("speed"))


def _scene(folder: Path, name: str, **spec: object) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.toml"
    path.write_text("".join(f"{key} = {json.dumps(value)}\n"  # TOML's form of these values
                            for key, value in {"value": 0.5, **spec}.items()))
    return path


def _process(outcome: campaign.RunOutcome) -> tuple[int, int]:
    """Return the process id and BLAS threads of a validated run."""
    pid, threads = (outcome.run_dir / "process.txt").read_text().split()
    return int(pid), int(threads)


def _comparable(outcome: campaign.RunOutcome) -> tuple:
    error = outcome.error
    return (outcome.name, outcome.status, outcome.metrics, outcome.outputs, outcome.reused,
            [str(w) for w in outcome.warnings],
            error and (error.kind, error.message, error.where, error.hint,
                       type(error.exception), error.exception.where))


def test_processes_give_the_in_process_outcomes_in_scene_order(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    data = tmp_path / "data"
    scenes = [_scene(data, "good", value=0.25, speed=0.8), _scene(data, "bad", value=2.0),
              _scene(data, "broken", broken=True), _scene(data, "noisy", warn=123)]
    warned = ["rigval: warning: [run noisy] DataWarning: 123 samples missing (channel: tor1)"]
    alone = run_campaign(scenes, tmp_path / "one", scheduler="none", validate=standin)
    assert capsys.readouterr().err.splitlines() == warned
    apart = run_campaign(scenes, tmp_path / "many", scheduler="processes", workers=2,
                         validate=standin)
    assert capsys.readouterr().err.splitlines() == warned  # raised again in this process
    assert [_comparable(o) for o in apart] == [_comparable(o) for o in alone]
    assert [o.status for o in apart] == ["passed", "failed", "error", "passed"]
    error = apart[2].error
    assert isinstance(error.exception, DataFileError)  # the object crossed the pipe, fields kept
    assert error.where == {"file": scenes[2], "line": 3}
    assert error.hint == "write one number per line"
    assert "DataFileError" in error.traceback  # the child's traceback
    assert apart[0].metrics[0]["value"] == 0.25
    pids = [_process(o)[0] for o in apart if o.status != "error"]
    assert len(set(pids)) == len(pids) == 3 and os.getpid() not in pids  # a child per run
    assert {_process(o)[0] for o in alone if o.status != "error"} == {os.getpid()}
    assert (tmp_path / "many" / "good" / campaign.MANIFEST_NAME).is_file()


def test_a_child_killed_by_a_signal_is_an_error_of_its_run_only(tmp_path: Path) -> None:
    data = tmp_path / "data"
    scenes = [_scene(data, "first"), _scene(data, "killed", kill=True),
              _scene(data, "crashed", exit=3), _scene(data, "last")]
    outcomes = run_campaign(scenes, tmp_path / "out", scheduler="processes", workers=2,
                            validate=standin)
    assert [o.status for o in outcomes] == ["passed", "error", "error", "passed"]
    assert "run crashed exited with code 3" in outcomes[2].error.message
    assert outcomes[2].error.kind == WORKER_DIED and "--workers 1" in outcomes[2].error.hint
    error = outcomes[1].error
    assert error.kind == WORKER_DIED
    assert "run killed was killed by signal SIGKILL" in error.message
    assert error.where["run"] == "killed"
    assert "out-of-memory" in error.hint
    assert not (tmp_path / "out" / "killed" / campaign.MANIFEST_NAME).exists()


def test_outcomes_follow_the_scenes_and_notices_the_completions(tmp_path: Path) -> None:
    data = tmp_path / "data"
    scenes = [_scene(data, "late", wait_for="told_early"), _scene(data, "early")]
    told = []

    def on_result(outcome: campaign.RunOutcome) -> None:
        told.append(outcome.name)
        (data / f"told_{outcome.name}").write_text("")

    outcomes = run_campaign(scenes, tmp_path / "out", scheduler="processes", workers=2,
                            validate=standin, on_result=on_result)
    assert told == ["early", "late"]  # "late" waited until the parent was told of "early"
    assert [o.name for o in outcomes] == ["late", "early"]
    assert [o.status for o in outcomes] == ["passed", "passed"]


def test_each_child_runs_one_blas_thread(tmp_path: Path) -> None:
    from threadpoolctl import threadpool_limits

    scenes = [_scene(tmp_path / "data", name) for name in ("a", "b")]
    with threadpool_limits(2, user_api="blas"):  # as numpy starts on a 2-core machine
        outcomes = run_campaign(scenes, tmp_path / "out", scheduler="processes",
                                validate=standin, workers=2)
    assert [_process(o)[1] for o in outcomes] == [1, 1]


def test_without_dask_several_runs_go_to_child_processes(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(campaign, "dask_available", lambda: False)
    monkeypatch.setattr(campaign.os, "cpu_count", lambda: 2)
    scenes = [_scene(tmp_path / "data", name) for name in ("a", "b")]
    apart = run_campaign(scenes, tmp_path / "out", validate=standin)
    assert os.getpid() not in {_process(o)[0] for o in apart}
    alone = run_campaign(scenes, tmp_path / "alone", validate=standin, workers=1)
    assert {_process(o)[0] for o in alone} == {os.getpid()}


def test_fork_only_while_this_process_runs_one_thread() -> None:
    if threading.active_count() == 1:  # no thread left running by another test
        assert start_method() == "fork"
    stop = threading.Event()
    thread = threading.Thread(target=stop.wait)
    thread.start()
    try:
        assert start_method() in {"forkserver", "spawn"}
    finally:
        stop.set()
        thread.join()


def draw_pid(inputs: object, names: tuple[str, ...]) -> list[list[str]]:
    """A figure group function whose "figure" names the process that drew it."""
    return [[f"{os.getpid()}"] for _ in names]


def drawing_standin(scene: Path, run_dir: Path) -> RunReport:
    """Draw one group with the drawers of this run's process; note who drew it."""
    from rigval.validation.report.drawing import Drawing, standby_drawers

    with standby_drawers() as drawers:
        page = Drawing(drawers)
        page.start(draw_pid, None, ("g",))
        drawer = int(page.texts("g")[0])
    (run_dir / "process.txt").write_text(f"{os.getpid()} {drawer}")
    return RunReport(passed=True, metrics=(), outputs=(), inputs=(), speed_rev_s=None)


def _drawers_serve_one_run_process_each() -> None:
    """Three runs, two at a time, two drawers forked first: each of the first two runs draws
    with a drawer of its own (another process), the third in its own process."""
    import tempfile

    from rigval.validation.beside import Standby
    from rigval.validation.report.drawing import Drawers
    from tests.validation.fresh_process import no_fork_here

    if no_fork_here():
        return
    with tempfile.TemporaryDirectory() as folder:
        scenes = [_scene(Path(folder) / "scenes", f"r{k}") for k in range(3)]
        standbys = Standby.group(2)
        with standbys[0]:
            outcomes = run_campaign(scenes, Path(folder) / "out", scheduler="processes",
                                    workers=2, validate=drawing_standin,
                                    drawers=Drawers(standbys).each())
        assert [o.status for o in outcomes] == ["passed"] * 3
        drawn = [tuple(map(int, (o.run_dir / "process.txt").read_text().split()))
                 for o in outcomes]
    (run1, drawer1), (run2, drawer2), (run3, drawer3) = drawn
    assert len({run1, run2, run3, drawer1, drawer2}) == 5  # two drawers, each its own process
    assert drawer3 == run3  # no drawer left for it: drawn in its own process
    assert os.getpid() not in {drawer1, drawer2}


def test_drawers_forked_for_the_runs_serve_one_run_process_each():
    from tests.validation.fresh_process import run_in_a_fresh_process

    run_in_a_fresh_process("test_campaign_processes", "_drawers_serve_one_run_process_each")
