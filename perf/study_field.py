"""Star positions on a crowded field: every star of a Hipparcos field, not one star alone.

The accuracy grid (study_accuracy.py) simulates one star per scene. A star tracker sees
fields: Orion to magnitude 6.5 puts ~150 stars in a DAVIS346's 22° field (16 mm lens),
some pairs a few pixels apart. Each scene (a constant pan about the image's up axis for
0.5 s, the default sensor with 0.1 or 1.5 Hz of background, two seeds) runs through the
default pipeline; its rows are matched to the nearest star within 3 px
(evstar.accuracy.match). Per star, its mean error; stars are split into isolated (no other
within 10 px at the middle of its rows, ≥ 6 px from the sensor's edges), close (another
within 8 px: blended pairs; "along": the neighbour within 30° of the star's motion) and the
rest. False rows: rows matching no star. error/σ: the
matched rows' error over their σ (centroids.csv's `sigma`, per axis): for an honest σ the
median is 1.18 and 95 % lie within 2.45. common px: the isolated stars' error they share
frame by frame (evstar.accuracy.common_error: per frame of ≥ 5 of them, their errors'
median vector; RMS over frames): a rigid field fit cannot remove it, and a star tracker's
attitude inherits it.

    python perf/study_field.py [--seeds 61,62] [--camera davis346:16] [--pointing 83.8,-5.4]
        [--motion pan|sine|slew] [--axis up|roll|x,y,z] [--rates 2,8] [--sensor default]
        [--imu default|no-noise|ideal] [--clock-offset-us 0] [--jitter DEG,HZ[,x,y,z]] [--name field]
        [--set estimate.field_min_stars=0]

Writes perf/results/study_<name>.json and .md (study_field.*: the defaults); prints the
table. study_cygnus.*: Cygnus (RA 305°, Dec +40°, ~330 stars) on a DVXplorer behind 8 mm,
seeds 71 and 72 (`--camera dvxplorer:8 --pointing 305,40 --seeds 71,72 --name cygnus`), a
field held out from the thirteenth session's tracker change, run once on its end and once
on its start (study_cygnus_before.*: 156c8fc's evstar on PYTHONPATH). The seventeenth
session's across step (evstar.across) off / on: `--set estimate.across_kernel_px=0`, results
*_off_s17 beside study_field.*, study_cygnus.* and study_{scorpius,sine,dark}_s17.*;
study_scorpius_sine_dark_s17_{on,off}.*: Scorpius on an EVK4 with the dark-sky sensor on
1 Hz sinusoids (`--camera evk4:16 --pointing 253,-38 --seeds 93,94 --motion sine --sensor
dark-sky --rates 5,20`), a setting first run then.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import pathlib

import numpy as np

from evstar import Config, Pipeline, accuracy, sim
from evstar.imu import Imu
from evstar.sim.imu_model import ImuSpec

RESULTS = pathlib.Path(__file__).resolve().parent / "results"
#: named turn axes (camera frame): about the image's up axis (a pan), about the boresight
AXES = {"up": (0.0, 1.0, 0.0), "roll": (0.0, 0.0, 1.0)}
#: the simulated gyro: a MEMS one (noise, bias, bias walk), without its white noise, ideal
IMUS = {"default": ImuSpec, "no-noise": lambda: ImuSpec(gyro_noise_density=0.0),
        "ideal": ImuSpec.ideal}
COLUMNS = ("noise Hz", "°/s", "seed", "stars seen", "rows", "false rows %",
           "isolated: stars / median / 90 % px", "close (< 8 px): stars / median px",
           "close, along the motion (< 30°): stars / median px", "all: median px",
           "error/σ: median, share ≤ 2.45", "common px")


def run_scene(noise_hz, rate_dps, seed, cam, pointing, settings=None, motion="pan",
              sensor="default", axis=AXES["up"], imu="default", clock_offset_us=0, jitter=None):
    """jitter: (degrees, Hz) of a platform's vibration about the image-plane axis across the
    turn axis (evstar.sim.Jitter), or (degrees, Hz, x, y, z) about that camera-frame axis."""
    duration = 0.5 if motion == "pan" else 1.0   # sine: 1 Hz, peak rate rate_dps; slew: rest to rest
    scene = sim.field_scenario(cam, *pointing, rate_dps, duration, motion=motion, sensor=sensor,
                               noise_hz=noise_hz, axis=axis)
    if jitter:
        across = np.cross(axis, (0.0, 0.0, 1.0)) if len(jitter) == 2 else jitter[2:]
        scene = dataclasses.replace(scene, trajectory=sim.Jitter(scene.trajectory, *jitter[:2],
                                                                 across))
    spec = dataclasses.replace(IMUS[imu](), time_offset_us=clock_offset_us)
    run = sim.simulate(dataclasses.replace(scene, imu=spec), seed=seed)
    if clock_offset_us:   # the gyro's clock offset not told: its stamps as the camera's
        run = dataclasses.replace(run, imu=Imu(run.imu.t, run.imu.gyro, run.imu.accel,
                                               R_cam_imu=run.imu.R_cam_imu))
    rows = Pipeline(Config().replace(**(settings or {}))).run(run.events, run.imu, run.camera).centroids
    star, err = accuracy.match(rows, run.truth.star_position)
    z = err[star >= 0] / np.maximum(rows["sigma"][star >= 0], 1e-12)   # honest σ: χ², 2 dof
    ids = np.unique(star[star >= 0])
    per_star = np.array([err[star == i].mean() for i in ids])
    t_mid = np.array([np.median(rows["t"][star == i]) for i in ids], np.float64)
    pos = run.truth.star_position(t_mid)                     # (stars seen, all stars, 2)
    own = pos[np.arange(len(ids)), ids]
    gap = np.hypot(*(pos - own[:, None]).transpose(2, 0, 1))
    gap[np.arange(len(ids)), ids] = np.inf
    nearest = np.nanmin(gap, axis=1)
    inner = ((own[:, 0] > 5) & (own[:, 0] < cam.width - 6) & (own[:, 1] > 5)
             & (own[:, 1] < cam.height - 6))
    iso, close = (nearest > 10) & inner, nearest < 8
    # close stars whose nearest neighbour lies within 30° of the motion (one pulse per pixel)
    ahead = run.truth.star_position(t_mid + 5000.0)[np.arange(len(ids)), ids] - own
    other = pos[np.arange(len(ids)), np.nanargmin(gap, axis=1)] - own
    cos = np.abs((ahead * other).sum(1)) / np.maximum(
        np.hypot(*ahead.T) * np.hypot(*other.T), 1e-12)
    along = close & (cos >= np.cos(np.radians(30)))
    # the isolated stars' error shared frame by frame (what a rigid field cannot remove)
    on = np.flatnonzero(np.isin(star, ids[iso]))
    truth = run.truth.star_position(rows["t"][on])[np.arange(len(on)), star[on]]
    dxy = np.column_stack([rows["x"][on], rows["y"][on]]) - truth
    common = accuracy.common_error(rows["frame"][on], star[on], dxy)[2]
    return {"noise_hz": noise_hz, "rate_dps": rate_dps, "seed": seed, "stars_seen": len(ids),
            "rows": len(rows), "false_pct": 100 * float((star < 0).mean()),
            "isolated": [int(iso.sum()), float(np.median(per_star[iso])),
                         float(np.percentile(per_star[iso], 90))],
            "close": [int(close.sum()), float(np.median(per_star[close]))],
            "close_along": [int(along.sum()), float(np.median(per_star[along])) if along.any()
                            else float("nan")],
            "all_median": float(np.median(per_star)),
            "z": [float(np.median(z)), float(np.mean(z <= 2.45))], "common_px": common}


def markdown(rows):
    lines = ["| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    for r in rows:
        i, c = r["isolated"], r["close"]
        lines.append(f"| {r['noise_hz']:g} | {r['rate_dps']:g} | {r['seed']} | {r['stars_seen']} | "
                     f"{r['rows']} | {r['false_pct']:.1f} | {i[0]} / {i[1]:.3f} / {i[2]:.3f} | "
                     f"{c[0]} / {c[1]:.3f} | " +
                     (f"{r['close_along'][0]} / {r['close_along'][1]:.3f} | " if "close_along" in r
                      else "— | ") + f"{r['all_median']:.3f} | " +
                     (f"{r['z'][0]:.2f}, {100 * r['z'][1]:.0f} % |" if "z" in r else "— |") +
                     (f" {r['common_px']:.3f} |" if "common_px" in r else " — |"))
    return "\n".join(lines)


def setting_value(text):
    """A --set value as JSON reads it (0, 1.5, true, null), else the text itself."""
    try:
        return json.loads(text)
    except ValueError:
        return text


def settings_of(pairs):
    """Config settings from --set KEY=VALUE texts (values: setting_value)."""
    return {k: setting_value(v) for k, v in (kv.split("=", 1) for kv in pairs)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="61,62", help="comma-separated simulator seeds")
    ap.add_argument("--camera", default="davis346:16", help="evstar.sim camera preset:focal mm")
    ap.add_argument("--pointing", default="83.8,-5.4",
                    help="RA,Dec (°) at the start (default: Orion's belt and sword)")
    ap.add_argument("--motion", choices=("pan", "sine", "slew"), default="pan",
                    help="pan: constant rate, 0.5 s; sine: 1 Hz with the rate as its peak, 1 s; "
                    "slew: rest to rest in 1 s, the rate its peak")
    ap.add_argument("--rates", default="2,8", help="comma-separated (peak) rates, °/s")
    ap.add_argument("--sensor", default="default", help="evstar.sim.sensor_model name")
    ap.add_argument("--axis", default="up",
                    help="turn axis in the camera frame: up (a pan), roll (the boresight) or x,y,z")
    ap.add_argument("--imu", choices=tuple(IMUS), default="default",
                    help="the simulated gyro: default (MEMS noise and bias), no-noise, ideal")
    ap.add_argument("--clock-offset-us", type=int, default=0,
                    help="the gyro's clock this many µs behind the camera's, not told to evstar")
    ap.add_argument("--jitter", default="",
                    help="a platform's vibration, DEG,HZ (about the image-plane axis across the "
                    "turn axis) or DEG,HZ,x,y,z (about that camera-frame axis)")
    ap.add_argument("--name", default="field", help="results: perf/results/study_<name>.*")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="a Config setting, e.g. estimate.field_min_stars=0 (repeatable)")
    args = ap.parse_args(argv)
    settings = settings_of(args.set)
    seeds = [int(s) for s in args.seeds.split(",")]
    name, focal = args.camera.split(":")
    cam = sim.camera_preset(name, float(focal))
    pointing = tuple(float(v) for v in args.pointing.split(","))
    rates = [float(r) for r in args.rates.split(",")]
    axis = AXES.get(args.axis) or tuple(float(v) for v in args.axis.split(","))
    jitter = tuple(float(v) for v in args.jitter.split(",")) if args.jitter else None
    rows = [run_scene(n, r, s, cam, pointing, settings, args.motion, args.sensor, axis, args.imu,
                      args.clock_offset_us, jitter)
            for n in (0.1, 1.5) for r in rates for s in seeds]
    RESULTS.mkdir(exist_ok=True)
    title = (f"# Star positions on a crowded field ({args.camera} mm, RA/Dec {args.pointing}°, "
             f"{args.motion} about {args.axis}, {args.sensor} sensor, {args.imu} IMU"
             f"{f' (its clock {args.clock_offset_us} µs behind, untold)' if args.clock_offset_us else ''}"
             f"{f', vibrating {args.jitter} (°, Hz[, axis])' if args.jitter else ''}, seeds {args.seeds}"
             f"{''.join(', ' + kv for kv in args.set)})\n\n")
    (RESULTS / f"study_{args.name}.json").write_text(json.dumps(rows, indent=1) + "\n")
    (RESULTS / f"study_{args.name}.md").write_text(title + markdown(rows) + "\n")
    print(markdown(rows))


if __name__ == "__main__":
    main()
