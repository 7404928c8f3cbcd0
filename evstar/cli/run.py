"""`evstar run IN -o OUTDIR`: the whole pipeline, with results and figures.

Writes centroids.csv, tracks.csv, metrics.json (deterministic for the same inputs and
seed), profile.json (seconds per stage), config.toml (the configuration used) and PNG
figures: denoise.png (accumulated events before/after), tracks.png, per_frame.png and,
with --truth, errors.png. Files appear only when the run completes. Inputs larger than
--stream-above-mb are processed in chunks with bounded memory.
"""
from __future__ import annotations

import json
import os
import pathlib
import shutil
import tempfile

import numpy as np

from .. import io, report
from ..pipeline import Pipeline
from .common import add_input_options, load
from .options import add_pipeline_options, config_from_args


def add_parser(sub):
    p = sub.add_parser("run", help="run the whole pipeline and write results and figures",
                       description=__doc__)
    p.add_argument("input", metavar="IN")
    p.add_argument("-o", "--output", required=True, metavar="OUTDIR")
    p.add_argument("--truth", help="simulator truth.npz: adds errors against ground truth")
    p.add_argument("--stream-above-mb", type=float, default=1024.0,
                   help="stream inputs larger than this many MB in chunks (1024)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_input_options(p)
    add_pipeline_options(p)
    return p


def run(args):
    from ..sim import load_truth

    cfg = config_from_args(args)
    truth = load_truth(args.truth) if args.truth else None
    pipe = Pipeline(cfg)
    big = os.path.getsize(args.input) > args.stream_above_mb * 1e6 if os.path.exists(args.input) else False
    if big:
        aux = load_aux(args)
        result = pipe.run_file(args.input, aux.imu, aux.camera, truth=truth, format=args.format,
                               sensor_size=args.sensor_size, progress=not args.no_progress)
    else:
        rec = load(args)
        result = pipe.run(rec.events, rec.imu, rec.camera, truth=truth)
    write_outputs(args.output, result, cfg, truth)
    summarise(result, args.output)


def load_aux(args):
    """IMU and camera for a streamed input (from their own files)."""
    from ..recording import Recording

    rec = Recording(events=None)
    rec.camera = io.read_camera(args.camera) if args.camera else None
    rec.imu = io.read_imu(args.imu) if args.imu else None
    return rec


def write_outputs(outdir, result, cfg, truth=None):
    """Write every output into a temporary folder, then move them into `outdir` together."""
    outdir = pathlib.Path(outdir)
    outdir.parent.mkdir(parents=True, exist_ok=True)
    tmp = pathlib.Path(tempfile.mkdtemp(prefix=f".{outdir.name}.", dir=outdir.parent))
    try:
        io.write_centroids(tmp / "centroids.csv", result.centroids)
        track_table(result.centroids).to_csv(tmp / "tracks.csv", index=False, float_format="%.4f")
        (tmp / "metrics.json").write_text(json.dumps(result.metrics, indent=2, default=_json) + "\n")
        (tmp / "profile.json").write_text(json.dumps(result.timings_s, indent=2) + "\n")
        (tmp / "config.toml").write_text(cfg.to_toml())
        figures(tmp, result, truth)
        outdir.mkdir(exist_ok=True)
        for f in sorted(tmp.iterdir()):
            os.replace(f, outdir / f.name)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def figures(folder, result, truth):
    report.plot_denoise(folder / "denoise.png", result.image_before, result.image_after)
    c = result.centroids
    truth_xy = None
    if truth is not None:
        truth_xy = truth.star_position(truth.t_us).transpose(1, 0, 2)
    report.plot_tracks(folder / "tracks.png", result.image_after, c, truth_xy)
    fc = result.frame_counts
    if fc:
        curves = {"events before": fc["before"], "events after": fc["after"]}
        if "signal_before" in fc:
            curves = {f"SNR {w} (dB)": 10 * np.log10(np.maximum(fc[f"signal_{w}"], 1e-9)
                                                    / np.maximum(fc[f"noise_{w}"], 1))
                      for w in ("before", "after")}
        report.plot_per_frame(folder / "per_frame.png", fc["t_s"], curves,
                              "SNR per frame (dB)" if "signal_before" in fc else "events per frame")
    if truth is not None and len(c):
        from ..accuracy import match

        star, err = match(c, truth.star_position)
        ok = star >= 0
        report.plot_errors(folder / "errors.png", c["t"][ok], err[ok], labels="centroid error")


def track_table(centroids):
    import pandas as pd

    rows = []
    for tid in np.unique(centroids["track"][centroids["track"] >= 0]):
        c = centroids[centroids["track"] == tid]
        dt = (c["t"][-1] - c["t"][0]) * 1e-6
        rows.append({"track": int(tid), "t_first": int(c["t"][0]), "t_last": int(c["t"][-1]),
                     "n_centroids": len(c), "x_first": c["x"][0], "y_first": c["y"][0],
                     "x_last": c["x"][-1], "y_last": c["y"][-1],
                     "vx_px_s": (c["x"][-1] - c["x"][0]) / dt if dt > 0 else 0.0,
                     "vy_px_s": (c["y"][-1] - c["y"][0]) / dt if dt > 0 else 0.0,
                     "mean_events": float(c["n_events"].mean())})
    cols = ["track", "t_first", "t_last", "n_centroids", "x_first", "y_first", "x_last", "y_last",
            "vx_px_s", "vy_px_s", "mean_events"]
    return pd.DataFrame(rows, columns=cols)


def summarise(result, outdir):
    m = result.metrics
    total = sum(result.timings_s.values())
    print(f"events        {m['events']:,} ({m['events_kept']:,} kept)")
    print(f"centroids     {m['centroids']:,} in {m['tracks']} track(s)")
    if "snr_before_db" in m:
        print(f"SNR           {m['snr_before_db']:.1f} dB -> {m['snr_after_db']:.1f} dB "
              f"(signal retained {100 * m['signal_retained']:.1f} %)")
        e = m["centroid_error_px"]
        print(f"centroid err  mean {e['mean']:.3f} px, max {e['max']:.3f} px ({e['n']} matched)")
    print(f"throughput    {m['events'] / max(total, 1e-9) / 1e6:.2f} M events/s "
          f"({', '.join(f'{k} {v:.2f} s' for k, v in result.timings_s.items())})")
    print(f"wrote         {outdir}/")


def _json(v):
    if isinstance(v, (np.integer, np.floating)):
        return v.item()
    if isinstance(v, np.ndarray):
        return v.tolist()
    raise TypeError(type(v))
