"""Close pairs of stars on the independent simulator (perf/indep_sim.py): error by separation.

A pair of stars (magnitudes 3.5 and 4, Gaussian PSF σ 1.2 px, ideal pixels, 1 Hz of
background, VGA behind f 540 px) moves at 4 or 12 °/s; the line joining them lies at 0°,
45° or 90° to the motion, and they are 2–8 px apart. Per scene, each star's mean error
(rows matched to the nearest star within 3 px at the row's time), the lowest share of
10 ms frames with a position, and false rows per 100 frames. Written in the thirty-second
session after its close-pair change (evstar.tracking.Tracker._without_blends), to map
where pairs stand rather than to tune it. --companions adds three isolated stars beside the
pair (magnitudes 3, 3.75, 4.5; 35-70 px away across the motion): the single-star widths
that evstar.pairs compares a track's with (study_pairs_companions*: the thirty-third
session's split of unresolved pairs, before and after).

    python perf/study_pairs.py [--rates 4,12] [--seps 2,3,4,5,6,8] [--angles 0,45,90]
        [--companions] [--set estimate.along_blends=false] [--name pairs]

Writes perf/results/study_<name>.json and .md; prints the table.
"""
from __future__ import annotations

import argparse
import json
import math
import pathlib
import sys

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import indep_sim as S  # noqa: E402
from study_field import settings_of  # noqa: E402

from evstar import Config, Pipeline, accuracy  # noqa: E402

RESULTS = pathlib.Path(__file__).resolve().parent / "results"
WIDTH, HEIGHT, FOCAL = 640, 480, 540.0
MOTION_DEG = 20.0          # the motion's direction in the image
MAGS = (3.5, 4.0)
DURATION_S = 0.6


#: --companions: isolated stars (offset across the motion px, magnitude) beside the pair,
#: whose widths tell a single star from a pair (evstar.pairs needs other tracks)
COMPANIONS = ((-50.0, 3.0), (35.0, 3.75), (70.0, 4.5))


def scene(rate, sep, angle, companions=False):
    """The pair's scene: the first star where the whole recording stays inside."""
    a = math.radians(MOTION_DEG + angle)
    travel = math.radians(rate) * FOCAL * DURATION_S
    m = math.radians(MOTION_DEG)
    x0 = WIDTH / 2 - travel / 2 * math.cos(m)
    y0 = HEIGHT / 2 - travel / 2 * math.sin(m)
    stars = [(x0, y0), (x0 + sep * math.cos(a), y0 + sep * math.sin(a))]
    mags = list(MAGS)
    for off, mag in (COMPANIONS if companions else ()):
        stars.append((x0 - off * math.sin(m), y0 + off * math.cos(m)))
        mags.append(mag)
    sc = S.Scene(WIDTH, HEIGHT, FOCAL, stars, mags, S.Linear(rate, MOTION_DEG),
                 S.Gaussian(1.2), DURATION_S, "rotate")
    return sc, S.Sensor(pixel="ideal", noise_hz=1.0)


def run_one(rate, sep, angle, seed, companions=False, settings=None):
    sc, sensor = scene(rate, sep, angle, companions)
    run = S.simulate(sc, sensor, seed=seed)
    cfg = Config().replace(**(settings or {}))
    rows = Pipeline(cfg).run(run.events, run.imu, run.camera).centroids
    star, err = accuracy.match(rows, run.truth)
    ev = run.events
    n = int((ev.t[-1] - ev.t[0]) // cfg.dt_us) + 1
    frames_t = ev.t[0] + (np.arange(n) + 0.5) * cfg.dt_us
    ok = star >= 0
    _, per = accuracy.detection(rows[ok], run.truth, np.arange(n), frames_t, WIDTH, HEIGHT)
    means = [float(err[star == s].mean()) if (star == s).any() else float("nan")
             for s in range(len(sc.mags))]
    return {"rate": rate, "sep_px": sep, "angle_deg": angle, "mean_px": means[:2],
            "companions_max_px": max(means[2:], default=float("nan")),
            "frames_min": float(np.nanmin(per)), "false_per_100": 100 * float((~ok).sum()) / n,
            "tracks": int(len(np.unique(rows["track"][rows["track"] >= 0])))}


def markdown(rows):
    out = ["| °/s | separation px | angle to motion ° | star 3.5 mean px | star 4 mean px | "
           "frames | false/100 | tracks | companions' worst mean px |",
           "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        a, b = r["mean_px"]
        out.append(f"| {r['rate']:g} | {r['sep_px']:g} | {r['angle_deg']:g} | {a:.3f} | {b:.3f} | "
                   f"{100 * r['frames_min']:.0f} % | {r['false_per_100']:.1f} | {r['tracks']} | "
                   f"{r.get('companions_max_px', float('nan')):.3f} |")
    return "\n".join(out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rates", default="4,12")
    ap.add_argument("--seps", default="2,3,4,5,6,8")
    ap.add_argument("--angles", default="0,45,90")
    ap.add_argument("--companions", action="store_true",
                    help="three isolated stars beside the pair (COMPANIONS)")
    ap.add_argument("--name", default="pairs")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="a Config setting, e.g. estimate.along_blends=false (repeatable)")
    a = ap.parse_args(argv)
    rows = []
    for i, (rate, sep, angle) in enumerate((float(r), float(s), float(g))
                                           for r in a.rates.split(",")
                                           for s in a.seps.split(",")
                                           for g in a.angles.split(",")):
        rows.append(run_one(rate, sep, angle, seed=8000 + i, companions=a.companions,
                            settings=settings_of(a.set)))
        print(markdown(rows[-1:]).splitlines()[-1], flush=True)
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / f"study_{a.name}.json").write_text(json.dumps(rows, indent=1) + "\n")
    (RESULTS / f"study_{a.name}.md").write_text(
        "# Close pairs on the independent simulator (perf/study_pairs.py)\n\n" + markdown(rows) + "\n")
    print(markdown(rows))


if __name__ == "__main__":
    main()
