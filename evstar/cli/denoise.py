"""`evstar denoise IN OUT --method classical|ndsef|mr-ndsef`: keep the events a filter accepts.

OUT receives the kept events in input order (format by extension, IMU and camera carried
over where the format holds them); --mask-out writes the keep mask (one bool per input
event) as .npy. Thresholds default to auto (Poisson false-alarm probability --alpha at the
measured background rate).
"""
from __future__ import annotations

import time

import numpy as np

from .. import io
from ..io.atomic import atomic_path, check_output_file, check_outputs
from ..errors import EvstarError
from .common import add_input_options, load

METHODS = ("classical", "ndsef", "mr-ndsef")


def add_parser(sub):
    p = sub.add_parser("denoise", help="denoise events: classical, NDSEF or MR-NDSEF filter",
                       description=__doc__)
    p.add_argument("input", metavar="IN")
    p.add_argument("output", metavar="OUT", help="kept events: .csv .npz .h5 .aedat4")
    p.add_argument("--method", required=True, choices=METHODS)
    p.add_argument("--dt-ms", type=float, default=10.0,
                   help="pseudo-frame length (NDSEF, MR-NDSEF) or support window (classical), ms (10)")
    p.add_argument("--k", type=int, default=1, help="classical: supporting neighbours needed (1 = dv's filter)")
    p.add_argument("--radius", type=float, default=5.0, help="NDSEF radius, px (5)")
    p.add_argument("--radii", type=float, nargs="+", default=[3, 5, 7, 9, 11], metavar="R",
                   help="MR-NDSEF radii, px, increasing (3 5 7 9 11)")
    th = p.add_mutually_exclusive_group()
    th.add_argument("--threshold", type=int, help="NDSEF density threshold (events in the disk)")
    th.add_argument("--thresholds", type=int, nargs="+", metavar="N", help="MR-NDSEF: one threshold per radius")
    th.add_argument("--auto", action="store_true", help="thresholds from the background rate (default)")
    p.add_argument("--alpha", type=float, default=1e-3, help="false-alarm probability of --auto (1e-3)")
    p.add_argument("--rate-hz", type=float, help="background rate for --auto, events/pixel/s (default: measured)")
    p.add_argument("--device", default="cpu", help="cpu or cuda (default cpu)")
    p.add_argument("--backend", default="taichi", choices=("taichi", "reference"))
    p.add_argument("--mask-out", metavar="MASK.npy", help="write the keep mask (bool per input event)")
    add_input_options(p)
    p.add_argument("--to", dest="out_format", help="output format, overriding OUT's extension")
    return p


def make_filter(args):
    """The filter the options describe; option misuse is a user error."""
    from .. import denoise

    method = args.method
    if args.threshold is not None and method != "ndsef":
        raise EvstarError("--threshold is for --method ndsef (use --thresholds for mr-ndsef)")
    if args.thresholds is not None and method != "mr-ndsef":
        raise EvstarError("--thresholds is for --method mr-ndsef (use --threshold for ndsef)")
    dt_us = int(round(args.dt_ms * 1000))
    common = dict(backend=args.backend, device=args.device)
    auto = dict(alpha=args.alpha, rate_hz=args.rate_hz)
    try:
        if method == "classical":
            return denoise.ClassicalFilter(dt_us, args.k, **common)
        if method == "ndsef":
            return denoise.NDSEF(dt_us, args.radius, args.threshold or "auto", **auto, **common)
        return denoise.MRNDSEF(dt_us, tuple(args.radii), tuple(args.thresholds) if args.thresholds else "auto",
                               **auto, **common)
    except ValueError as exc:
        raise EvstarError(f"invalid option: {exc}") from None


def run(args):
    for out in (args.output, args.mask_out):
        if out is not None:
            check_output_file(out)
    check_outputs([args.output, args.mask_out], [args.input, args.imu, args.camera])
    flt = make_filter(args)
    rec = load(args)
    start = time.perf_counter()
    keep = flt.apply(rec.events)
    elapsed = time.perf_counter() - start
    io.write(args.output, rec.events[keep], imu=rec.imu, camera=rec.camera, format=args.out_format)
    if args.mask_out:
        with atomic_path(args.mask_out) as tmp, open(tmp, "wb") as f:
            np.save(f, keep)  # a file object: np.save adds no ".npy" to the temporary name
    n = len(keep)
    extra = f", thresholds {list(flt.thresholds_)}" if hasattr(flt, "thresholds_") else ""
    print(f"kept {int(keep.sum()):,} of {n:,} events ({100 * keep.mean() if n else 0:.1f} %) "
          f"with {args.method}{extra} in {elapsed:.3f} s; wrote {args.output}")
