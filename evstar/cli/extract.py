"""`evstar extract IN -o centroids.csv`: denoise, cluster and track; write the centroids.

CSV header `t,x,y,track,n_events,frame` (t in µs; track -1 = unconfirmed) followed by
`spread,border,split,sigma,source,n_on` (n_on: the ON events among n_events). With --compensate imu|pf the events are first warped with the IMU
(--imu CSV, or the IMU stream of an AEDAT4/HDF5/NPZ input) and --camera.
"""
from __future__ import annotations

from .common import add_force_option, add_input_options, check_output_suffix, load
from .options import add_pipeline_options, config_from_args


def add_arguments(p):
    p.add_argument("input", metavar="IN")
    p.add_argument("-o", "--output", required=True, metavar="CENTROIDS.csv")
    add_input_options(p)
    add_pipeline_options(p)
    add_force_option(p)


def run(args):
    from .. import backends, io
    from ..io.atomic import check_new_files, check_output_file, check_outputs
    from ..io.centroid_files import CENTROID_FORMATS
    from ..pipeline import Pipeline

    check_output_file(args.output, "-o/--output")
    check_output_suffix(args.output, "-o/--output", list(CENTROID_FORMATS),   # before any work
                        "a centroid table (CSV, HDF5 or NPZ)")
    check_outputs([args.output], [args.input, args.imu, args.camera, getattr(args, "config", None)])
    check_new_files([args.output], args.force)
    cfg = config_from_args(args)
    check_outputs([args.output], cfg.input_files())   # a pixel_lag_file, from a config too
    backends.require(cfg.device)   # a missing GPU before the recording is read
    rec = load(args)
    result = Pipeline(cfg).run(rec.events, rec.imu, rec.camera)
    io.write_centroids(args.output, result.centroids)
    m = result.metrics
    print(f"{m['centroids']:,} centroids in {m['tracks']} tracks from {m['events_kept']:,} of "
          f"{m['events']:,} events; wrote {args.output}")
