"""`evstar run IN -o OUTDIR`: the whole pipeline, with results and figures.

Writes centroids.csv, tracks.csv, metrics.json (deterministic for the same inputs and
seed), profile.json (seconds per stage), config.toml (the configuration used) and PNG
figures: denoise.png (accumulated events before/after), tracks.png, per_frame.png and,
with --truth, errors.png. Files appear only when the run completes; a rerun into the same
folder replaces these files and no others. Inputs larger than --stream-above-mb are
processed in chunks with bounded memory.
"""
from __future__ import annotations

import os

from .common import add_input_options, load
from .options import add_pipeline_options, config_from_args


def add_arguments(p):
    p.add_argument("input", metavar="IN")
    p.add_argument("-o", "--output", required=True, metavar="OUTDIR")
    p.add_argument("--truth", help="simulator truth.npz: adds errors against ground truth")
    p.add_argument("--stream-above-mb", type=float, default=1024.0,
                   help="stream inputs larger than this many MB in chunks (1024)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_input_options(p)
    add_pipeline_options(p)


def run(args):
    from .. import outputs
    from ..io.atomic import check_output_dir, check_outputs
    from ..pipeline import Pipeline
    from ..sim import load_truth

    check_output_dir(args.output)
    check_outputs(outputs.run_files(args.output),
                  [args.input, args.imu, args.camera, args.truth, getattr(args, "config", None)])
    cfg = config_from_args(args)
    truth = load_truth(args.truth) if args.truth else None
    pipe = Pipeline(cfg)
    big = os.path.getsize(args.input) > args.stream_above_mb * 1e6 if os.path.isfile(args.input) else False
    if big:
        aux = load_aux(args)
        result = pipe.run_file(args.input, aux.imu, aux.camera, truth=truth, format=args.format,
                               sensor_size=args.sensor_size, progress=not args.no_progress)
    else:
        rec = load(args)
        result = pipe.run(rec.events, rec.imu, rec.camera, truth=truth)
    outputs.write_run(args.output, result, cfg, truth)
    print(outputs.summary_text(result, args.output))


def load_aux(args):
    """IMU and camera for a streamed input (from their own files)."""
    from .. import io
    from ..recording import Recording

    rec = Recording(events=None)
    rec.camera = io.read_camera(args.camera) if args.camera else None
    rec.imu = io.read_imu(args.imu) if args.imu else None
    return rec

