"""`evstar batch INPUTS... -o OUTDIR`: `evstar run` on many recordings at once, on Dask.

Each input (a file or a glob pattern, quoted) gets OUTDIR/<file stem>/ with exactly what
`evstar run` writes (stems that repeat are prefixed by their folder's name). OUTDIR gets
summary.csv and summary.parquet, one row per input: status ok or failed, its one-line
error, counts, seconds and the scalar metrics. A failing recording never stops the others;
the exit code is 3 when any failed. A rerun skips recordings already done with the same
input and configuration (--force redoes them).

By default a local cluster of --workers processes runs the tasks; --scheduler uses a
running Dask scheduler (`dask scheduler`, with `dask worker tcp://HOST:8786` on each
machine; every worker needs evstar and the same paths to the inputs and OUTDIR).
"""
from __future__ import annotations

import argparse
import sys

from .options import checked, config_from_args
from .run import add_run_options, recording_options


def add_arguments(p):
    p.add_argument("inputs", nargs="+", metavar="INPUT", type=input_name,
                   help="recordings or glob patterns")
    p.add_argument("-o", "--output", required=True, metavar="OUTDIR")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=checked(int, 1), metavar="N",
                       help="local worker processes (default: the CPU count; at most one per recording)")
    where.add_argument("--scheduler", metavar="ADDRESS", type=scheduler_address,
                       help="a running Dask scheduler, e.g. tcp://host:8786")
    p.add_argument("--force", action="store_true", help="redo recordings already done")
    add_run_options(p)


def input_name(text):
    """argparse `type` of INPUT: a name (an empty one would be the current folder)."""
    if not text.strip():
        raise argparse.ArgumentTypeError(f"must name a recording or a glob pattern, got {text!r}")
    return text


def scheduler_address(text):
    """argparse `type` of --scheduler: a well-formed Dask address (reachable or not)."""
    from ..batch import scheduler_address_error

    why = scheduler_address_error(text)
    if why:
        raise argparse.ArgumentTypeError(why)
    return text.strip()


def run(args):
    from ..batch import run_many  # imports Dask only when it runs
    from ..errors import DataError

    options = recording_options(args)
    del options["truth"]  # simulator truth belongs to one recording
    table = run_many(args.inputs, config_from_args(args), args.output, force=args.force,
                     workers=args.workers, scheduler=args.scheduler, options=options,
                     progress=not args.no_progress)
    failed = table[table["status"] == "failed"]
    skipped = int(table["skipped"].sum())
    print(f"{len(table)} recording(s): {len(table) - len(failed)} ok ({skipped} skipped), "
          f"{len(failed)} failed\nwrote         {args.output}/summary.csv")
    if len(failed):
        print(f"evstar batch: error: {len(failed)} of {len(table)} recording(s) failed, first: "
              f"{failed['error'].iloc[0]} (see {args.output}/summary.csv)", file=sys.stderr)
        return DataError.exit_code
    return 0
