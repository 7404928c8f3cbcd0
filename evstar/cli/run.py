"""`evstar run IN -o OUTDIR`: the whole pipeline, with results and figures.

Writes centroids.csv, tracks.csv, metrics.json (deterministic for the same inputs and
seed), profile.json (seconds per stage), config.toml (the configuration used) and PNG
figures: denoise.png (accumulated events before/after), tracks.png, per_frame.png and,
with --truth, errors.png; with a camera (--camera or the recording's) also attitude.csv,
the inertial attitude as `evstar attitude` writes it (the [attitude_filter] settings of
--config, or the --attitude-* options), when a frame, or the pooled events of a window (not
when streamed), could be identified. Files appear only when the run
completes; a rerun into the same
folder replaces these files and no others. Inputs larger than --stream-above-mb are
processed in chunks with bounded memory.
"""
from __future__ import annotations

from .common import add_input_options
from .options import add_pipeline_options, checked, config_from_args

MAX_STREAM_ABOVE_MB = 1e9  # a petabyte: larger is no threshold but a typo


def add_arguments(p):
    p.add_argument("input", metavar="IN")
    p.add_argument("-o", "--output", required=True, metavar="OUTDIR")
    p.add_argument("--truth", help="simulator truth.npz: adds errors against ground truth")
    add_run_options(p)


def add_run_options(p):
    """What `evstar run` and `evstar batch` share: streaming, progress, inputs, pipeline,
    attitude."""
    p.add_argument("--stream-above-mb", type=checked(float, 0, MAX_STREAM_ABOVE_MB), default=1024.0,
                   metavar="MB", help="stream inputs larger than this many MB in chunks (1024; "
                   "0: always; at most 1e9, a petabyte)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_input_options(p)
    add_pipeline_options(p, attitude=True)


def run(args):
    from .. import outputs
    from ..io.atomic import check_output_dir, check_outputs
    from ..runs import run_recording

    check_output_dir(args.output)  # output problems first, before the configuration's
    check_outputs(outputs.run_files(args.output), [getattr(args, "config", None)])
    result = run_recording(args.input, args.output, config_from_args(args),
                           **recording_options(args), progress=not args.no_progress)
    print(outputs.summary_text(result, args.output))


def recording_options(args):
    """run_recording's keywords from the command line (all but the output and progress)."""
    return dict(truth=getattr(args, "truth", None), imu=args.imu, camera=args.camera,
                format=args.format, sensor_size=args.sensor_size, sort=args.sort,
                stream_above_mb=args.stream_above_mb, imu_offset_us=args.imu_offset_us)
