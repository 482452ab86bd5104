"""Fuzz suite of the readers: damaged copies of real NI files and of the shipped sample runs.

The mutations, invariants and limits are those of the engine ``fuzz_engine.py`` beside this file
(also a command for long campaigns: ``python tests/acquisition/fuzz_engine.py --help``): only
rigval errors, no hang, no allocation beyond a stated multiple of the file size, every sample
nptdms reads returned with its value or its loss reported in a DataWarning, never an empty result
without a warning. The normal
run uses a few hundred seeded variants; ``-m slow`` runs thousands.
"""

from __future__ import annotations

import importlib.util
import sys
from collections import Counter
from pathlib import Path
from types import ModuleType

import pytest

ENGINE = Path(__file__).resolve().with_name("fuzz_engine.py")


def _engine() -> ModuleType:
    spec = importlib.util.spec_from_file_location("fuzz_readers", ENGINE)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("fuzz_readers", module)  # dataclasses look their module up there
    spec.loader.exec_module(sys.modules["fuzz_readers"])
    return sys.modules["fuzz_readers"]


def _check(results: list, minimum: int) -> None:
    violations = [f"{r.variant.source.name}: {r.variant.kind}: {v}"
                  for r in results for v in r.violations]
    outcomes = Counter(r.outcome for r in results)
    print(f"{len(results)} variants, outcomes {dict(outcomes)}, {len(violations)} violations")
    assert len(results) >= minimum  # the mutations really ran
    assert not violations, "\n".join(violations[:20])


def _real_files(realdata: Path) -> list[Path]:
    return sorted(p for p in realdata.rglob("*") if p.suffix in (".tdms", ".lvm"))


def test_fuzz_real_ni_files(realdata_dir: Path) -> None:
    engine = _engine()
    files = _real_files(realdata_dir)
    assert len(files) >= 11
    _check(engine.fuzz(files, per_file=20, seed=14), minimum=200)


def test_fuzz_sample_runs() -> None:
    engine = _engine()
    files = engine.sources(None, full=False)
    assert {p.suffix for p in files} == {".tdms", ".csv"}
    _check(engine.fuzz(files, per_file=20, seed=14), minimum=20)


@pytest.mark.slow
def test_fuzz_thousands_of_variants(realdata_dir: Path) -> None:
    """About 2200 variants (a minute); the benchmark script runs the whole sample runs too."""
    engine = _engine()
    _check(engine.fuzz(_real_files(realdata_dir), per_file=200, seed=2), minimum=2000)


def test_the_fuzzer_sees_a_violation(tmp_path: Path) -> None:
    """The checks can fail: a hand-made loss without a warning is reported."""
    engine = _engine()
    csv = tmp_path / "run.csv"
    lines = ["time;a\n"] + [f"{k};{k * 0.5}\n" for k in range(10)]
    csv.write_text("".join(lines))
    cut = "".join(lines[:-2]).encode()  # two rows removed at a line end: undetectable
    variant = engine.Variant(csv, "rows removed at a line end", cut)
    result = engine.run_variant(variant, reference={"variant": 10})
    assert result.violations and "lost without a warning" in result.violations[0]
