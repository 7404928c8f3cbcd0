"""Attitude study: the event-based MEKF against an APS-like baseline, versus angular rate.

For each camera preset (DAVIS346 behind 16 mm, f ≈ 865 px; EVK4 behind 12 mm, f ≈ 2469 px),
each motion (constant pan 0, 5, 10, 20, 30 °/s about the image's up axis, and the paper's
10°/1 Hz sinusoid) over a Hipparcos field (Orion, mag <= 6, ICRS), the simulator's events go
through evstar.Pipeline (defaults) and evstar.attitude.estimate, with and without the IMU;
identification is evstar.attitude.identify (plate solver) when available, else the truth
oracle (evstar.attitude.oracle). Errors against the simulator's true attitude at every
10 ms output: cross-boresight (arcsec; px = angle x focal length) and about-boresight
(arcsec; px = angle x half the sensor diagonal), time to first fix, fraction of frames
after the first fix with an attitude.

APS-like baseline: a frame camera with the same optics, one 100 ms exposure per fix
(10 Hz); each star's centroid is that of its streak (the mean of its true image positions
over the exposure) plus noise growing with the streak length, a star being detected while
its peak pixel signal (flux spread along the streak) stays above a threshold; the fix is
the Wahba solution at mid-exposure, held (no IMU) or carried by the gyro (IMU) until the
next one; errors at the same 10 ms outputs.

    python perf/study_attitude.py [--quick]

Writes perf/results/study_attitude.json, .md and .png; prints the table.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import pathlib
import pickle
import sys
import time

import numpy as np

import evstar
from evstar import sim
from evstar.attitude import estimate, rotation, wahba
from evstar.attitude.oracle import truth_identifier

RESULTS = pathlib.Path(__file__).parent / "results"
CACHE = pathlib.Path(os.environ.get("EVSTAR_STUDY_CACHE", "/tmp/evstar_study_attitude"))
CAMERAS = {"davis346": 16.0, "evk4": 12.0}          # preset -> focal length, mm
MOTIONS = ("0", "5", "10", "20", "30", "sine")
POINTING = (83.8, -5.4)                              # Orion: ra, dec (deg)
MAG_LIMIT = 6.0
DURATION_S = 1.0
ARCSEC = math.pi / 180 / 3600


def trajectory(motion):
    R0 = sim.attitude_from_radec(*POINTING)
    if motion == "sine":
        return sim.Sinusoid(10.0, 1.0, R0=R0)
    return sim.ConstantRate(float(motion), R0=R0)


def scene(camera_name, motion, seed=1):
    """(centroids, truth, imu) of one simulated run, cached on disk."""
    path = CACHE / f"{camera_name}-{motion}-{seed}.pkl"
    if path.exists():
        return pickle.loads(path.read_bytes())
    cam = sim.camera_preset(camera_name, CAMERAS[camera_name])
    traj = trajectory(motion)
    stars = sim.hipparcos_field_along(cam, traj, DURATION_S, mag_limit=MAG_LIMIT)
    run = sim.simulate(sim.Scenario(cam, stars, traj, DURATION_S), seed=seed)
    res = evstar.Pipeline(evstar.Config()).run(run.events, run.imu, run.camera)
    out = (res.centroids, run.truth, run.imu)
    CACHE.mkdir(parents=True, exist_ok=True)
    path.write_bytes(pickle.dumps(out))
    return out


if __name__ == "__main__":
    for cam in sys.argv[1:]:
        for m in MOTIONS:
            t = time.time()
            c, truth, imu = scene(cam, m)
            print(cam, m, len(c), len(truth.stars), f"{time.time() - t:.1f} s", flush=True)
