"""How a polarity-imbalanced background moves the stars along their motion.

A background ON event just before a pixel's ON run can join the run (evstar.crossings
keeps an outermost event within 5x the passage's largest inside gap), which moves the
deepest level pair's rising time early; an OFF event just after its OFF run moves the
falling time late. With as many ON as OFF background events the two cancel in the
midpoints; with more of one they do not. Found on perf/study_indep.py --fresh2's G1 (5 Hz,
60 % ON): every star 0.047 px ahead.

Each row: one scene of perf/study_indep.py (its stars, motion, PSF, sensor) with the
background's rate and ON fraction replaced; the default pipeline (no IMU); mean error and
the signed mean error along the motion (+ ahead) of the rows matched to a star within 3 px.

    python perf/study_noise_polarity.py [--scenes G1,F6] [--rates 0.5,2,5] [--on 0.2,0.5,0.8]

Writes perf/results/study_noise_polarity.json and .md; prints the table.
"""
from __future__ import annotations

import argparse
import dataclasses
import pathlib
import sys

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import indep_sim as S  # noqa: E402
import study_indep as SI  # noqa: E402

from evstar import Config, Pipeline, profiling  # noqa: E402

RESULTS = pathlib.Path(__file__).resolve().parent / "results"
COLUMNS = [("scene", "scene", ""), ("noise_hz", "background Hz", "g"), ("on", "ON fraction", "g"),
           ("mean_px", "mean px", ".3f"), ("along_px", "along px (+ ahead)", "+.3f"),
           ("rows", "rows", "")]


def errors(rows, truth):
    """(mean error, mean signed error along the motion) of the rows within 3 px of a star."""
    t = rows["t"].astype(np.float64)
    pos, later = truth(t), truth(t + 1000.0)
    xy = np.stack([rows["x"], rows["y"]], axis=1)
    dist = np.hypot(*(pos - xy[:, None]).transpose(2, 0, 1))
    star = np.argmin(np.where(np.isfinite(dist), dist, np.inf), axis=1)
    i = np.arange(len(rows))
    ok = dist[i, star] < 3
    v = later[i, star] - pos[i, star]
    u = v / np.maximum(np.linalg.norm(v, axis=1), 1e-12)[:, None]
    along = np.sum((xy - pos[i, star]) * u, axis=1)
    return float(dist[i, star][ok].mean()), float(along[ok].mean()), int(ok.sum())


def run(label, rate_hz, on_fraction):
    seed, spec = SI.held_out_scene(label)
    scene, sensor = SI.scene_of(seed, spec)
    sensor = dataclasses.replace(sensor, noise_hz=rate_hz, noise_on_fraction=on_fraction)
    sim = S.simulate(scene, sensor, seed=seed)
    res = Pipeline(Config()).run(sim.events, sim.imu, sim.camera)
    mean, along, n = errors(res.centroids, sim.truth)
    return {"scene": label, "noise_hz": rate_hz, "on": on_fraction, "mean_px": mean,
            "along_px": along, "rows": n}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", default="G1,F6")
    ap.add_argument("--rates", default="0.5,2,5", help="background rates, Hz per pixel")
    ap.add_argument("--on", default="0.2,0.5,0.8", help="ON fractions of the background")
    a = ap.parse_args(argv)
    rows = [run(s, float(r), float(f)) for s in a.scenes.split(",")
            for r in a.rates.split(",") for f in a.on.split(",")]
    text = profiling.table(rows, COLUMNS)
    profiling.write_report(RESULTS, "study_noise_polarity", rows,
                           "Stars' along-motion error against the background's rate and ON "
                           "fraction", text, vars(a))
    print(text)


if __name__ == "__main__":
    main()
