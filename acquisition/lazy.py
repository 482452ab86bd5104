"""The one public-API style of rigval's packages: ``__all__`` and names imported on first use.

Each package ``__init__`` lists its public names in ``__all__`` and maps each to the module that
defines it; :func:`lazy_exports` returns the module-level ``__getattr__`` (PEP 562) that imports
that module on first access and the ``__dir__`` that lists the lazy names too. Importing a
package therefore costs nothing until a name is used, so that ``rigval --help`` and
``import rigval.model.errors`` stay light.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from importlib import import_module
from typing import Any

__all__ = ["lazy_exports"]


def lazy_exports(package: str, names: Mapping[str, str], namespace: dict[str, Any]
                 ) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """Return ``(__getattr__, __dir__)`` for a package whose names are imported on first use.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    names : mapping of str to str
        Public name -> submodule defining it (relative to the package); a name equal to its
        submodule's name is the submodule itself.
    namespace : dict
        The package's ``globals()``; an imported name is stored there, so the next access is a
        plain attribute lookup.
    """

    def __getattr__(name: str) -> Any:
        if name not in names:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        module = import_module(f"{package}.{names[name]}")
        value = module if names[name] == name else getattr(module, name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(names))

    return __getattr__, __dir__
