"""SciPy imported by a command keeps its docstrings as written, and nothing else changes.

The checks that import SciPy for the first time run in fresh interpreters (this one has it
imported); the expectation is the docstring in SciPy's source, read with :mod:`ast`, and the
note SciPy adds without the stand-in.
"""

import ast
import importlib
import inspect
import sys

import numpy as np
import pytest

from rigval.validation import cli, scipy_docstrings
from rigval.validation.scipy_docstrings import docstrings_as_written
from tests.validation.fresh_process import run_in_a_fresh_process

NOTE = "Array API Standard Support"


def _source_docstring(function):
    """The docstring as written in the function's source file."""
    module = ast.parse(inspect.getsource(sys.modules[function.__module__]))
    found = [node for node in ast.walk(module)
             if isinstance(node, ast.FunctionDef) and node.name == function.__name__]
    return ast.get_docstring(found[0], clean=False)


def _filtered_once():
    """sosfiltfilt of a step, the values a caller gets."""
    from scipy.signal import butter, sosfiltfilt

    return sosfiltfilt(butter(4, 0.1, output="sos"), np.r_[np.zeros(50), np.ones(50)])


def check_imported_inside():
    """Fresh process: SciPy first imported inside the block (the import hook's case)."""
    assert "scipy" not in sys.modules
    hooks = list(sys.meta_path)
    with docstrings_as_written():
        import scipy.signal
    from scipy._lib import _array_api, _docscrape

    function = scipy.signal.sosfiltfilt
    assert NOTE not in function.__doc__
    assert function.__doc__ == _source_docstring(function).lstrip(" \n")
    assert sys.meta_path == hooks  # the hook is gone
    assert _array_api.FunctionDoc is _docscrape.FunctionDoc  # SciPy's parser is back
    assert _array_api.__loader__.get_source(_array_api.__name__)  # the real loader's source
    assert _array_api.__spec__.loader is _array_api.__loader__  # a reload is SciPy's own
    assert np.isfinite(_filtered_once()).all()
    # a SciPy module imported afterwards (scipy.signal does not import it) gets SciPy's note
    import scipy.cluster.vq

    assert NOTE in scipy.cluster.vq.kmeans.__doc__


def check_imported_outside():
    """Fresh process: the same import without the block has SciPy's note (the expectation)."""
    import scipy.signal

    assert NOTE in scipy.signal.sosfiltfilt.__doc__


def check_cli_imports_inside(out):
    """Fresh process: a command's first SciPy import (validating a shipped run) is inside."""
    from rigval.sample_data import runs_dir

    assert "scipy" not in sys.modules
    assert cli.main(["-q", "validate", str(runs_dir() / "run_0p8_scene.toml"), "--out", out]) == 0
    import scipy.signal

    assert NOTE not in scipy.signal.sosfiltfilt.__doc__


@pytest.mark.parametrize("check", ["check_imported_inside", "check_imported_outside"])
def test_fresh_import(check):
    run_in_a_fresh_process("test_scipy_docstrings", check, timeout_s=120)


def test_fresh_command(tmp_path):
    run_in_a_fresh_process("test_scipy_docstrings", "check_cli_imports_inside", timeout_s=120,
                           args=(str(tmp_path / "out"),))


def test_loaded_scipy_parser_stood_in_and_put_back_on_error():
    _array_api = importlib.import_module("scipy._lib._array_api")
    real = _array_api.FunctionDoc
    with pytest.raises(RuntimeError, match="inside"), docstrings_as_written():
        stand_in = _array_api.FunctionDoc
        assert stand_in is not real
        doc = stand_in(_filtered_once)
        doc["Notes"].append("a note")
        assert str(doc).split("\n", 1)[1] == _filtered_once.__doc__  # as the decorator reads
        raise RuntimeError("inside")
    assert _array_api.FunctionDoc is real
    assert scipy_docstrings._Hook not in {type(hook) for hook in sys.meta_path}


def test_stand_in_hands_other_uses_to_the_real_parser():
    _docscrape = importlib.import_module("scipy._lib._docscrape")
    doc = scipy_docstrings._DocstringAsWritten(_filtered_once, _docscrape.FunctionDoc)
    real = _docscrape.FunctionDoc(_filtered_once)
    assert doc.get_func() == real.get_func()


def test_main_runs_the_command_inside(monkeypatch):
    entered = []

    class Recording:
        def __enter__(self):
            entered.append("in")

        def __exit__(self, *exc):
            entered.append("out")

    monkeypatch.setattr(scipy_docstrings, "docstrings_as_written", Recording)
    assert cli.main(["--version"]) == 0
    assert entered == ["in", "out"]
