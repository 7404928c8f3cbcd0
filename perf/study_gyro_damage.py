"""Star positions from a damaged gyro record, repaired (evstar.gyro_repair) and not.

Per scene of evstar's simulator, the same events run with `--compensate imu` on the clean
gyro and on damaged copies of it — sample gaps, samples lost at random, runs of samples
many times too large — with `motion.repair_gyro` on (the default) and off; `--compensate
none` beside them as the run that trusts no gyro. Mean and max error (px) of the rows
matched to the star, and false rows (matched to none) per 100 frames.

The repair was developed on the first scene (the paper's sinusoid, seed 3, a 100 ms gap
and ten 50x samples); the other scenes and damages were written after it and run once.

    python perf/study_gyro_damage.py [--name NAME]

Writes perf/results/study_gyro_damage[_NAME].json and .md.
"""
import argparse
import json
import pathlib
import warnings

import numpy as np

from evstar import Config, Imu, Pipeline, accuracy, sim
from evstar.errors import EvstarWarning
from evstar.sim.imu_model import ImuSpec

RESULTS = pathlib.Path(__file__).parent / "results"


def scenes():
    """(label, Simulation): the development scene first, then held-out ones."""
    yield "dev: sinusoid 10°/1 Hz mag 4, seed 3", sim.simulate(
        sim.paper_sinusoid(10.0, 1.0, duration_s=1.0, magnitude=4.0), seed=3)
    yield "sinusoid 5°/2 Hz mag 3.5, seed 21", sim.simulate(
        sim.paper_sinusoid(5.0, 2.0, duration_s=1.0, magnitude=3.5), seed=21)
    yield "8 °/s mag 4, seed 22", sim.simulate(
        sim.paper_preset(8.0, duration_s=1.0, magnitude=4.0), seed=22)
    yield "dark-sky sinusoid 10°/1 Hz mag 3, seed 23", sim.simulate(
        sim.paper_sinusoid(10.0, 1.0, duration_s=1.0, magnitude=3.0,
                           sensor=sim.sensor_model("dark-sky")), seed=23)
    yield "sinusoid 10°/1 Hz mag 4, 200 Hz gyro, seed 24", sim.simulate(
        sim.paper_sinusoid(10.0, 1.0, duration_s=1.0, magnitude=4.0,
                           imu=ImuSpec(rate_hz=200.0)), seed=24)


def damages(imu):
    """(label, Imu) of the clean record and damaged copies."""
    t, g = imu.t, imu.gyro
    t0 = int(t[0])
    rng = np.random.default_rng(5)

    def keep(mask, gyro=g):
        return Imu(t[mask], gyro[mask], imu.accel[mask], R_cam_imu=imu.R_cam_imu,
                   time_offset_us=imu.time_offset_us)

    def gap(start_ms, length_ms):
        rel = t - t0
        return keep((rel < start_ms * 1000) | (rel > (start_ms + length_ms) * 1000))

    def scaled(starts, n, factor):
        out = g.copy()
        for s in starts:
            out[s:s + n] *= factor
        return keep(np.ones(len(t), bool), out)

    n = len(t)
    yield "clean", imu
    yield "gap 100 ms at 0.4 s", gap(400, 100)
    yield "gap 50 ms at 0.7 s", gap(700, 50)
    yield "gap 250 ms at 0.2 s", gap(200, 250)
    yield "30 % lost at random", keep(rng.random(n) >= 0.3)
    yield "10 samples x50 at 0.3 s", scaled([int(0.3 * n)], 10, 50.0)
    yield "20 single samples x30", scaled(rng.choice(np.arange(5, n - 5), 20, replace=False), 1, 30.0)
    yield "5 runs of 3 samples x5", scaled(rng.choice(np.arange(5, n - 5), 5, replace=False), 3, 5.0)


def score(run, imu, compensate, repair):
    cfg = Config().replace(**{"motion.compensate": compensate, "motion.repair_gyro": repair})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", EvstarWarning)
        res = Pipeline(cfg).run(run.events, imu, run.camera)
    star, err = accuracy.match(res.centroids, run.truth.star_position)
    ok = star >= 0
    frames = max(len(np.unique(res.centroids["frame"])), 1)
    return {"mean": round(float(err[ok].mean()), 4) if ok.any() else None,
            "max": round(float(err[ok].max()), 3) if ok.any() else None,
            "false_per_100": round(100.0 * np.count_nonzero(~ok) / frames, 1)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--name", default="")
    args = ap.parse_args(argv)
    rows = []
    for label, run in scenes():
        none = score(run, None, "none", True)
        for damage, imu in damages(run.imu):
            rows.append({"scene": label, "damage": damage, "none": none,
                         "repaired": score(run, imu, "imu", True),
                         "as_is": score(run, imu, "imu", False)})
            print(_line(rows[-1]), flush=True)
    stem = "study_gyro_damage" + (f"_{args.name}" if args.name else "")
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / f"{stem}.json").write_text(json.dumps(rows, indent=1))
    (RESULTS / f"{stem}.md").write_text(markdown(rows))
    print(markdown(rows))


def _cell(s):
    mean = "—" if s["mean"] is None else f"{s['mean']:.3f}"
    top = "—" if s["max"] is None else f"{s['max']:.2f}"
    return f"{mean} / {top} / {s['false_per_100']:.1f}"


def _line(r):
    return f"{r['scene']:48s} {r['damage']:26s} as is {_cell(r['as_is'])}  repaired {_cell(r['repaired'])}"


def markdown(rows):
    out = ["Mean px / max px / false rows per 100 frames, `--compensate imu` with the gyro "
           "record as it is and repaired (motion.repair_gyro), and `--compensate none`.", "",
           "| scene | gyro record | imu, as is | imu, repaired | none |", "|---|---|---|---|---|"]
    out += [f"| {r['scene']} | {r['damage']} | {_cell(r['as_is'])} | {_cell(r['repaired'])} "
            f"| {_cell(r['none'])} |" for r in rows]
    return "\n".join(out) + "\n"


if __name__ == "__main__":
    main()
