"""A star field with close pairs on the independent simulator (perf/indep_sim.py).

evstar's own field studies (perf/study_field.py) use its simulator and Hipparcos. This one
draws a field on the independent simulator — its sensor models, PSFs and pixel physics
are not evstar's — so that close pairs, along and across the motion, are seen on sensors
the estimator was not written on. Per scene: SINGLES random stars (magnitudes 3–5) and
PAIRS pairs (the primary 3–4.5, the secondary 0.3–1.5 magnitudes fainter, 2–5 px apart,
the line joining them at a random angle to the motion) on a VGA sensor behind f 540 px,
turning at a constant rate for DURATION_S; every star stays in view. Each scene runs
through the default pipeline and once more with each --set (default: the blends step
off), so the two columns differ by that setting alone.

Per scene: the isolated stars' median error (no other star within 10 px), the pairs'
primaries' median error, split into pairs within 30° of the motion ("along") and the rest,
the pairs' secondaries found (matched in ≥ half the frames), and false rows (matching no
star within 3 px).

    python perf/study_indep_field.py [--seeds 9001] [--set estimate.along_blends=false]
        [--name indep_field]

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
from study_indep import SENSORS  # noqa: E402

from evstar import Config, Pipeline, accuracy  # noqa: E402

RESULTS = pathlib.Path(__file__).resolve().parent / "results"
WIDTH, HEIGHT, FOCAL = 640, 480, 540.0
SINGLES, PAIRS, DURATION_S = 30, 12, 1.0
#: (sensor of study_indep.SENSORS, rate °/s, motion direction °, PSF)
GRID = [
    ("ideal", 6, 20, S.Gaussian(1.0)),
    ("ideal", 15, 200, S.Gaussian(1.4)),
    ("coarse", 6, 70, S.Gaussian(1.4)),
    ("coarse", 15, 10, S.Gaussian(1.0)),
    ("fine", 6, 250, S.Gaussian(1.0)),
    ("fine", 15, 130, S.Gaussian(1.4)),
    ("jittery", 12, 45, S.Gaussian(1.2)),
    ("ideal", 10, 300, S.Moffat(3.0, 3.0)),
]
COLUMNS = ("sensor", "°/s", "PSF", "seed", "isolated median px", "pairs along: n / median px",
           "pairs other: n / median px", "secondaries found", "false rows %")


def field(rate, direction, seed):
    """(start positions, magnitudes, pairs [(primary, secondary, angle to motion °)])."""
    rng = np.random.default_rng(seed)
    travel = math.radians(rate) * FOCAL * DURATION_S
    u = np.array([math.cos(math.radians(direction)), math.sin(math.radians(direction))])
    lo = np.maximum(12 - travel * u, 12)
    hi = np.minimum(np.array([WIDTH, HEIGHT]) - 12 - travel * u, [WIDTH - 12, HEIGHT - 12])
    xy, mags, pairs = [], [], []
    for _ in range(SINGLES):
        xy.append(rng.uniform(lo, hi))
        mags.append(rng.uniform(3.0, 5.0))
    for _ in range(PAIRS):
        p = rng.uniform(lo + 6, hi - 6)
        angle = rng.uniform(0, 90)
        a = math.radians(direction + angle * rng.choice([-1, 1]))
        sep = rng.uniform(2.0, 5.0)
        m = rng.uniform(3.0, 4.5)
        pairs.append((len(xy), len(xy) + 1, angle))
        xy += [p, p + sep * np.array([math.cos(a), math.sin(a)])]
        mags += [m, m + rng.uniform(0.3, 1.5)]
    return [tuple(v) for v in xy], mags, pairs


def run_scene(sensor, rate, direction, psf, seed, settings):
    xy, mags, pairs = field(rate, direction, seed)
    scene = S.Scene(WIDTH, HEIGHT, FOCAL, xy, mags, S.Linear(rate, direction), psf,
                    DURATION_S, "rotate")
    run = S.simulate(scene, S.Sensor(noise_hz=1.0, **SENSORS[sensor]), seed=seed)
    out = []
    for s in ({}, settings):
        rows = Pipeline(Config().replace(**s)).run(run.events, run.imu, run.camera).centroids
        out.append(_scores(rows, run, np.array(xy), pairs))
    return {"sensor": sensor, "rate": rate, "psf": psf.label(), "seed": seed,
            "default": out[0], "set": out[1]}


def _scores(rows, run, xy, pairs):
    star, err = accuracy.match(rows, run.truth)
    frames = np.unique(rows["frame"])
    mean = {s: float(err[star == s].mean()) for s in np.unique(star[star >= 0])}
    found = {s: len(np.unique(rows["frame"][star == s])) >= 0.5 * len(frames) for s in mean}
    gap = np.hypot(*(xy[:, None] - xy[None]).transpose(2, 0, 1))
    np.fill_diagonal(gap, np.inf)
    iso = [mean[s] for s in mean if gap[s].min() > 10]
    along = [mean.get(a, np.nan) for a, _, ang in pairs if ang < 30]
    other = [mean.get(a, np.nan) for a, _, ang in pairs if ang >= 30]
    return {"isolated": float(np.median(iso)), "along": along, "other": other,
            "secondaries": int(sum(found.get(b, False) for _, b, _ in pairs)),
            "false_pct": 100 * float((star < 0).mean())}


def markdown(rows, label):
    lines = ["| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    for r in rows:
        cells = []
        for key in ("default", "set"):
            s = r[key]
            cells.append([f"{s['isolated']:.3f}",
                          f"{len(s['along'])} / {np.nanmedian(s['along']):.3f}",
                          f"{len(s['other'])} / {np.nanmedian(s['other']):.3f}",
                          f"{s['secondaries']} of {PAIRS}", f"{s['false_pct']:.1f}"])
        lines.append(f"| {r['sensor']} | {r['rate']:g} | {r['psf']} | {r['seed']} | " +
                     " | ".join(f"{a} ({label}: {b})" if a != b else a
                                for a, b in zip(*cells)) + " |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="9001", help="comma-separated field seeds")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="the second run's Config setting (repeatable; default: "
                    "estimate.along_blends=false)")
    ap.add_argument("--name", default="indep_field")
    a = ap.parse_args(argv)
    settings = settings_of(a.set or ["estimate.along_blends=false"])
    label = ", ".join(a.set or ["estimate.along_blends=false"])
    rows = []
    for seed in (int(s) for s in a.seeds.split(",")):
        for i, (sensor, rate, direction, psf) in enumerate(GRID):
            rows.append(run_scene(sensor, rate, direction, psf, seed * 100 + i, settings))
            print(markdown(rows[-1:], label).splitlines()[-1], flush=True)
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / f"study_{a.name}.json").write_text(json.dumps(rows, indent=1) + "\n")
    (RESULTS / f"study_{a.name}.md").write_text(
        f"# A star field with close pairs on the independent simulator (perf/study_indep_field.py; "
        f"in brackets: with {label})\n\n" + markdown(rows, label) + "\n")
    print(markdown(rows, label))


if __name__ == "__main__":
    main()
