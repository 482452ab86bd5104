"""After Ctrl-C, what fails is the interrupt's consequence: the command line exits 130, not 4."""

import subprocess
import sys

SCRIPT = """
import argparse, os, signal, sys, time
from rigval.validation import cli, console

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

class FakeParser(argparse.ArgumentParser):  # the subcommand without the real parser
    func = None
    def parse_args(self, argv=None, namespace=None):
        return argparse.Namespace(command="x", func=FakeParser.func, verbose=0, quiet=False)

cli.build_parser = FakeParser
for name, func in (("interrupted", command), ("bug", bug)):
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
