"""Timestamps on a lattice: what a sensor that stamps its events per readout (every event of a
readout of Q µs carries the readout's start time) does to star positions.

Scenes of perf/study_accuracy.py (the default crossings estimator); each run's timestamps
floored to multiples of Q. A floored stamp is on average Q/2 early, so a star is reported
where it was Q/2 after the stamped time: an along-motion offset of speed × Q/2 (positive:
ahead of the star at that time), which no data of a constant-rate run can tell from the
star's own motion (a clock offset); with the IMU, the gyro's clock measurement
(`motion.measure_clock`) takes it as a clock offset of the events against the gyro.

    python perf/study_time_quantization.py [--q 0,100,500,1000]

Writes perf/results/study_time_quantization.json and .md and prints the table.
"""
import argparse
import pathlib

import numpy as np

import study_accuracy as sa
from evstar import Config, Events, Pipeline, accuracy, profiling, sim

RESULTS = pathlib.Path(__file__).resolve().parent / "results"
SCENES = [dict(motion=2, mag=4.5, psf=1.2, sensor="default", comp="none"),
          dict(motion=8, mag=4.0, psf=1.0, sensor="default", comp="none"),
          dict(motion=20, mag=3.5, psf=1.0, sensor="default", comp="none"),
          dict(motion=20, mag=3.5, psf=1.0, sensor="default", comp="imu"),
          dict(motion="sine", mag=4.0, psf=1.0, sensor="default", comp="imu")]
COLUMNS = [("scene", "scene", ""), ("q_us", "Q µs", ""), ("speed", "median speed px/s", ".0f"),
           ("expected", "speed × Q/2 px", ".3f"), ("along", "along offset px (median)", "+.3f"),
           ("mean", "mean px", ".3f"), ("max", "max px", ".2f")]


def run(s, q_us, seed=3):
    r = sim.simulate(sa.scenario({**s, "set": "q", "seed": seed}), seed=seed)
    ev = r.events
    if q_us:
        ev = Events(ev.t // q_us * q_us, ev.x, ev.y, ev.p, ev.width, ev.height)
    rows = Pipeline(Config().replace(**{"motion.compensate": s["comp"]})).run(
        ev, r.imu, r.camera).centroids
    star, err = accuracy.match(rows, r.truth.star_position)
    rows, err = rows[star >= 0], err[star >= 0]
    t = rows["t"].astype(np.int64)
    v = (r.truth.star_position(t + 500)[:, 0] - r.truth.star_position(t - 500)[:, 0]) / 1e-3
    speed = np.hypot(v[:, 0], v[:, 1])
    moving = speed > 1.0
    u = v[moving] / speed[moving, None]
    off = np.column_stack([rows["x"], rows["y"]])[moving] - r.truth.star_position(t)[:, 0][moving]
    return {"speed": float(np.median(speed)), "along": float(np.median((off * u).sum(1))),
            "mean": float(err.mean()), "max": float(err.max()),
            "expected": float(np.median(speed)) * q_us * 1e-6 / 2}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--q", default="0,100,500,1000", help="lattice steps (µs) to floor the stamps to")
    a = ap.parse_args()
    rows = []
    for s in SCENES:
        name = f"{s['motion']}{' °/s' if s['motion'] != 'sine' else ''}, mag {s['mag']}, {s['comp']}"
        for q in (int(v) for v in a.q.split(",")):
            rows.append({"scene": name, "q_us": q, **run(s, q)})
            print(profiling.table(rows[-1:], COLUMNS).splitlines()[-1], flush=True)
    profiling.write_results(RESULTS / "study_time_quantization.json", rows, vars(a))
    text = profiling.table(rows, COLUMNS)
    (RESULTS / "study_time_quantization.md").write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
