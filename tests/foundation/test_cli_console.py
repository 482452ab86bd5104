"""The command line as a user meets it, run as a subprocess: verbosity after the subcommand,
-q, defaults and exit codes in --help, the exit code of a bug, one-line warnings, rigval docs."""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from rigval.sample_data import runs_dir
from rigval.validation.cli import COMMANDS, EXIT_BUG, build_parser

REPO = Path(__file__).resolve().parents[2]
CSV = runs_dir() / "run_0p8_wls2.csv"


def rigval(*args: str, cwd: Path | None = None,
           env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "rigval.validation.cli", *args],
                          capture_output=True, text=True, cwd=cwd, timeout=300,
                          env={**os.environ, **(env or {})})


def python(code: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=cwd,
                          timeout=300)


def test_verbosity_options_work_after_the_subcommand(tmp_path: Path) -> None:
    before = rigval("-v", "info", str(CSV), cwd=tmp_path)
    after = rigval("info", "-v", str(CSV), cwd=tmp_path)
    assert before.returncode == after.returncode == 0, after.stderr
    assert after.stdout == before.stdout and CSV.name in after.stdout
    # -v shows the INFO log line about the CSV's zone-less time stamps; without -v it is absent
    assert "INFO" in after.stderr and "INFO" in before.stderr
    assert "INFO" not in rigval("info", str(CSV), cwd=tmp_path).stderr


def test_quiet_prints_nothing_but_errors(tmp_path: Path) -> None:
    quiet = rigval("info", "-q", str(CSV), cwd=tmp_path)
    assert quiet.returncode == 0 and quiet.stdout == "" and quiet.stderr == ""
    missing = rigval("info", "-q", str(tmp_path / "nope.tdms"), cwd=tmp_path)
    assert missing.returncode == 2 and "nope.tdms" in missing.stderr and missing.stdout == ""


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


@pytest.mark.parametrize("name", [c.replace("_", "-") for c in COMMANDS])
def test_every_help_shows_defaults_and_exit_codes(name: str) -> None:
    sub = _subparsers(build_parser())[name]
    text = " ".join(sub.format_help().split())
    assert "Exit codes:" in text and f"{EXIT_BUG} internal error" in text
    for action in sub._actions:
        default = action.default
        if (action.option_strings and action.help and default not in (None, False, [])
                and default is not argparse.SUPPRESS):
            entry = " ".join(sub.formatter_class("x")._expand_help(action).split())
            assert "default" in entry and str(default) in entry, (name, action.dest, entry)


def test_simulate_rig_help_shows_speed_duration_seed_defaults() -> None:
    out = rigval("simulate-rig", "--help").stdout
    text = " ".join(out.split())
    for option, default in (("--speed SPEED", "1.0"), ("--duration DURATION", "20.0"),
                            ("--seed SEED", "1")):
        assert re.search(re.escape(option) + r" [^()]*\(default: " + re.escape(default) + r"\)",
                         text), option
    assert "Exit codes" in out


def test_info_timezone_shifts_local_csv_times_and_drops_the_note(tmp_path: Path) -> None:
    utc = rigval("info", "--json", str(CSV), cwd=tmp_path)
    berlin = rigval("info", "--json", "--timezone", "Europe/Berlin", str(CSV), cwd=tmp_path)
    assert utc.returncode == berlin.returncode == 0
    start = re.compile(r'"start_time": "([^"]+)"')
    a, b = start.search(utc.stdout).group(1), start.search(berlin.stdout).group(1)
    import numpy as np  # the run is in March: Berlin is UTC+1, so the UTC start is 1 h earlier

    shift = np.datetime64(a.rstrip("Z")) - np.datetime64(b.rstrip("Z"))
    assert shift == np.timedelta64(3600, "s")
    assert "taken as UTC" in utc.stdout and "taken as UTC" not in berlin.stdout
    bad = rigval("info", "--timezone", "Mars/Olympus", str(CSV), cwd=tmp_path)
    assert bad.returncode == 3 and "Mars/Olympus" in bad.stderr


