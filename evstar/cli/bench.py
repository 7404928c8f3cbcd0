"""`evstar bench`: throughput of every stage on a simulated scene; JSON plus a table."""
from __future__ import annotations


from .. import parameters as P
from .options import add_options, checked


def add_arguments(p):
    p.add_argument("--events", type=checked(int, 1000, 10**9), default=1_000_000,
                   help="scene size in events, 1000 to 1e9 (1e6)")
    add_options(p, P.GLOBAL, ["device"], device={"default": "cpu"})
    p.add_argument("--repeats", type=checked(int, 1, 1000), default=3,
                   help="timed runs per stage (median reported)")
    p.add_argument("-o", "--output", default="bench.json", help="JSON results (bench.json)")


def run(args):
    from .. import bench, profiling

    rows = bench.run(args.events, args.device, args.repeats)
    profiling.write_results(args.output, rows, {"events": args.events, "device": args.device,
                                                "repeats": args.repeats})
    print(bench.markdown(rows))
    print(f"wrote {args.output}")
