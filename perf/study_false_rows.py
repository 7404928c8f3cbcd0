"""Where a star field's false rows come from: the rows no star lies within 3 px of, by
their speed and their centroids' events, with each group's signed error along the motion
(against the nearest star, within 8 px).

    python perf/study_false_rows.py [--camera evk4:16] [--pointing 253,-38] [--motion sine]
        [--rate 20] [--sensor dark-sky] [--noise 1.5] [--seed 93] [--name false_rows]
        [--set motion.compensate=imu]

Writes perf/results/study_<name>.json and .md; prints the tables. Found by the
twenty-first session on the Scorpius EVK4 dark-sky 20 °/s sinusoid: the false rows are
faint stars' rows trailing their star by 3–6 px at peak speed (their crossings' lag, one
level pair deep, under-corrected), not noise.
"""
from __future__ import annotations

import argparse
import pathlib

import numpy as np

from evstar import Config, Pipeline, accuracy, profiling, sim
from study_field import settings_of

RESULTS = pathlib.Path(__file__).resolve().parent / "results"
SPEEDS = (0, 200, 400, 600, 800, 1000, np.inf)            # px/s
EVENTS = (0, 10, 20, 40, 80, 160, np.inf)                 # events per row's centroid
COLUMNS = [("group", "rows of", ""), ("rows", "rows", ""), ("false_pct", "false %", ".1f"),
           ("along_median", "along median px", "+.2f"), ("along_p10", "along 10 % px", "+.2f"),
           ("sigma_median", "σ median px", ".2f")]


def rows_and_truth(a):
    name, focal = a.camera.split(":")
    cam = sim.camera_preset(name, float(focal))
    ra, dec = (float(v) for v in a.pointing.split(","))
    scene = sim.field_scenario(cam, ra, dec, a.rate, 1.0 if a.motion == "sine" else 0.5,
                               motion=a.motion, sensor=a.sensor, noise_hz=a.noise)
    run = sim.simulate(scene, seed=a.seed)
    return (Pipeline(Config().replace(**settings_of(a.set))).run(run.events, run.imu, run.camera)
            .centroids, run.truth)


def signed_along(rows, truth):
    """(distance to the nearest star, its speed px/s, the row's offset along its motion px)."""
    t = rows["t"].astype(np.float64)
    pos, later = truth.star_position(t), truth.star_position(t + 500.0)
    dist = np.hypot(pos[..., 0] - rows["x"][:, None], pos[..., 1] - rows["y"][:, None])
    j = np.argmin(np.where(np.isfinite(dist), dist, np.inf), axis=1)
    i = np.arange(len(rows))
    v = (later[i, j] - pos[i, j]) / 500e-6
    speed = np.linalg.norm(v, axis=1)
    u = v / np.maximum(speed, 1e-9)[:, None]
    off = np.column_stack([rows["x"], rows["y"]]) - pos[i, j]
    return dist[i, j], speed, (off * u).sum(axis=1)


def groups(label, value, edges, rows, false, near, along):
    out = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        m = near & (value >= lo) & (value < hi)
        if m.any():
            out.append({"group": f"{label} {lo:g}–{hi:g}", "rows": int(m.sum()),
                        "false_pct": 100 * float(false[m].mean()),
                        "along_median": float(np.median(along[m])),
                        "along_p10": float(np.percentile(along[m], 10)),
                        "sigma_median": float(np.median(rows["sigma"][m]))})
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--camera", default="evk4:16")
    ap.add_argument("--pointing", default="253,-38")
    ap.add_argument("--motion", choices=("pan", "sine"), default="sine")
    ap.add_argument("--rate", type=float, default=20.0)
    ap.add_argument("--sensor", default="dark-sky")
    ap.add_argument("--noise", type=float, default=1.5)
    ap.add_argument("--seed", type=int, default=93)
    ap.add_argument("--name", default="false_rows")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="a Config setting, e.g. motion.compensate=imu (repeatable)")
    a = ap.parse_args()
    rows, truth = rows_and_truth(a)
    star, _ = accuracy.match(rows, truth.star_position)
    dist, speed, along = signed_along(rows, truth)
    false, near = star < 0, dist < 8
    out = (groups("speed px/s", speed, SPEEDS, rows, false, near, along)
           + groups("events", rows["n_events"], EVENTS, rows, false, near & (speed > 800), along))
    text = (f"{len(rows)} rows, {100 * false.mean():.1f} % false; "
            f"sources of the false: {dict(zip(*np.unique(rows['source'][false], return_counts=True)))}\n\n"
            + profiling.table(out, COLUMNS)
            + "\n\n(events rows: those faster than 800 px/s)")
    profiling.write_report(RESULTS, f"study_{a.name}", out, "False rows by speed and brightness "
                           f"({a.camera} {a.pointing} {a.motion} {a.rate:g} °/s, {a.sensor}, "
                           f"{a.noise:g} Hz, seed {a.seed}{''.join(', ' + kv for kv in a.set)})", text, vars(a))
    print(text)


if __name__ == "__main__":
    main()
