"""`evstar attitude IN -o attitude.csv --camera camera.json`: the inertial attitude.

IN is a recording (the pipeline runs first, with --config's settings) or a centroid file
written by `evstar extract` / `evstar run` (.csv, .h5, .npz). Stars are identified against
the Hipparcos catalogue (epoch --epoch, a decimal year), then a multiplicative EKF follows
the attitude with the identified tracks, driven by the gyro when there is an IMU (--imu,
or the recording's own), else by a constant-rate model. From a recording, when no frame's
centroids identify within --pooled-window-ms, the window's events pooled into one image are
identified (evstar.attitude.identify_events); a centroid file has frames only. The
filter's settings are --config's [attitude_filter] table, the options overriding it (the
same section `evstar run` writes its attitude.csv with).

CSV header `t,qw,qx,qy,qz` (t µs; unit quaternion, scalar first, camera -> ICRS) followed
by `ra_deg,dec_deg,roll_deg,wx,wy,wz,n_stars,status`; one row every 1/--rate-hz after the
first fix (docs/attitude.md defines roll and the statuses).
"""
from __future__ import annotations

import pathlib

from .. import parameters as P
from .common import add_force_option, add_input_options, check_output_suffix, load
from .options import add_options, checked, config_from_args


def add_arguments(p):
    p.add_argument("input", metavar="IN", help="recording, or centroid file (.csv .h5 .npz)")
    p.add_argument("-o", "--output", required=True, metavar="ATTITUDE.csv")
    p.add_argument("--epoch", type=checked(float, 1000, 3000), metavar="YEAR",
                   help="epoch of the star positions, decimal year (default: the catalogue's)")
    p.add_argument("--config", help="configuration file (.toml or .json): its [attitude_filter] "
                   "(the options below override it) and, for a recording, the pipeline's settings")
    add_input_options(p)
    add_options(p, P.ATTITUDE_FILTER)
    add_force_option(p)


def run(args):
    from .. import io
    from ..attitude import AttitudeEstimator, write_attitude
    from ..errors import DataError, ParameterError
    from ..io.atomic import check_new_files, check_output_file, check_outputs

    check_output_file(args.output, "-o/--output")
    check_output_suffix(args.output, "-o/--output", [".csv"], "CSV")
    check_outputs([args.output], [args.input, args.imu, args.camera, args.config])
    check_new_files([args.output], args.force)
    cfg = config_from_args(args)   # the options' dests are its attitude_filter.* keys
    if is_centroid_file(args.input):
        from ..runs import read_aux, require_imu

        camera, imu = read_aux(args.camera, args.imu, bool(args.sort), args.imu_offset_us)
        require_imu(imu, args.imu_offset_us, args.input)
        if camera is None:
            raise ParameterError("the attitude needs the camera's intrinsics: give --camera camera.json")
        centroids = io.read_centroids(args.input, sensor=(camera.width, camera.height))
        events = None            # a centroid file: frames only, no pooled-window fallback
    else:
        centroids, camera, imu, events = _pipeline(args, cfg)
    if camera is None:
        raise ParameterError("the attitude needs the camera's intrinsics: give --camera camera.json")
    est = AttitudeEstimator(camera, imu, epoch=args.epoch, **cfg.attitude_options())
    rows = est.run(centroids, events)
    if not len(rows):
        raise DataError(f"no attitude: {no_output_after_fix(est, centroids) or fix_summary(est.fixes)}")
    write_attitude(args.output, rows)
    print(f"{len(rows):,} attitudes {rows['t'][0]}..{rows['t'][-1]} µs "
          f"({'gyro' if imu is not None else 'constant-rate model'}), first fix at "
          f"{rows['t'][0]} µs, {fix_summary(est.fixes)}; wrote {args.output}")


def _pipeline(args, cfg):
    from .. import backends
    from ..pipeline import Pipeline

    backends.require(cfg.device)   # a missing GPU before the recording is read
    rec = load(args)
    result = Pipeline(cfg).run(rec.events, rec.imu, rec.camera)
    return result.centroids, rec.camera, rec.imu, rec.events


#: header names only a centroid table has (an event CSV has t, x, y and a polarity)
CENTROID_ONLY = {"track", "n_events", "frame", "spread", "border", "split", "sigma", "source", "n_on"}


def is_centroid_file(path):
    """True for a centroid table (NPZ array or HDF5 dataset 'centroids'; a CSV whose header
    names a centroid column such as track, or has no polarity column), False for anything
    else (read as a recording)."""
    path = pathlib.Path(path)
    ext = path.suffix.lower()
    try:
        if ext == ".csv":
            return _csv_is_centroids(path)
        if ext == ".npz":
            import numpy as np
            with np.load(path, allow_pickle=False) as z:
                return "centroids" in z.files
        if ext in (".h5", ".hdf5"):
            import h5py
            with h5py.File(path, "r") as f:
                return "centroids" in f
    except (OSError, ValueError):
        return False   # the recording reader reports what is wrong with it
    return False


def _csv_is_centroids(path):
    """A header (the first line that is not blank or a # comment) naming a centroid-only
    column or no polarity column: meant as centroids (read_centroids says what is missing)."""
    import re

    from ..io.text import ALIASES

    with open(path, encoding="utf-8-sig", errors="replace") as f:
        header = next((ln for ln in f if ln.strip() and not ln.startswith("#")), "")
    names = {n.strip().strip("\"'").strip().lower() for n in re.split(r"[,;\s]+", header.strip())}
    if not any(c.isalpha() and c not in "eE" for c in header):
        return False     # headerless rows: the t x y p event layout
    return bool(names & CENTROID_ONLY) or not names & set(ALIASES["p"])


def no_output_after_fix(est, centroids):
    """Why identification succeeded yet no row came: every output time (one each 1/rate_hz
    from the first centroid) falls before the first fix. None when that is not the case."""
    import numpy as np

    ok = [t for t, status, _ in est.fixes if status.split()[-1] == "ok"]
    c = centroids
    if "source" in c.dtype.names:
        c = c[c["source"] != "coasted"]
    c = c[np.isfinite(c["x"]) & np.isfinite(c["y"])]
    if not ok or not len(c):
        return None
    rate = est.o["rate_hz"]
    step_us = 1e6 / rate
    t0 = int(c["t"].min()) + int(round(est.o["centroid_delay_us"] or 0))
    span_us = int(c["t"].max()) - int(c["t"].min())
    last_out = t0 + int(span_us // step_us) * step_us
    if last_out > min(ok):
        return None
    why = ("every centroid has the same t: nothing follows the fix" if span_us == 0 else
           f"--rate-hz {rate:g} gives one output every {step_us / 1e3:g} ms from {t0} µs; raise --rate-hz")
    return (f"{fix_summary(est.fixes)}, but no output time after the first fix at {min(ok)} µs: "
            f"the centroids span {span_us / 1e3:g} ms, {why}")


def fix_summary(fixes):
    """'identification: 3 ok, 97 too_few_stars' from AttitudeEstimator.fixes."""
    if not fixes:
        return "no frame had centroids to identify"
    counts = {}
    for _, status, _ in fixes:
        counts[status] = counts.get(status, 0) + 1
    return "identification: " + ", ".join(f"{n} {s}" for s, n in sorted(counts.items()))
