"""After Ctrl-C, what fails is the interrupt's consequence: the command line exits 130, not 4.

A Ctrl-C whose KeyboardInterrupt something swallowed (Dask's start-up, an import's callback)
still ends the command with its one line.
"""

import subprocess
import sys

SCRIPT = """
import argparse, os, signal, sys, time
from rigval.validation import cli, console

# as a terminal's foreground process has it, whatever this test's runner blocked or ignored
signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
signal.signal(signal.SIGINT, signal.default_int_handler)

def command(args):
    with console.interrupt_quietly():
        try:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(5)
        except KeyboardInterrupt:  # swallowed, as Dask's start-up can do, then a follow-on error
            raise RuntimeError("Nanny failed to start.") from None

def bug(args):
    with console.interrupt_quietly():
        raise RuntimeError("a real bug")

def early(args):
    try:
        os.kill(os.getpid(), signal.SIGINT)  # while the command's modules are imported, say
        time.sleep(5)
    except KeyboardInterrupt:  # swallowed before the command's own block (an import's callback)
        pass
    with console.interrupt_quietly():  # stops as it starts
        print("the block ran", file=sys.__stdout__, flush=True)

class FakeParser(argparse.ArgumentParser):  # the subcommand without the real parser
    func = None
    def parse_args(self, argv=None, namespace=None):
        return argparse.Namespace(command="x", func=FakeParser.func, verbose=0, quiet=False)

cli.build_parser = FakeParser
for name, func in (("interrupted", command), ("bug", bug), ("early", early)):
    FakeParser.func = func
    code = cli.main([])
    print(name, code, console.was_interrupted(), file=sys.__stdout__, flush=True)
"""


def test_an_error_after_ctrl_c_exits_as_interrupted_and_a_bug_still_as_a_bug() -> None:
    result = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True,
                            timeout=120)
    lines = result.stdout.split("\n")
    assert "interrupted 130 True" in lines, (result.stdout, result.stderr)
    assert "bug 4 False" in lines, (result.stdout, result.stderr)
    assert "early 130 True" in lines, (result.stdout, result.stderr)
    assert "the block ran" not in lines


def test_ctrl_c_at_the_start_of_a_command_prints_one_line() -> None:
    """An interrupt whose KeyboardInterrupt is swallowed: one line on stderr, nothing after."""
    script = SCRIPT.split("cli.build_parser = FakeParser")[0] + (
        "cli.build_parser = FakeParser\nFakeParser.func = early\n"
        "sys.exit(cli.main([]))\n")
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 130, result.stderr
    assert result.stderr.splitlines() == ["rigval: interrupted"], result.stderr
    assert "the block ran" not in result.stdout
