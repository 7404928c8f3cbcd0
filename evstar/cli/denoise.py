"""`evstar denoise IN OUT [--method classical|ndsef|mr-ndsef]`: keep the events a filter
accepts (default: MR-NDSEF, the configuration's default).

OUT receives the kept events in input order (format by extension, IMU and camera carried
over where the format holds them); --mask-out writes the keep mask (one bool per input
event) as .npy. Thresholds default to auto (Poisson false-alarm probability --alpha at the
measured background rate).
"""
from __future__ import annotations

import time

from .. import parameters as P
from ..errors import OutputError, ParameterError
from .common import (add_force_option, add_input_options, add_output_format_option, check_events_output,
                     check_output_suffix, load)
from .options import add_options, config_from_args

METHODS = P.METHODS[1:]  # every filter; "none" is for the pipeline


def add_arguments(p):
    p.add_argument("input", metavar="IN")
    p.add_argument("output", metavar="OUT", help="kept events: .csv .npz .h5 .aedat4")
    add_options(p, P.GLOBAL, ["device", "dt_us"])
    add_options(p, P.DENOISE, method={"choices": METHODS})
    add_options(p, P.KERNEL, ["backend"], section="")
    p.add_argument("--auto", action="store_true", help="thresholds from the background rate (the default)")
    p.add_argument("--mask-out", metavar="MASK.npy", help="write the keep mask (bool per input event)")
    add_input_options(p)
    add_output_format_option(p, "output format, overriding OUT's extension (csv, npz, hdf5, aedat4)")
    add_force_option(p)


def make_filter(args):
    """The filter the options describe (the pipeline's factory); option misuse is a user error."""
    from .. import denoise

    given = {k for k, v in vars(args).items() if v is not None and v is not False}
    for option, key, method in (("--threshold", "denoise.threshold", "ndsef"),
                                ("--thresholds", "denoise.thresholds", "mr-ndsef")):
        if key in given and method_of(args) != method:
            raise ParameterError(f"{option} is for --method {method}")
        if key in given and "auto" in given:
            raise ParameterError(f"{option} and --auto exclude each other")
    return denoise.from_config(config_from_args(args), backend=args.backend or "taichi")


def method_of(args):
    """--method, or the declared default when it is not given."""
    return args.__dict__["denoise.method"] or P.DENOISE["method"].default


def run(args):
    import numpy as np

    from .. import backends, io
    from ..io.atomic import atomic_path, check_new_files, check_output_file, check_outputs

    for out, option in ((args.output, "OUT"), (args.mask_out, "--mask-out")):
        if out is not None:
            check_output_file(out, option)
    check_events_output(args.output, args.out_format)  # the format, before any work
    try:  # the two outputs must differ: the mask would replace the kept events
        check_outputs([args.mask_out], [args.output])
    except OutputError:
        raise ParameterError(f"--mask-out {args.mask_out} is OUT {args.output}; give the mask "
                             "its own file") from None
    if args.mask_out is not None:
        check_output_suffix(args.mask_out, "--mask-out", [".npy"], "a NumPy array")
    check_outputs([args.output, args.mask_out], [args.input, args.imu, args.camera])
    check_new_files([args.output, args.mask_out], args.force)
    flt = make_filter(args)
    backends.require(config_from_args(args).device)   # a missing GPU before the recording is read
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
          f"with {method_of(args)}{extra} in {elapsed:.3f} s; wrote {args.output}")
