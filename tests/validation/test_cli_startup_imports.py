"""``rigval --help`` and ``rigval info`` start without the heavy libraries (no timing asserts).

Each case runs the command line in a fresh interpreter and reports which modules it imported.
"""

import json
import subprocess
import sys

import pytest

from rigval.sample_data import runs_dir

HEAVY = ("matplotlib", "scipy", "xarray", "pandas", "numpy", "netCDF4", "dask", "nptdms")

SCRIPT = """
import contextlib, io, json, sys
if {block_dask}:
    sys.modules["dask"] = None  # an installation without the parallel extra
from rigval.validation.cli import main
with contextlib.redirect_stdout(io.StringIO()) as out:
    code = main({argv!r})
print(json.dumps({{"code": code, "out": out.getvalue(),
                  "modules": [m for m in {heavy!r} if m in sys.modules]}}))
"""


def run_cli(argv, block_dask=False, watch=HEAVY):
    code = SCRIPT.format(argv=list(argv), heavy=watch, block_dask=block_dask)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("argv", [["--help"], ["info", "--help"], ["validate", "--help"],
                                  ["--version"]])
def test_help_imports_no_numeric_library(argv):
    result = run_cli(argv)
    assert result["code"] == 0
    assert "rigval" in result["out"]
    assert result["modules"] == []


def test_help_looks_up_no_version_and_no_process_pool():
    # the version is read from the distribution's metadata only for --version; the bench
    # command's stages come without its runner (a process pool)
    result = run_cli(["validate", "--help"],
                     watch=("importlib.metadata", "concurrent.futures.process"))
    assert result["code"] == 0 and result["modules"] == []
    version = run_cli(["--version"], watch=("importlib.metadata",))
    assert version["out"].startswith("rigval ") and version["modules"] == ["importlib.metadata"]


def test_info_of_a_tdms_file_reads_metadata_with_numpy_alone():
    # described from the segment metadata (rigval.acquisition.tdms_plan): no Dataset, no nptdms
    result = run_cli(["info", str(runs_dir() / "run_0p8_cdaq.tdms")])
    assert result["code"] == 0
    assert "samples" in result["out"]  # it did describe the file
    assert result["modules"] == ["numpy"]


@pytest.mark.parametrize("name", ["run_0p8_wls2.csv", "run_0p8_wls1.tdms"])
def test_info_without_the_parallel_extra_imports_no_scipy(name):
    # With dask installed, xarray imports dask.array (and with it scipy.sparse) on the first
    # Variable it builds; a default installation has no dask.
    result = run_cli(["info", str(runs_dir() / name)], block_dask=True)
    assert result["code"] == 0
    assert "samples" in result["out"]
    assert "matplotlib" not in result["modules"]
    assert "scipy" not in result["modules"]


FORK_WATCH = """
import contextlib, io, json, sys
from rigval.validation import beside
seen = []
group = beside.Standby.group
def watching(*args, **kwargs):
    seen.append([m for m in {watch!r} if m in sys.modules])
    return group(*args, **kwargs)
beside.Standby.group = watching
from rigval.validation.cli import main
with contextlib.redirect_stdout(io.StringIO()):
    code = main({argv!r})
print(json.dumps({{"code": code, "seen": seen}}))
"""


@pytest.mark.parametrize("command", [["validate"], ["identify", "--parameters", "A.mass"]])
def test_the_drawers_are_forked_before_the_pipeline_is_imported(command, tmp_path):
    # so that they import matplotlib on the core left idle while this process imports the
    # pipeline (watch: what was imported when they were forked)
    argv = [command[0], str(runs_dir() / "run_0p8_scene.toml"), "--out", str(tmp_path / "out"),
            *command[1:]]
    code = FORK_WATCH.format(argv=argv, watch=(*HEAVY, "rigval.validation.pipeline"))
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300, check=True)
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result["code"] == 0
    assert result["seen"] == [[]]  # one group of drawers, forked before any of them


def test_a_validation_never_imports_scipy_stats(tmp_path):
    # scipy.signal imports it for one function rigval never calls, and it is the largest
    # import of a run (rigval.processing.scipy_signal); the run's quantiles come from
    # scipy.special
    argv = ["validate", str(runs_dir() / "run_0p8_scene.toml"), "--out", str(tmp_path / "out")]
    result = run_cli(argv, block_dask=True, watch=("scipy.signal", "scipy.stats"))
    assert result["code"] == 0
    assert result["modules"] == ["scipy.signal"]
