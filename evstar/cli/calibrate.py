"""`evstar calibrate IN -o pixel_lag.json`: how late the sensor's pixels report a star.

A dim pixel's photoreceptor is slow, so a star's pixel crossings trail it by a lag that
depends on the pixel's brightness (and the star's speed). At a constant slew rate that lag
looks like a position offset; on a recording whose rate changes and turns back (e.g. a
sinusoidal slew, 10° at 0.5 Hz; along a path that never reverses, each star's offset trades
against the lag) with its IMU (--imu CSV, or the IMU stream of an AEDAT4/HDF5/NPZ input) and
--camera, it is measured: one lag per brightness (level pairs per crossing) and speed, from
all stars together, no sensor model. `evstar run` and `evstar extract` take the file as
--pixel-lag-file (config: estimate.pixel_lag_file) and move every crossing back by its lag.
Calibrate once per camera, lens and bias settings.
"""
from __future__ import annotations

from .common import add_force_option, add_input_options, check_output_suffix, load
from .options import add_pipeline_options, config_from_args


def add_arguments(p):
    p.add_argument("input", metavar="IN", help="calibration recording (slew rate changing and turning back, with IMU)")
    p.add_argument("-o", "--output", required=True, metavar="PIXEL_LAG.json")
    add_input_options(p)
    add_pipeline_options(p)
    add_force_option(p)


def run(args):
    import numpy as np

    from .. import backends
    from ..calibration import calibrate
    from ..io.atomic import check_new_files, check_output_file, check_outputs

    check_output_file(args.output, "-o/--output")
    check_output_suffix(args.output, "-o/--output", [".json"], "JSON")
    check_outputs([args.output], [args.input, args.imu, args.camera, getattr(args, "config", None)])
    check_new_files([args.output], args.force)
    cfg = config_from_args(args)
    check_outputs([args.output], cfg.input_files())   # a pixel_lag_file, from a config too
    backends.require(cfg.device)   # a missing GPU before the recording is read
    rec = load(args)
    lag = calibrate(rec.events, rec.imu, rec.camera, cfg, progress=print)
    lag.meta["recording"] = str(args.input)
    lag.save(args.output)
    speeds = "  ".join(f"{s:>7.0f}" for s in lag.speed_px_s)
    print(f"pixel lag (ms) by level pairs (rows) and speed (px/s): {speeds}")
    for k, row in zip(lag.pairs, lag.lag_us):
        print(f"  {k:>2d}  " + "  ".join(f"{v / 1000:7.2f}" for v in row))
    r = lag.threshold_ratio
    print(f"OFF/ON threshold ratio {r:.3f}" if r is not None else
          "OFF/ON threshold ratio: too few level runs to measure (runs measure their own)")
    print(f"from {lag.meta['crossings']:,} crossings of {lag.meta['tracks']} tracks; "
          f"lag {np.min(lag.lag_us) / 1000:.2f}–{np.max(lag.lag_us) / 1000:.2f} ms; wrote {args.output}")
