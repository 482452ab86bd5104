"""Fuzz the readers with damaged copies of real NI files and the shipped sample runs.

Each variant is one local edit of a source file: a truncation at a structural boundary (TDMS
lead-in, metadata and raw-data boundaries; text mid-line), byte flips in lead-in, metadata or
data, a zeroed block, a huge value count, a garbage tail, a mismatched ``.tdms_index`` file, or a
text edit (text cell, NaN row, footer, ragged row, BOM, UTF-16, mixed decimal separators).

Invariants checked for every variant (a failure is a *violation*):

1. only rigval errors (:class:`~rigval.acquisition.errors.RigvalError`) are raised;
2. no hang: each read runs under a per-variant time limit (``signal.setitimer``);
3. no allocation larger than the file justifies: the tracemalloc peak of the read stays below
   ``MEMORY_FACTOR * file size + MEMORY_CONSTANT`` (see there for the reasoning);
4. TDMS: every sample nptdms reads from the same bytes is returned with the same value, or the
   stream's loss is reported in a DataWarning; rigval never returns more than nptdms reads;
   text: fewer samples than the intact file only with a DataWarning;
5. never an empty result without a warning.

Usage: ``python tests/acquisition/fuzz_engine.py [--variants-per-file N] [--seed S] [--full]``;
prints the number of variants, outcomes and violations. The unit test
``tests/acquisition/test_fuzz.py`` runs a few hundred variants with this engine.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import random
import re
import signal
import struct
import sys
import tempfile
import time
import tracemalloc
import warnings
from collections import Counter
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from nptdms import TdmsFile

from rigval.acquisition import read
from rigval.acquisition.errors import DataWarning, RigvalError

#: Peak traced memory allowed per byte of input. A TDMS value of 1 or 2 bytes (uint8 lines,
#: int16 DAQmx raw data) becomes a float64 (8 bytes), read once by nptdms as raw and once scaled,
#: plus the time index: about 3 x 8 = 24 bytes per input byte at worst. A text cell of 4 bytes
#: ("0;1\n") becomes a Python str of about 50 bytes while pandas splits it, plus its float64:
#: about 15 per input byte. 64 leaves room for both and still flags any allocation driven by a
#: value count the file's bytes cannot hold (item 8 of issue 14 tried 656 TiB).
MEMORY_FACTOR = 64
#: Fixed allowance in bytes: xarray/pandas objects, nptdms metadata objects, warning texts.
MEMORY_CONSTANT = 16 << 20
#: Seconds allowed per read (the largest sample run reads in about 4 s under tracemalloc).
TIME_LIMIT_S = 30.0

TDMS_LEAD_IN = 28


class _Timeout(BaseException):  # a BaseException: no reader may swallow it
    """Raised by the interval timer when a read exceeds its time limit."""


@dataclass
class Variant:
    """One damaged copy of a source file."""

    source: Path
    kind: str
    data: bytes
    index: bytes | None = None  # a .tdms_index to put next to the copy


@dataclass
class Result:
    """What one variant did."""

    variant: Variant
    outcome: str  # "read", "rigval error", or "violation"
    violations: list[str] = field(default_factory=list)
    peak: int = 0  # tracemalloc peak of the read, bytes


# --- sources ----------------------------------------------------------------------------------

def sources(realdata: Path | None, full: bool) -> list[Path]:
    """Return the real NI files and the shipped sample-run data files."""
    from rigval.sample_data import runs_dir

    found: list[Path] = []
    if realdata is not None and realdata.is_dir():
        found += sorted(p for p in realdata.rglob("*") if p.suffix in (".tdms", ".lvm"))
    runs = sorted(p for p in runs_dir().iterdir() if p.suffix in (".tdms", ".csv"))
    return found + (runs if full else [p for p in runs if "0p8" in p.name])


def _text_base(path: Path, full: bool) -> bytes:
    """Return a text file's bytes; in the normal run the sample CSVs are cut to 400 rows."""
    data = path.read_bytes()
    if full or path.suffix != ".csv" or len(data) < 100_000:
        return data
    return b"".join(data.splitlines(keepends=True)[:403])


