"""`evstar convert IN OUT`: change a recording's format (events, with IMU where both hold it)."""
from __future__ import annotations

from .common import (add_force_option, add_input_options, add_output_format_option,
                     check_events_output, load)


def add_arguments(p):
    p.add_argument("input", metavar="IN")
    p.add_argument("output", metavar="OUT", help="output file: .csv .npz .h5 .aedat4")
    add_input_options(p)
    add_output_format_option(p, "output format, overriding the extension (csv, npz, hdf5, aedat4)")
    add_force_option(p)


def run(args):
    from .. import io
    from ..io.atomic import check_new_files, check_output_file, check_outputs

    check_output_file(args.output, "OUT")
    check_events_output(args.output, args.out_format)  # the format, before any work
    check_outputs([args.output], [args.input, args.imu, args.camera])
    check_new_files([args.output], args.force)
    rec = load(args)
    io.write(args.output, rec, format=args.out_format)
    n = len(rec.events)
    print(f"wrote {n:,} event{'' if n == 1 else 's'} to {args.output}")
