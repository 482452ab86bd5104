"""A command's SciPy imports without SciPy's array API docstring notes (start-up time).

SciPy 1.15 and later decorate their public functions with ``xp_capabilities``, which parses
each function's docstring (numpydoc) as its module is imported and writes it back with a table
of the array API backends the function supports: about 500 functions for the imports of a
validation, 0.3 s of a cold command's 1.0 s of imports on this project's machine
(docs/performance.md). A command line process never shows those docstrings, so while a command
runs (:func:`rigval.validation.cli.main`), the parser is stood in for by one that keeps each
docstring as written (:class:`_DocstringAsWritten`); each function, its behaviour and SciPy's
table of its capabilities are unchanged.

The stand-in is put in place when SciPy's module ``scipy._lib._array_api`` is loaded (an import
hook: a command that never imports SciPy pays nothing) or at once where it is loaded already,
and taken away when the command returns: ``import rigval`` in a script never sees it. A SciPy
without that module, or whose module binds no ``FunctionDoc``, imports as it is.
"""

from __future__ import annotations

import contextlib
import importlib.abc
import importlib.machinery
import sys
import types
from collections import defaultdict
from collections.abc import Callable, Iterator, Sequence
from typing import Any

__all__ = ["docstrings_as_written"]

#: The SciPy module whose ``xp_capabilities`` decorator parses the docstrings.
_MODULE = "scipy._lib._array_api"
#: The parser's name in it.
_PARSER = "FunctionDoc"


class _DocstringAsWritten:
    """Stands for SciPy's ``FunctionDoc`` in ``xp_capabilities``: keeps the docstring.

    The decorator appends its note to the ``Notes`` section and writes back the text without
    its first line (the signature line ``FunctionDoc`` puts first); here the sections take
    the note and drop it, and the text is an empty first line and the docstring. Any other
    use, which a later SciPy might make, is the real parser's.
    """

    def __init__(self, function: Any, real: Callable[[Any], Any]) -> None:
        self._function = function
        self._real = real
        self._sections: defaultdict[str, list[str]] = defaultdict(list)

    def __getitem__(self, section: str) -> list[str]:
        return self._sections[section]

    def __str__(self) -> str:
        return "\n" + (getattr(self._function, "__doc__", None) or "")

    def __getattr__(self, name: str) -> Any:
        return getattr(self._real(self._function), name)


def _stand_in(module: types.ModuleType) -> Callable[[], None] | None:
    """Put the stand-in in ``module``; return what puts its parser back (None: none there)."""
    real = getattr(module, _PARSER, None)
    if not isinstance(real, type):
        return None

    def parser(function: Any) -> _DocstringAsWritten:
        return _DocstringAsWritten(function, real)

    setattr(module, _PARSER, parser)

    def put_back() -> None:
        if getattr(module, _PARSER, None) is parser:
            setattr(module, _PARSER, real)

    return put_back


class _Loader(importlib.abc.Loader):
    """SciPy's loader of the module, putting the stand-in in once the module is executed."""

    def __init__(self, loader: importlib.abc.Loader, put_backs: list[Callable[[], None]]
                 ) -> None:
        self._loader = loader
        self._put_backs = put_backs

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> types.ModuleType | None:
        return self._loader.create_module(spec)

    def exec_module(self, module: types.ModuleType) -> None:
        # SciPy's loader from here on: inspect and tracebacks read the source through it, and
        # a later importlib.reload executes the module as SciPy's import does
        module.__loader__ = self._loader
        if module.__spec__ is not None:
            module.__spec__.loader = self._loader
        self._loader.exec_module(module)
        put_back = _stand_in(module)
        if put_back is not None:
            self._put_backs.append(put_back)


class _Hook(importlib.abc.MetaPathFinder):
    """Finds ``scipy._lib._array_api`` as the path finder does, with :class:`_Loader`."""

    def __init__(self) -> None:
        self.put_backs: list[Callable[[], None]] = []

    def find_spec(self, fullname: str, path: Sequence[str] | None,
                  target: types.ModuleType | None = None
                  ) -> importlib.machinery.ModuleSpec | None:
        if fullname != _MODULE:
            return None
        spec = importlib.machinery.PathFinder.find_spec(fullname, path, target)
        if spec is None or spec.loader is None:
            return spec
        spec.loader = _Loader(spec.loader, self.put_backs)
        return spec


@contextlib.contextmanager
def docstrings_as_written() -> Iterator[None]:
    """Import SciPy inside the block with its docstrings as written (see the module).

    Each SciPy function imported inside keeps its docstring without the array API note; SciPy's
    parser is put back on leaving, also on an error.
    """
    hook = _Hook()
    loaded = sys.modules.get(_MODULE)
    if loaded is not None:
        put_back = _stand_in(loaded)
        if put_back is not None:
            hook.put_backs.append(put_back)
    else:
        sys.meta_path.insert(0, hook)
    try:
        yield
    finally:
        with contextlib.suppress(ValueError):
            sys.meta_path.remove(hook)
        for put_back in hook.put_backs:
            put_back()
