"""`evstar bench`: throughput of every stage on a simulated scene; JSON plus a table."""
from __future__ import annotations


def add_parser(sub):
    p = sub.add_parser("bench", help="measure throughput per stage and backend", description=__doc__)
    p.add_argument("--events", type=int, default=1_000_000, help="scene size in events (1e6)")
    p.add_argument("--device", default="cpu", help="cpu or cuda")
    p.add_argument("--repeats", type=int, default=3, help="timed runs per stage (median reported)")
    p.add_argument("-o", "--output", default="bench.json", help="JSON results (bench.json)")
    return p


def run(args):
    from .. import bench, profiling

    if args.events < 1000 or args.repeats < 1:
        raise ValueError("--events must be >= 1000 and --repeats >= 1")
    rows = bench.run(args.events, args.device, args.repeats)
    profiling.write_results(args.output, rows, {"events": args.events, "device": args.device,
                                                "repeats": args.repeats})
    print(bench.markdown(rows))
    print(f"wrote {args.output}")
