"""`evstar bench`: throughput of every stage on a simulated scene; JSON plus a table.

-o names a .json file; an existing file there is replaced only when it holds an earlier
`evstar bench` result (never a recording, a camera file or any other JSON)."""
from __future__ import annotations

import json
import pathlib

from .. import parameters as P
from .options import add_options, checked

#: the top-level keys of a results file (evstar.profiling.write_results)
RESULT_KEYS = {"machine", "meta", "rows"}
#: the largest --events (memory: see add_arguments)
MAX_EVENTS = 10**8


def add_arguments(p):
    # the scene and its copies hold ~60 bytes an event: 1e8 is ~6 GB (1e9 asked for 60)
    p.add_argument("--events", type=checked(int, 1000, MAX_EVENTS), default=1_000_000,
                   help="scene size in events, 1000 to 1e8; the scene lasts at least 0.5 s, "
                        "about 70,000 events (1e6)")
    add_options(p, P.GLOBAL, ["device"], device={"default": "cpu"})
    p.add_argument("--repeats", type=checked(int, 1, 1000), default=3,
                   help="timed runs per stage, 1 to 1000, the median reported (3)")
    p.add_argument("-o", "--output", default="bench.json", metavar="RESULTS.json",
                   help="JSON results (bench.json)")


def check_results_path(path):
    """Before any work: a .json name (ParameterError) where no other file would be replaced
    (OutputError)."""
    from ..errors import OutputError
    from ..io.atomic import check_output_file
    from .common import check_output_suffix

    check_output_file(path, "-o/--output")   # the raw text: "x.json/" is a folder path
    check_output_suffix(path, "-o/--output", [".json"], "JSON")
    path = pathlib.Path(path)
    if path.exists() and not _is_results(path):
        raise OutputError(path, "exists and is not an evstar bench result; evstar bench replaces "
                                "only its own results, choose another name")


def _is_results(path):
    try:
        with open(path, encoding="utf-8") as f:
            doc = json.load(f)
    except (OSError, ValueError):
        return False
    return isinstance(doc, dict) and set(doc) == RESULT_KEYS


def run(args):
    from .. import bench, profiling

    check_results_path(args.output)
    rows = bench.run(args.events, args.device, args.repeats)
    profiling.write_results(args.output, rows, {"events": args.events, "device": args.device,
                                                "repeats": args.repeats})
    print(bench.markdown(rows))
    print(f"wrote {args.output}")