BUG = ("import sys\n"
       "import rigval.validation.commands.docs as docs\n"
       "from rigval.validation.cli import main\n"
       "def broken():\n"
       "    return {'x': 1 / 0}\n"
       "docs.pages = broken\n"
       "sys.exit(main(sys.argv[1:] or ['docs']))\n")


def test_a_bug_exits_4_with_one_line_naming_the_traceback_file(tmp_path: Path) -> None:
    result = python(BUG, tmp_path)
    assert result.returncode == EXIT_BUG == 4
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "internal error" in lines[0] and "ZeroDivisionError" in lines[0]
    path = Path(re.search(r"full traceback in (\S+\.txt)", lines[0]).group(1))
    written = path.read_text()
    assert "Traceback (most recent call last)" in written and "in broken" in written
    path.unlink()


def test_a_bug_with_v_prints_the_traceback(tmp_path: Path) -> None:
    script = tmp_path / "bug.py"
    script.write_text(BUG)
    result = subprocess.run([sys.executable, str(script), "docs", "-v"], capture_output=True,
                            text=True, cwd=tmp_path, timeout=300)
    assert result.returncode == 4
    assert "Traceback (most recent call last)" in result.stderr and "in broken" in result.stderr
    Path(re.search(r"full traceback in (\S+\.txt)", result.stderr).group(1)).unlink()


def test_usage_and_data_errors_keep_their_codes(tmp_path: Path) -> None:
    assert rigval("info", cwd=tmp_path).returncode == 2  # no FILE: argparse usage error
    assert rigval("docs", "no-such-page", cwd=tmp_path).returncode == 2


WARN = ("import sys\n"
        "import rigval.validation.commands.docs as docs\n"
        "from rigval.acquisition.warn import warn_data\n"
        "from rigval.validation.cli import main\n"
        "from rigval.validation.console import run_context\n"
        "def noisy(args):\n"
        "    with run_context('run_0p8'):\n"
        "        warn_data('3 samples lost\\nin a gap', where={'stream': 'wls1', "
        "'channel': 'acc1'})\n"
        "    print('done')\n"
        "    return 0\n"
        "docs.run = noisy\n"
        "sys.exit(main(sys.argv[1:]))\n")


def test_a_warning_is_one_line_naming_run_stream_and_channel(tmp_path: Path) -> None:
    script = tmp_path / "warn.py"
    script.write_text(WARN)
    result = subprocess.run([sys.executable, str(script), "docs"], capture_output=True,
                            text=True, cwd=tmp_path, timeout=300)
    assert result.returncode == 0 and result.stdout == "done\n"
    assert result.stderr.splitlines() == [
        "rigval: warning: [run run_0p8] DataWarning: 3 samples lost in a gap (stream: wls1, "
        "channel: acc1)"]
    quiet = subprocess.run([sys.executable, str(script), "docs", "-q"], capture_output=True,
                           text=True, cwd=tmp_path, timeout=300)
    assert quiet.stdout == "" and quiet.stderr == ""


def test_docs_prints_the_shipped_page_and_error_hints_point_to_it(tmp_path: Path) -> None:
    page = rigval("docs", "scene", cwd=tmp_path)
    assert page.returncode == 0
    assert page.stdout == (REPO / "docs" / "scene.md").read_text(encoding="utf-8")
    listing = rigval("docs", cwd=tmp_path).stdout
    assert {line.split()[0] for line in listing.splitlines()} == {
        p.stem for p in (REPO / "docs").glob("*.md")}
    scene = tmp_path / "bad_scene.toml"
    scene.write_text('schema = "rigval-scene/1"\nno_such_key = 1\n')
    bad = rigval("validate", str(scene), "--out", str(tmp_path / "out"), cwd=tmp_path)
    assert bad.returncode == 2
    assert "docs/scene.md" in bad.stderr and "rigval docs scene" in bad.stderr


@pytest.mark.slow
def test_demo_quiet_prints_nothing_and_still_writes_the_reports(tmp_path: Path) -> None:
    result = rigval("demo", "-q", "--out", str(tmp_path / "demo"), cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert result.stdout == "" and result.stderr == ""
    assert (tmp_path / "demo" / "index.html").is_file()
    assert len(list((tmp_path / "demo").glob("*/report.html"))) >= 2
