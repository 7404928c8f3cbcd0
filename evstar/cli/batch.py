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

import sys

from .common import add_input_options
from .options import add_pipeline_options, checked, config_from_args


def add_arguments(p):
    p.add_argument("inputs", nargs="+", metavar="INPUT", help="recordings or glob patterns")
    p.add_argument("-o", "--output", required=True, metavar="OUTDIR")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=checked(int, 1), metavar="N",
                       help="local worker processes (default: the CPU count)")
    where.add_argument("--scheduler", metavar="ADDRESS",
                       help="a running Dask scheduler, e.g. tcp://host:8786")
    p.add_argument("--force", action="store_true", help="redo recordings already done")
    p.add_argument("--stream-above-mb", type=float, default=1024.0,
                   help="stream inputs larger than this many MB in chunks (1024)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_input_options(p)
    add_pipeline_options(p)


def run(args):
    from ..batch import run_many  # imports Dask only when it runs
    from ..errors import DataError

    options = dict(imu=args.imu, camera=args.camera, format=args.format, sort=args.sort,
                   sensor_size=args.sensor_size, stream_above_mb=args.stream_above_mb)
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
