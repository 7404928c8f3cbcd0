"""One scene of perf/study_accuracy.py over several seeds: how much a row's figures owe to
its one seed (the default crossings estimator; mean / max error px, frames with a position,
false rows per 100 frames).

    python perf/study_seeds.py [--motion 1] [--mag 4] [--psf 1.5] [--sensor default]
        [--comp none] [--seeds 7-14] [--refractory-us 0] [--amplitude 10 --duration 1]   (--motion sine)

Writes perf/results/study_seeds_<scene>.json and .md (e.g. study_seeds_1dps_mag4_psf1.5_default_none).
"""
import argparse
import pathlib

import numpy as np

import study_accuracy as sa
from evstar import Config, Pipeline, profiling, sim

RESULTS = pathlib.Path(__file__).resolve().parent / "results"
COLUMNS = [("seed", "seed", ""), ("events_per_frame", "events/frame", ".0f"), ("mean", "mean px", ".3f"),
           ("max", "max px", ".2f"), ("frames_pct", "frames %", ".0f"), ("false_per_100", "false /100", ".1f")]


def run_seed(s):
    run = sim.simulate(sa.scenario(s), seed=s["seed"])
    ev = run.events
    cfg = Config().replace(**{"motion.compensate": s["comp"],
                              "estimate.refractory_us": s.get("refractory_us", 0.0)})
    res = Pipeline(cfg).run(ev, run.imu, run.camera)
    t0 = int(ev.t[0])
    n_frames = int((ev.t[-1] - t0) // cfg.dt_us) + 1
    frames_t = t0 + (np.arange(n_frames) + 0.5) * cfg.dt_us
    sc = sa.scores(res.centroids, run.truth, frames_t, run.camera, n_frames)
    return {"seed": s["seed"], "events_per_frame": float((run.truth.labels >= 0).sum() / n_frames),
            "mean": sc["mean"], "max": sc["max"], "frames_pct": 100 * sc["frames"],
            "false_per_100": sc["false_per_100"]}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--motion", default="1", help="°/s, or sine")
    ap.add_argument("--mag", type=float, default=4.0)
    ap.add_argument("--psf", type=float, default=1.5)
    ap.add_argument("--sensor", default="default", choices=sorted(sa.SENSORS))
    ap.add_argument("--comp", default="none", choices=("none", "imu"))
    ap.add_argument("--amplitude", type=float, default=10.0,
                    help="the sinusoid's amplitude, ° (1 Hz; with --motion sine)")
    ap.add_argument("--duration", type=float, default=1.0, help="the sinusoid's span, s")
    ap.add_argument("--seeds", default="7-14", help="first-last")
    ap.add_argument("--refractory-us", type=float, default=0.0,
                    help="tell the estimator the sensor's refractory period (the simulator's: 100)")
    a = ap.parse_args()
    first, last = (int(v) for v in a.seeds.split("-"))
    motion = a.motion if a.motion == "sine" else float(a.motion)
    rows = [run_seed(dict(motion=motion, mag=a.mag, psf=a.psf, sensor=a.sensor, comp=a.comp,
                          seed=seed, refractory_us=a.refractory_us, amplitude=a.amplitude,
                          duration=a.duration))
            for seed in range(first, last + 1)]
    text = profiling.table(rows, COLUMNS)
    motion_name = (f"sine{a.amplitude:g}deg{a.duration:g}s" if (a.amplitude, a.duration) != (10.0, 1.0)
                   else "sine") if a.motion == "sine" else f"{a.motion}dps"
    name = f"study_seeds_{motion_name}_mag{a.mag:g}_psf{a.psf:g}_{a.sensor}_{a.comp}"
    name += f"_refractory{a.refractory_us:g}" if a.refractory_us else ""
    profiling.write_results(RESULTS / f"{name}.json", rows, vars(a))
    (RESULTS / f"{name}.md").write_text(f"# {vars(a)}\n\n{text}\n")
    print(text)


if __name__ == "__main__":
    main()
