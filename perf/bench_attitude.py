"""Cost of the attitude filter: one prediction, one joint update (m stars), and the whole
estimator at 1 kHz output.

The steps are the numpy MEKF (evstar.attitude.filter), timed alone; the estimator runs on
synthetic centroids of Hipparcos stars (evstar.attitude.oracle.synthetic_run: 10 ms frames,
DAVIS346 behind 16 mm, 10 °/s pan, truth identification) with and without the IMU, at
--rate-hz 1000: seconds per second of data (below 1: faster than real time) and output
rows/s. Writes perf/results/bench_attitude.json and prints a table.

    python perf/bench_attitude.py [--repeats 5]
"""
from __future__ import annotations

import argparse
import pathlib

import numpy as np

from evstar import sim
from evstar.attitude import AttitudeEstimator, Mekf
from evstar.attitude.filter import exp_so3
from evstar.attitude.oracle import synthetic_run, truth_identifier
from evstar.profiling import table, time_call, write_results

OUT = pathlib.Path(__file__).parent / "results" / "bench_attitude.json"


def filter_for(mode, rng):
    n = 6 if mode == "rate" else 3
    return Mekf(exp_so3(rng.normal(size=3)), 0.1 * rng.normal(size=n), np.eye(n + 3) * 1e-6, mode,
                gyro_noise=2e-4, bias_walk=1e-4, jerk_noise=10.0)


def step_rows(repeats):
    rng = np.random.default_rng(0)
    rows = []
    for mode in ("rate", "imu"):
        f = filter_for(mode, rng)
        gyro = rng.normal(size=3)
        t = time_call(lambda: [f.predict(1e-3, gyro) for _ in range(100)], repeats)["median_s"] / 100
        rows.append(dict(what=f"predict ({mode})", stars="—", us=t * 1e6, per_s=1 / t))
        for m in (10, 30, 60):
            d = (f.R @ np.c_[rng.uniform(-0.2, 0.2, (m, 2)), np.ones(m)].T).T
            d /= np.linalg.norm(d, axis=1, keepdims=True)
            z = -f.residuals(np.zeros((m, 2)), d)[0]
            sig, dt = np.full((m, 2), 1e-4), rng.uniform(-2e-3, 0, m)
            rates = None if mode == "rate" else np.tile(gyro, (m, 1))

            def update():
                g = f.copy()
                g.update(z, d, sig, dt, rates, gate=5.0)

            t = time_call(update, repeats)["median_s"]
            rows.append(dict(what=f"update ({mode}, gated)", stars=m, us=t * 1e6, per_s=1 / t))
    return rows


def estimator_rows(repeats):
    cam = sim.camera_preset("davis346", 16.0)
    traj = sim.ConstantRate(10.0, R0=sim.attitude_from_radec(83.8, -5.4))
    c, truth, imu = synthetic_run(traj, cam, 1.0, sigma_px=0.05, mag_limit=6.0)
    n_stars = float(np.median(np.bincount(c["frame"])))
    rows = []
    for name, use in (("no IMU", None), ("IMU 1 kHz", imu)):
        est = AttitudeEstimator(cam, use, rate_hz=1000, identifier=truth_identifier(truth))
        out = []
        t = time_call(lambda: out.append(est.run(c)), max(1, repeats // 2))["median_s"]
        rows.append(dict(what=f"estimate, 1 kHz rows, {name}", stars=n_stars, us=t * 1e6,
                         per_s=len(out[-1]) / t, realtime=t / 1.0))
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    rows = step_rows(args.repeats) + estimator_rows(args.repeats)
    print(table(rows, [("what", "step", ""), ("stars", "stars", ""), ("us", "µs per call", ".0f"),
                       ("per_s", "calls (rows) / s", ",.0f"), ("realtime", "s per s of data", ".2f")]))
    write_results(OUT, rows, dict(note="numpy MEKF on one CPU core; estimator: synthetic centroids, "
                                       "100 frames/s, truth identification"))
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