# --- TDMS structure ---------------------------------------------------------------------------

def tdms_boundaries(data: bytes) -> list[tuple[str, int, int]]:
    """Return ``(part, start, end)`` for each lead-in, metadata and raw-data block.

    Written independently of the reader: only the lead-in fields are decoded.
    """
    parts: list[tuple[str, int, int]] = []
    pos = 0
    while pos + TDMS_LEAD_IN <= len(data) and data[pos:pos + 4] == b"TDSm":
        toc = struct.unpack_from("<i", data, pos + 4)[0]
        endian = ">" if toc & (1 << 6) else "<"
        next_offset, raw_offset = struct.unpack_from(endian + "QQ", data, pos + 12)
        meta_end = min(pos + TDMS_LEAD_IN + raw_offset, len(data))
        end = min(pos + TDMS_LEAD_IN + next_offset, len(data))
        parts += [("lead-in", pos, pos + TDMS_LEAD_IN), ("metadata", pos + TDMS_LEAD_IN, meta_end),
                  ("data", meta_end, end)]
        if end <= pos:
            break
        pos = end
    return parts


def tdms_variants(path: Path, rng: random.Random, count: int) -> Iterator[Variant]:
    """Yield ``count`` damaged copies of a TDMS file (all boundary truncations come first)."""
    data = path.read_bytes()
    parts = tdms_boundaries(data)
    cuts = sorted({c for _, a, b in parts for c in (a, a + 1, a + 4, a + 12, b - 1, b + 3)
                   if 0 < c < len(data)})
    made = 0
    for cut in rng.sample(cuts, min(len(cuts), max(1, count // 3))):
        yield Variant(path, f"truncate at byte {cut}", data[:cut])
        made += 1
    others = [p for p in sorted(path.parent.glob("*.tdms_index")) if p.stem != path.stem]
    while made < count:
        made += 1
        kind = rng.choice(["flip", "flip", "zero", "tail", "count", "index", "toc", "offset",
                           "property", "type"])
        part, start, end = rng.choice([p for p in parts if p[2] > p[1]] or [("file", 0, 1)])
        buffer = bytearray(data)
        if kind == "flip":
            at = rng.randrange(start, end)
            buffer[at] ^= 1 << rng.randrange(8)
            yield Variant(path, f"bit flip in {part} at byte {at}", bytes(buffer))
        elif kind == "zero":
            at = rng.randrange(start, end)
            width = rng.randint(1, 64)
            buffer[at:at + width] = bytes(len(buffer[at:at + width]))
            yield Variant(path, f"{width} zero bytes in {part} at byte {at}", bytes(buffer))
        elif kind == "tail":
            tail = rng.randbytes(rng.randint(1, 200))
            yield Variant(path, f"{len(tail)} garbage bytes appended", data + tail)
        elif kind == "count":  # a u32/u64 in the metadata set to a huge value
            metas = [p for p in parts if p[0] == "metadata" and p[2] - p[1] >= 8]
            if not metas:
                made -= 1
                continue
            _, start, end = rng.choice(metas)
            at = rng.randrange(start, end - 7)
            struct.pack_into("<Q", buffer, at, rng.choice([2**31, 2**50, 2**63 - 1]))
            yield Variant(path, f"huge number written in metadata at byte {at}", bytes(buffer))
        elif kind == "toc":  # one ToC bit of one segment
            leads = [p for p in parts if p[0] == "lead-in"]
            at = rng.choice(leads)[1] + 4
            bit = rng.choice([1, 2, 3, 5, 6, 7])
            buffer[at] ^= 1 << bit
            yield Variant(path, f"ToC bit {bit} flipped at byte {at}", bytes(buffer))
        elif kind == "offset":  # next-segment or raw-data offset moved by a few bytes
            leads = [p for p in parts if p[0] == "lead-in"]
            at = rng.choice(leads)[1] + rng.choice([12, 20])
            endian = "<"
            value = struct.unpack_from(endian + "Q", buffer, at)[0]
            struct.pack_into(endian + "Q", buffer, at, max(0, value + rng.choice(
                [-16, -8, -2, -1, 1, 2, 8, 16, 1 << 20])) & (2**64 - 1))
            yield Variant(path, f"segment offset changed at byte {at}", bytes(buffer))
        elif kind == "property":  # a time property set to an odd value
            name = rng.choice([b"wf_increment", b"wf_start_offset", b"wf_samples"])
            hits = [m.end() for m in re.finditer(re.escape(name), data)]
            if not hits:
                made -= 1
                continue
            at = rng.choice(hits) + 4  # after the name: u32 type, then the value
            if at + 8 > len(buffer):
                made -= 1
                continue
            value = rng.choice([0.0, -1.0, float("nan"), float("inf"), 1e300, 5e-324])
            big = data[at - 4:at] == b"\x00\x00\x00\x0a"
            struct.pack_into(">d" if big else "<d", buffer, at, value)
            yield Variant(path, f"{name.decode()} set to {value} at byte {at}", bytes(buffer))
        elif kind == "type":  # a raw-data index's data type changed
            metas = [p for p in parts if p[0] == "metadata" and p[2] - p[1] >= 16]
            hits = [a + m.start() for _, a, b in metas
                    for m in re.finditer(rb"\x14\x00\x00\x00", data[a:b])]
            if not hits:
                made -= 1
                continue
            at = min(rng.choice(hits) + 4, len(buffer) - 4)
            struct.pack_into("<I", buffer, at, rng.choice([0, 1, 3, 10, 0x20, 0x44, 0x99]))
            yield Variant(path, f"raw data type changed at byte {at}", bytes(buffer))
        else:
            if not others:
                made -= 1
                continue
            index = rng.choice(others)
            yield Variant(path, f"mismatched index {index.name}", data, index.read_bytes())


# --- text -------------------------------------------------------------------------------------

def text_variants(path: Path, base: bytes, rng: random.Random, count: int) -> Iterator[Variant]:
    """Yield ``count`` locally edited copies of a CSV or LVM file."""
    text = base.decode("utf-8-sig")
    lines = text.splitlines(keepends=True)
    numeric = [k for k, ln in enumerate(lines) if re.match(r"^\s*[-+]?[\d.,]", ln)]
    if not numeric:
        return
    for _ in range(count):
        kind = rng.choice(["cell", "nan", "footer", "ragged", "bom", "utf16", "decimal", "cut",
                           "tail"])
        edited = list(lines)
        k = rng.choice(numeric)
        sep = "\t" if "\t" in lines[k] else ";"
        cells = lines[k].rstrip("\r\n").split(sep)
        if kind == "cell":
            cells[rng.randrange(len(cells))] = rng.choice(["abc", "#NV", "--", "1.2.3"])
            edited[k] = sep.join(cells) + "\n"
        elif kind == "nan":
            edited.insert(k, sep.join(["NaN"] * len(cells)) + "\n")
        elif kind == "footer":
            edited += ["Statistics\n", sep.join(["Mean", *cells[1:]]) + "\n"]
        elif kind == "ragged":
            cut = rng.randint(1, max(1, len(cells) - 1))
            edited[k] = sep.join(cells[:cut] if rng.random() < 0.5 else [*cells, "7"]) + "\n"
        elif kind == "decimal":
            swap = (",", ".") if "," in lines[k] and sep != "," else (".", ",")
            edited[k] = lines[k].replace(*swap)
        joined = "".join(edited)
        if kind == "bom":
            data = b"\xef\xbb\xbf" + base.removeprefix(b"\xef\xbb\xbf")
        elif kind == "utf16":
            data = joined.encode("utf-16")
        elif kind == "cut":  # mid-line only: a cut at a line end leaves a complete-looking file
            line = rng.choice(numeric[1:] or numeric)
            offset = len("".join(lines[:line]).encode())
            width = len(lines[line].rstrip("\r\n").encode())
            data = base[:offset + rng.randint(1, max(1, width - 1))]
        elif kind == "tail":
            data = base + rng.randbytes(rng.randint(1, 100))
        else:
            data = joined.encode()
        yield Variant(path, f"text edit {kind} near line {k + 1}", data)


# --- checks -----------------------------------------------------------------------------------

@contextlib.contextmanager
def time_limit(seconds: float) -> Iterator[None]:
    """Raise :class:`_Timeout` in the main thread after ``seconds``."""
    def alarm(signum: int, frame: object) -> None:
        raise _Timeout

    previous = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def _nptdms_values(data: bytes) -> dict[str, np.ndarray] | None:
    """Return object path -> values nptdms reads from ``data`` (no index file), or None."""
    out: dict[str, np.ndarray] = {}
    try:
        with time_limit(TIME_LIMIT_S), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            tdms = TdmsFile.open(io.BytesIO(data))
            for group in tdms.groups():
                for channel in group.channels():
                    # what nptdms "can read": a length the bytes can hold (else it allocates
                    # whatever the damaged metadata claims)
                    if len(channel) > 8 * len(data):
                        continue
                    values = channel.read_data()
                    if values.dtype.kind in "iufb":
                        out[channel.path] = values
    except (Exception, _Timeout):
        return out or None
    return out


def _stream_texts(streams: dict) -> dict[str, tuple[str, np.ndarray]]:
    """Return source channel -> (stream name, values)."""
    return {ds[v].attrs["source_channel"]: (name, ds[v].values)
            for name, ds in streams.items() for v in ds.data_vars
            if v not in ("valid", "segment")}


def run_variant(variant: Variant, reference: dict[str, int] | None = None) -> Result:
    """Read one variant and check the invariants."""
    suffix = variant.source.suffix
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"variant{suffix}"
        path.write_bytes(variant.data)
        if variant.index is not None:
            Path(str(path) + "_index").write_bytes(variant.index)
        size = max(len(variant.data), 1)
        caught: list[warnings.WarningMessage] = []
        error: BaseException | None = None
        streams: dict = {}
        tracemalloc.start()
        try:
            with time_limit(TIME_LIMIT_S), warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                streams = read(path, checksum=False)
        except (Exception, _Timeout) as raised:
            error = raised
        finally:
            peak = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
    texts = [str(w.message) for w in caught if issubclass(w.category, DataWarning)]
    result = Result(variant, "read" if error is None else "rigval error", peak=peak)
    bad = result.violations
    if isinstance(error, _Timeout):
        bad.append(f"hang: no answer within {TIME_LIMIT_S} s")
    elif error is not None and not isinstance(error, RigvalError):
        bad.append(f"non-rigval error {type(error).__name__}: {str(error)[:200]}")
    limit = MEMORY_FACTOR * size + MEMORY_CONSTANT
    if peak > limit:
        bad.append(f"allocation: peak {peak} bytes > {limit} allowed for {size} bytes")
    if error is None and not streams and not texts:
        bad.append("empty result without a warning")
    if error is None and suffix == ".tdms":
        bad += _compare_with_nptdms(variant.data, streams, texts)
    elif error is None and reference is not None:
        got = {name: ds.sizes["time"] for name, ds in streams.items()}
        short = {k: (got.get(k, 0), n) for k, n in reference.items() if got.get(k, 0) < n}
        if short and not texts:
            bad.append(f"text samples lost without a warning: {short}")
    if bad:
        result.outcome = "violation"
    return result


def _compare_with_nptdms(data: bytes, streams: dict, texts: list[str]) -> list[str]:
    """Check rigval's values against nptdms' for every channel nptdms reads."""
    expected = _nptdms_values(data)
    if expected is None:
        return []
    got = _stream_texts(streams)
    bad = []
    for path, values in expected.items():
        if "Decimated Data_Level" in path or values.size == 0:
            continue  # skipped by design (include_decimated=False), or nothing to lose
        if path not in got:
            if not texts:
                bad.append(f"lost silently: {path}: {values.size} values nptdms reads are "
                           "missing, no warning")
            continue
        stream, mine = got[path]
        if mine.size > values.size:
            bad.append(f"more than nptdms: {path}: {mine.size} values returned, nptdms "
                       f"reads {values.size}")
            continue
        if not np.array_equal(mine.astype(float), values[:mine.size].astype(float),
                              equal_nan=True):
            bad.append(f"values differ: {path}: not the values nptdms reads")
        if mine.size < values.size and not any(stream in t or "damaged" in t for t in texts):
            bad.append(f"lost silently: {path}: {mine.size} of {values.size} values returned, "
                       f"no warning naming stream {stream!r}")
    return bad


def _reference_sizes(path: Path, data: bytes) -> dict[str, int] | None:
    """Return stream -> samples of an intact text file (under the variant's file name)."""
    with tempfile.TemporaryDirectory() as folder:
        copy = Path(folder) / f"variant{path.suffix}"
        copy.write_bytes(data)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                return {k: ds.sizes["time"] for k, ds in read(copy, checksum=False).items()}
            except RigvalError:
                return None


def fuzz(files: list[Path], per_file: int, seed: int, full: bool = False,
         progress: Callable[[Result], None] | None = None) -> list[Result]:
    """Run ``per_file`` variants of every file; return every result."""
    results = []
    for k, path in enumerate(files):
        rng = random.Random(f"{seed}:{k}:{path.name}")
        if path.suffix == ".tdms":
            count = per_file if path.stat().st_size < 300_000 else max(1, per_file // 10)
            variants = tdms_variants(path, rng, count)
            reference = None
        else:
            base = _text_base(path, full)
            variants = text_variants(path, base, rng, per_file)
            reference = _reference_sizes(path, base)
        for variant in variants:
            result = run_variant(variant, reference)
            results.append(result)
            if progress is not None:
                progress(result)
    return results


def main(argv: list[str] | None = None) -> int:
    """Run the fuzzer and print the counts."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--variants-per-file", type=int, default=200)
    parser.add_argument("--seed", type=int, default=14)
    parser.add_argument("--full", action="store_true", help="every sample run, whole CSVs")
    parser.add_argument("--realdata", type=Path,
                        default=Path(os.environ.get("RIGVAL_SHARED", Path(__file__).resolve()
                                                    .parents[3] / "shared")) / "realdata")
    args = parser.parse_args(argv)
    files = sources(args.realdata, args.full)
    started = time.perf_counter()

    def progress(result: Result) -> None:
        for text in result.violations:
            print(f"VIOLATION {result.variant.source.name}: {result.variant.kind}: {text}")

    results = fuzz(files, args.variants_per_file, args.seed, args.full, progress)
    outcomes = Counter(r.outcome for r in results)
    kinds = Counter(v.split(":")[0] for r in results for v in r.violations)
    print(f"files: {len(files)}, variants: {len(results)}, seed {args.seed}, "
          f"{time.perf_counter() - started:.1f} s")
    print(f"outcomes: {dict(outcomes)}")
    def used(r: Result) -> float:
        return r.peak / (MEMORY_FACTOR * len(r.variant.data) + MEMORY_CONSTANT)

    worst = max(results, key=used)
    big = [r for r in results if len(r.variant.data) > 100_000]
    ratio = max((r.peak / len(r.variant.data) for r in big), default=float("nan"))
    print(f"allocation: at most {used(worst):.1%} of the limit ({worst.peak} bytes for a "
          f"{len(worst.variant.data)}-byte {worst.variant.source.name}); files > 100 kB peak at "
          f"{ratio:.1f} x their size")
    print(f"violations: {sum(len(r.violations) for r in results)} {dict(kinds)}")
    return 1 if kinds else 0


if __name__ == "__main__":
    sys.exit(main())
