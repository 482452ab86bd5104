"""One public-API style: every package lists __all__, resolves each name, and imports lazily."""

from __future__ import annotations

import importlib
import json
import subprocess
import sys

import pytest

PACKAGES = ("rigval.acquisition", "rigval.processing", "rigval.model", "rigval.validation",
            "rigval.sample_data")
HEAVY = ("numpy", "scipy", "xarray", "pandas", "matplotlib", "netCDF4", "nptdms")


@pytest.mark.parametrize("name", PACKAGES)
def test_every_public_name_resolves_and_is_listed(name: str) -> None:
    package = importlib.import_module(name)
    assert len(set(package.__all__)) == len(package.__all__)
    listed = set(dir(package))
    for public in package.__all__:
        assert public in listed, public
        assert getattr(package, public) is not None, public
    with pytest.raises(AttributeError, match="no attribute 'nothing_here'"):
        package.nothing_here  # noqa: B018


def test_importing_the_packages_imports_no_numeric_library() -> None:
    code = (f"import importlib, json, sys\nfor p in {PACKAGES!r}: importlib.import_module(p)\n"
            f"print(json.dumps([m for m in {HEAVY!r} if m in sys.modules]))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, check=True)
    assert json.loads(done.stdout.strip().splitlines()[-1]) == []
