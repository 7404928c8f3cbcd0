"""`evstar convert IN OUT`: change a recording's format (events, with IMU where both hold it)."""
from __future__ import annotations

from .common import add_input_options, load


def add_arguments(p):
    p.add_argument("input", metavar="IN")
    p.add_argument("output", metavar="OUT", help="output file: .csv .npz .h5 .aedat4")
    add_input_options(p)
    p.add_argument("--to", dest="out_format", help="output format, overriding the extension")


def run(args):
    from .. import io
    from ..io.atomic import check_output_file, check_outputs

    check_output_file(args.output)
    check_outputs([args.output], [args.input, args.imu, args.camera])
    rec = load(args)
    io.write(args.output, rec, format=args.out_format)
    print(f"wrote {len(rec.events):,} events to {args.output}")
