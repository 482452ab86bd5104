"""``rigval bench [--quick] --out DIR``: what each processing and model choice costs and gains.

Runs the sweeps of :mod:`rigval.validation.bench.core` on synthetic cases with known truth, writes
``bench.csv``, ``bench.md`` and one ``bench_<stage>.png`` per stage (time against error) into
``DIR``; prints the Markdown table (and, with ``--compare CSV``, each row's error and CPU time
against an earlier run's ``bench.csv``). Exit code 0 when every error is within its stated bound,
1 otherwise. ``--quick`` (small cases, fewer choices) takes well under a minute; the full run a
few minutes on 2 cores. Run it on an otherwise idle machine for figures worth quoting.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import Any

from rigval.validation.commands.common import add_command, add_out_option

__all__ = ["add_parser", "run"]


def add_parser(subparsers: Any) -> None:
    """Register the ``bench`` subcommand."""
    from rigval.validation.bench.rows import STAGES

    parser = add_command(
        subparsers, run, "bench",
        help="measure speed against error of the main choices (tables and plots)",
        description="Sweep each stage's main choices (model tolerance and evaluation points, "
                    "alignment events and pulse quality, angle resampling, drive-angle "
                    "derivatives, readers) on synthetic cases with known truth; write a CSV and "
                    "Markdown table and plots of time against error.",
        exit_codes="0 every error within its stated bound, 1 a bound exceeded, "
                   "2 usage error.")
    add_out_option(parser)
    parser.add_argument("--quick", action="store_true",
                        help="small cases and fewer choices (well under a minute)")
    parser.add_argument("--stage", dest="stages", action="append", choices=STAGES,
                        help="run only this stage (repeatable; default: all)")
    parser.add_argument("--long", action="store_true",
                        help="instead of the sweeps: write and validate virtual-rig runs of "
                             "20, 200, 2000, 3600 and 14400 s (--quick: 20 and 200 s) and "
                             "report each validation's wall and CPU time and peak memory (about "
                             "4 minutes up to 3600 s on an idle 2-core machine, the 14400 s run "
                             "about four times the 3600 s one's; docs/performance.md)")
    parser.add_argument("--durations", type=lambda text: [float(v) for v in text.split(",")],
                        metavar="S,S,...", help="with --long: these record lengths in s")
    parser.add_argument("--compare", type=Path, metavar="CSV",
                        help="an earlier bench.csv: print this run's errors and CPU times "
                             "against it")


def run(args: argparse.Namespace) -> int:
    """Run the sweeps, write the files and print the table; return the exit code."""
    from rigval.validation.bench.core import STAGES, machine_note, run_bench
    from rigval.validation.bench.long_cases import DURATIONS_S, QUICK_DURATIONS_S, long_rows
    from rigval.validation.bench.report import (
        closing_line,
        compare_text,
        markdown_table,
        read_csv,
        write_outputs,
    )

    reference = read_csv(args.compare) if args.compare else None  # fail before the long run
    durations = args.durations or (QUICK_DURATIONS_S if args.quick else DURATIONS_S)
    if args.long:
        plan = (f"writing and validating virtual-rig runs of "
                f"{', '.join(f'{d:g}' for d in durations)} s, each command in its own process "
                "(an hour of record takes about 2.5 minutes on an idle 2-core machine)")
    else:
        plan = (f"running {', '.join(args.stages or STAGES)} "
                f"({'well under a minute' if args.quick else 'a few minutes'}, one BLAS thread; "
                "the model's full inverse dynamics also with the default BLAS threads)")
    if not getattr(args, "quiet", False):
        print(f"rigval bench: {plan}", file=sys.stderr)
    before = machine_note()
    rows = long_rows(durations) if args.long else run_bench(args.stages, quick=args.quick)
    note = (("Quick run (small cases). " if args.quick else "") + "Machine: " + before
            + f"; load average {os.getloadavg()[0]:.2f} after the run")
    paths = write_outputs(rows, args.out, note)
    print(markdown_table(rows, note))
    print(f"wrote {', '.join(p.name for p in paths)} to {args.out}")
    if reference is not None:
        print(f"\n## Against {args.compare}\n")
        print(compare_text(rows, reference))
    over = [r for r in rows if not r.within_bound]
    for r in over:
        print(f"rigval bench: {r.stage} / {r.case} / {r.choice}: {r.metric} {r.error:.3g} "
              f"{r.unit} exceeds its bound {r.bound:.3g}", file=sys.stderr)
    print(closing_line(rows), file=sys.stderr if over else sys.stdout)
    return 1 if over else 0
