import subprocess
import sys
from importlib.metadata import version

from rigval.validation.campaign import runs
from rigval.validation.report import predict_report, run_report
from rigval.validation.version import rigval_version


def test_one_version_lookup_for_every_writer() -> None:
    assert rigval_version() == version("rigval")  # the editable install has metadata
    # the campaign manifest, both reports and the command line use this one function
    assert runs._rigval_version is rigval_version
    assert run_report.rigval_version is rigval_version
    assert predict_report.rigval_version is rigval_version


def test_cli_prints_the_version() -> None:
    done = subprocess.run([sys.executable, "-m", "rigval.validation.cli", "--version"],
                          capture_output=True, text=True, check=True)
    assert done.stdout.strip() == f"rigval {version('rigval')}"
